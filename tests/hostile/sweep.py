"""The hostile sweep of issue 33: every surface a user's file or setting reaches, probed with what
breaks programs, each probe judged the same way.

A probe is one command line (:class:`Probe`) run through :func:`pencilbot.cli.main` in a child
process (:func:`run`) under a 2 GB address-space limit, with an alarm for each probe: a probe that
hangs is stopped by its alarm and counted, and the child goes on with the next. A probe fails when
it raises out of ``main`` or prints a traceback, hangs, exits 0 where its input is wrong, prints
anything but one ``pencilbot: error:`` line when it refuses, or changes a file it must leave (an
input, a FIFO or a device named as output, an output left after a refusal). Everything else is a
clean error, or a correct run where the input is right.

:func:`probes` builds the surfaces in a folder: CLI commands × bad files (FIFO, device, folder,
empty, sparse 20 GB, a name that is not UTF-8, a truncated image, FIFO and device outputs);
G-code lines (system commands, jogs on and off the bed, numbers too long for a float, NUL and
non-ASCII bytes); HP-GL (pens, speeds, coordinates); profiles (every numeric key of a G-code, an
EBB and an HP-GL profile out of range, templates the board rejects); and the settings a user can
break (``PENCILBOT_PROFILE``, ``config.toml``). ``bench/hostile.py`` runs them all; the CI runs a
sample (``tests/hostile/test_sweep.py``).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import resource
import stat
import subprocess
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image
from profile_tables import shipped_table, toml_text

LIMIT = 2 << 30  # bytes of address space the child may have
SECONDS = 20  # a probe running longer has hung (the slowest clean one takes about 3 s)


@dataclass
class Probe:
    """One command line of the sweep.

    ``surface`` is what it probes ("files", "gcode lines", "hpgl", "profiles", "settings"),
    ``name`` what it is; ``argv`` the command line (paths relative to the folder), run with ``env``;
    ``good``: the input is right and the run must succeed (else it must be refused); ``keep``:
    paths that must be as they were afterwards (content, or kind of file); ``absent``: paths that
    must not exist afterwards (an output after a refusal).
    """

    surface: str
    name: str
    argv: list[str]
    good: bool = False
    env: dict[str, str] = field(default_factory=dict)
    keep: list[str] = field(default_factory=list)
    absent: list[str] = field(default_factory=list)


_RUNNER = r"""
import contextlib, io, json, os, signal, sys, traceback
class Hang(BaseException):
    pass
def alarm(signum, frame):
    raise Hang()
signal.signal(signal.SIGALRM, alarm)
from pencilbot.cli import main
folder, seconds = sys.argv[1], float(sys.argv[2])
sys.path[:0] = [sys.argv[3], os.path.dirname(sys.argv[3])]
from sweep import state
for line in sys.stdin:
    case = json.loads(line)
    os.chdir(folder)
    saved = {k: os.environ.get(k) for k in case["env"]}
    os.environ.update(case["env"])
    err, out = io.StringIO(), io.StringIO()
    escaped, hung = "", False
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        signal.setitimer(signal.ITIMER_REAL, seconds)
        try:
            code = main(case["argv"])
        except Hang:
            code, hung = -1, True
        except BaseException:
            code, escaped = -1, traceback.format_exc()
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
    for k, v in saved.items():
        os.environ.pop(k, None) if v is None else os.environ.__setitem__(k, v)
    kept = {p: state(p) for p in case["keep"]}
    left = [p for p in case["absent"] if os.path.exists(p)]
    for p in case["clean"]:  # the next probe starts without this one's output
        if os.path.isfile(p) and not os.path.islink(p):
            os.unlink(p)
    print(json.dumps({"code": code, "err": err.getvalue()[-4000:], "escaped": escaped[-4000:], "hung": hung,
                      "kept": kept, "left": left}), flush=True)
    if hung or escaped:
        break  # a probe stopped half-way may leave the process broken (a module half imported): a new one goes on
"""


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT, LIMIT))


def state(path) -> list | None:
    """What a kept path is, in the child right after each probe and here before any: its kind
    and, for a file, its size and a digest of its head (None: absent); JSON's lists."""
    try:
        info = os.lstat(path)
    except OSError:
        return None
    if stat.S_ISREG(info.st_mode):
        with open(path, "rb") as handle:
            return ["file", info.st_size, hashlib.sha256(handle.read(1 << 20)).hexdigest()]
    return [stat.S_IFMT(info.st_mode), info.st_rdev]


def run(probes: list[Probe], folder: Path, seconds: float = SECONDS) -> list[dict]:
    """Run ``probes`` in a child process (a new one after a probe that hangs, raises or kills it); each result is the probe's fields, ``code``, ``err``,
    ``verdict`` ("clean error", "correct" or "failure") and ``why`` (for a failure)."""
    kept = {p: state(folder / p) for probe in probes for p in probe.keep}
    env = {
        **os.environ,
        "PYTHONFAULTHANDLER": "0",
        "OPENBLAS_NUM_THREADS": "1",
        "OMP_NUM_THREADS": "1",
        "PENCILBOT_CONFIG_DIR": str(folder / "config"),
    }
    env.pop("PENCILBOT_PROFILE", None)
    cases = [
        json.dumps(
            {
                "argv": p.argv,
                "env": p.env,
                "keep": p.keep,
                "absent": p.absent,
                "clean": [*p.absent, *_OUTPUTS],
            }
        )
        for p in probes
    ]
    child = [sys.executable, "-c", _RUNNER, str(folder), str(seconds), str(Path(__file__).parent)]
    answers: list[dict] = []
    while len(answers) < len(probes):  # a child per run of probes up to one that hangs, raises or kills it
        proc = subprocess.run(
            child,
            input="".join(c + "\n" for c in cases[len(answers) :]),
            text=True,
            check=False,
            capture_output=True,
            preexec_fn=_limit_memory,
            env=env,
            cwd=folder,
            timeout=seconds * (len(probes) - len(answers)) + 120,
            errors="surrogateescape",
        )
        lines = [json.loads(line) for line in proc.stdout.splitlines()]
        answers += lines or [
            {"code": None, "err": proc.stderr[-2000:], "escaped": "", "hung": False, "kept": {}, "left": []}
        ]
    results = []
    for probe, result in zip(probes, answers):
        result.update(asdict(probe))
        result["why"] = _judge(probe, result, kept)
        result["verdict"] = "failure" if result["why"] else "correct" if probe.good else "clean error"
        results.append(result)
    return results


_OUTPUTS = ("o.png", "o.svg", "o.gcode", "o.hpgl")


def _judge(probe: Probe, result: dict, kept: dict) -> str:
    """Why the probe failed ("" if it did not)."""
    err, code = result["err"], result["code"]
    if code is None:
        return "the child process died (" + (err.strip().splitlines() or ["no output"])[-1] + ")"
    if result["hung"]:
        return "hung (stopped by its alarm)"
    if result["escaped"] or "Traceback" in err:
        return "traceback: " + (result["escaped"] or err).strip().splitlines()[-1]
    changed = [p for p in probe.keep if result.get("kept", {}).get(p) != kept[p]]
    if changed:
        return f"changed or replaced {', '.join(changed)}"
    if probe.good:
        return "" if code == 0 else f"refused a right input (exit {code}): {err.strip()[-300:]}"
    if code == 0:
        return "exit 0 on a wrong input"
    if result.get("left"):
        return f"left {', '.join(result['left'])} behind after refusing"
    # What a terminal shows: a progress bar's line overwritten (\r) by the message.
    shown = [line.rsplit("\r", 1)[-1] for line in err.strip().split("\n")]
    lines = [line for line in shown if line.strip() and not line.startswith("WARNING")]
    if len(lines) != 1 or not lines[0].startswith("pencilbot: error: "):
        return f"not one error line: {err.strip()[-300:]!r}"
    return ""


def counts(results: list[dict]) -> dict:
    """Per surface: probes, clean errors, correct runs, failures (and the failures' names)."""
    out: dict[str, dict] = {}
    for r in results:
        row = out.setdefault(
            r["surface"], {"probes": 0, "clean errors": 0, "correct": 0, "failures": 0, "failed": []}
        )
        row["probes"] += 1
        key = {"failure": "failures", "correct": "correct", "clean error": "clean errors"}[r["verdict"]]
        row[key] += 1
        if r["verdict"] == "failure":
            row["failed"].append(f"{r['name']}: {r['why']}")
    return out


# --- the surfaces ------------------------------------------------------------------------------

_SVG = (
    '<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="60mm" viewBox="0 0 60 60">'
    '<path d="M 5 5 L 40 40 L 50 10" stroke="black"/><path d="M 10 50 L 30 20" stroke="black"/></svg>'
)
_GCODE = "G21\nG90\nM3 S30\nG0 X10 Y10\nM3 S90\nG1 X20 Y10 F1000\nG1 X20 Y20\nM3 S30\n"
_HPGL = "IN;SP1;PU400,400;PD800,400,800,800;PU;SP0;\n"


def _files(folder: Path) -> None:
    """The good inputs, and every bad kind of file, in ``folder``."""
    (folder / "config").mkdir(exist_ok=True)
    rng = np.random.default_rng(7)
    Image.fromarray((rng.random((40, 56)) * 255).astype(np.uint8)).save(folder / "p.png")
    (folder / "d.svg").write_text(_SVG)
    (folder / "d.gcode").write_text(_GCODE)
    (folder / "d.hpgl").write_text(_HPGL)
    png = (folder / "p.png").read_bytes()
    (folder / "truncated.png").write_bytes(png[: len(png) // 2])
    (folder / os.fsdecode(b"ph\xff\xfeoto.png")).write_bytes(png)
    (folder / os.fsdecode(b"dr\xe9.svg")).write_text(_SVG)
    for suffix in ("png", "svg", "gcode", "hpgl", "toml", "json"):
        (folder / f"empty.{suffix}").write_bytes(b"")
        with open(folder / f"sparse.{suffix}", "wb") as handle:  # 20 GB of nothing: never read whole
            handle.truncate(20 << 30)
        for kind in ("fifo", "dir", "dev"):
            path = folder / f"{kind}.{suffix}"
            if path.exists() or path.is_symlink():
                continue
            if kind == "fifo":
                os.mkfifo(path)
            elif kind == "dir":
                path.mkdir()
            else:
                device(path, 5)  # a /dev/zero of our own: endless zeros
    for suffix in ("png", "svg", "gcode", "hpgl"):
        for kind, minor in (("outfifo", None), ("outdev", 3)):
            path = folder / f"{kind}.{suffix}"
            if not path.exists():
                os.mkfifo(path) if minor is None else device(path, minor)  # (3: a /dev/null of our own)


def device(path: Path, minor: int) -> Path:
    """A character device node (major 1: /dev/null 3, /dev/zero 5), or a FIFO where that is not
    allowed (not root): either is no regular file."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, minor))
    except PermissionError:
        os.mkfifo(path)
    return path


def _file_probes() -> list[Probe]:
    out = []
    readers = [  # (command and its options, the input's suffix, the output it would write)
        (["sketch", "{}", "-o", "o.png"], "png", "o.png"),
        (["plan", "{}", "-o", "o.svg"], "png", "o.svg"),
        (["plan", "{}", "-o", "o.svg"], "svg", "o.svg"),
        (["optimize", "{}", "-o", "o.svg"], "svg", "o.svg"),
        (["stat", "{}"], "svg", None),
        (["stat", "{}"], "gcode", None),
        (["stat", "{}", "--profile", "hp7475a"], "hpgl", None),
        (["export", "{}", "-o", "o.gcode"], "svg", "o.gcode"),
        (["export", "{}", "-o", "o.gcode"], "png", "o.gcode"),
        (["simulate", "{}", "-o", "o.png"], "gcode", "o.png"),
        (["simulate", "{}", "-o", "o.png", "--profile", "hp7475a"], "hpgl", "o.png"),
        (["draw", "{}", "--port", "sim://"], "gcode", None),
        (["draw", "{}", "--port", "sim://", "--profile", "hp7475a"], "hpgl", None),
    ]
    for argv, suffix, output in readers:
        command = argv[0]
        absent = [output] if output else []
        for kind in ("fifo", "dir", "dev", "empty", "sparse"):
            name = f"{kind}.{suffix}"
            out.append(
                Probe(
                    "files",
                    f"{command} {name}",
                    [a.replace("{}", name) for a in argv],
                    keep=[name],
                    absent=absent,
                )
            )
        if suffix == "png":
            out.append(
                Probe(
                    "files",
                    f"{command} truncated.png",
                    [a.replace("{}", "truncated.png") for a in argv],
                    keep=["truncated.png"],
                    absent=absent,
                )
            )
        good = {"png": os.fsdecode(b"ph\xff\xfeoto.png"), "svg": os.fsdecode(b"dr\xe9.svg")}.get(suffix)
        if good and (command != "plan" or suffix == "png"):
            out.append(
                Probe(
                    "files",
                    f"{command} a name not UTF-8 ({suffix})",
                    [a.replace("{}", good) for a in argv],
                    good=True,
                    keep=[good],
                )
            )
        if output:
            for kind in ("outfifo", "outdev"):
                target = f"{kind}{Path(output).suffix}"
                good_input = {"png": "p.png", "svg": "d.svg", "gcode": "d.gcode", "hpgl": "d.hpgl"}[suffix]
                argv_out = [good_input if a == "{}" else target if a == output else a for a in argv]
                out.append(Probe("files", f"{command} -o {target}", argv_out, keep=[target, good_input]))
    return out


_SYSTEM = [
    "$N0=G0X5",
    "$100=250",
    "$3=1",
    "$130=10",
    "$SLP",
    "$C",
    "$RST=*",
    "$RST=$",
    "$H",
    "$X",
    "$$",
    "$#",
    "$I",
    "$G",
    "$",
    "$N1=M3S90",
    "$J",
]
_BAD_LINES = {
    "jog G53 off the bed": "$J=G53 X900 Y900 F3000",
    "jog G91 off the bed": "$J=G91 X500 F3000",
    "jog in inches off the bed": "$J=G20 X10 Y1 F100",
    "jog G91 G20 off the bed": "$J=G91 G20 Y20 F100",
    "X of 400 digits": "G1 X" + "9" * 400 + " F1000",
    "F of 400 digits": "G1 X5 F" + "9" * 400,
    "S of 400 digits": "M3 S" + "9" * 400,
    "X negative 30 digits": "G1 X-" + "9" * 30,
    "dwell of 1e30 s": "G4 P" + "1" + "0" * 30,
    "NUL byte": "G1 X5\x00Y5",
    "non-ASCII command": "G1 X5 Y5 \u00e9",
    "G53 off the bed": "G53 G0 X900",
    "G92 then off the bed": "G92 X-500\nG0 X0",
}


def _gcode_probes(folder: Path) -> list[Probe]:
    out = []
    head, tail = "G21\nG90\nM3 S30\nG0 X10 Y10\n", "M3 S90\nG1 X20 Y10 F1000\nG1 X20 Y20\nM3 S30\n"
    cases = {f"system command {line}": line for line in _SYSTEM} | _BAD_LINES
    goods = {
        "jog on the bed": "$J=G91 X5 Y5 F1000",
        "jog G53 on the bed": "$J=G53 X50 Y50 F3000",
        "homing allowed by name": "$H",
        "check mode allowed by name": "$C",
    }
    for index, (name, line) in enumerate([*cases.items(), *goods.items()]):
        path = f"line{index}.gcode"
        (folder / path).write_text(head + line + "\n" + tail, encoding="utf-8")
        allow = ["--allow-system-commands", line] if "allowed" in name else []
        for argv in (
            ["stat", path, *allow],
            ["simulate", path, "-o", "o.png", *allow],
            ["draw", path, "--port", "sim://", *allow],
        ):
            # Check mode from before the first stroke: it draws nothing, which stat says (an
            # error); simulate and draw run it as asked, and warn.
            good = name in goods and not (name == "check mode allowed by name" and argv[0] == "stat")
            if name == "homing allowed by name" and argv[0] != "stat":
                continue  # the virtual board has no homing switches ($22=0): it refuses $H, as GRBL does
            out.append(
                Probe(
                    "gcode lines",
                    f"{argv[0]}: {name}",
                    [*argv, "-q"],
                    good=good,
                    keep=[path],
                    absent=["o.png"] if argv[0] == "simulate" and not good else [],
                )
            )
    return out


_HPGL_BAD = {
    "SP of 30 digits": "IN;SP" + "9" * 30 + ";PD100,100;",
    "SP-3": "IN;SP-3;PU0,0;PD100,100;",
    "SP1.5": "IN;SP1.5;PD1,1;",
    "VS-5": "IN;VS-5;SP1;PD100,100;",
    "VS of 400 digits": "IN;VS" + "9" * 400 + ";SP1;PD100,100;",
    "PA of 400 digits": "IN;SP1;PA" + "9" * 400 + ",100;",
    "PD of 400 digits": "IN;SP1;PD" + "9" * 400 + "," + "9" * 400 + ";",
    "PR of 30 digits": "IN;SP1;PU0,0;PR" + "9" * 30 + ",0;",
    "PD odd count": "IN;SP1;PD1,2,3;",
    "unknown instruction": "IN;SP1;XX1;PD100,100;",
    "binary": "\x00\x01\x02\xff",
}


def _hpgl_probes(folder: Path) -> list[Probe]:
    out = []
    for index, (name, text) in enumerate(_HPGL_BAD.items()):
        path = f"bad{index}.hpgl"
        (folder / path).write_bytes(text.encode("latin-1"))
        for argv in (["stat", path], ["simulate", path, "-o", "o.png"], ["draw", path, "--port", "sim://"]):
            out.append(
                Probe(
                    "hpgl",
                    f"{argv[0]}: {name}",
                    [*argv, "--profile", "hp7475a", "-q"],
                    keep=[path],
                    absent=["o.png"] if argv[0] == "simulate" else [],
                )
            )
    out.append(
        Probe("hpgl", "stat: a right file", ["stat", "d.hpgl", "--profile", "hp7475a", "-q"], good=True)
    )
    (folder / "travel.hpgl").write_text("IN;SP1;PU100,100;PU200,200;SP0;\n")
    out.append(Probe("hpgl", "stat: no pen down", ["stat", "travel.hpgl", "--profile", "hp7475a", "-q"]))
    for argv in (["simulate", "travel.hpgl", "-o", "o.png"], ["draw", "travel.hpgl", "--port", "sim://"]):
        # Travel only is a program a plotter runs (an empty picture), not a wrong one.
        out.append(Probe("hpgl", f"{argv[0]}: no pen down", [*argv, "--profile", "hp7475a", "-q"], good=True))
    return out


_BAD_NUMBERS = [-1e300, -1.0, 0.0, 1e-9, 1e300, math.nan, math.inf, "text", True]
# Keys a 0 (or a tiny number) is right for: delays, cornering, the servo's instant rate, offsets.
_ZERO_OK = {
    "up_delay",
    "down_delay",
    "junction_deviation",
    "servo_rate_up",
    "servo_rate_down",
    "min_move_ms",
    "up",
    "down",
    "offset",
    "park",
    "decimals",
}
_FAMILY_BAD = [
    ("axidraw-v3", "ebb", "steps_per_mm", 1e-9),
    ("axidraw-v3", "pen", "up", 200),
    ("axidraw-a3", "pen", "down", 101),
    ("axidraw-v3", "ebb", "servo_max", 100),
    ("grbl-servo-a4", "pen", "up", 1e308),
    ("grbl-servo-a4", "pen", "up", -30),
    ("grbl-servo-a4", "pen", "up", 1e-7),
    ("grbl-servo-a4", "pen", "up_command", "$RST=*"),
    ("grbl-servo-a4", "pen", "down_command", "$J=G91X5F100"),
    ("grbl-servo-a4", "gcode", "header", "G21\nG91"),
    ("grbl-servo-a4", "gcode", "header", "G20"),
    ("grbl-servo-a4", "pen", "up_command", "M3 S{up}\n$SLP"),
    ("marlin-servo-a4", "pen", "up", 400),
    ("grbl-z-a3", "pen", "down", -5000),
    ("hp7475a", "motion", "draw_feed", 1e6),
    ("hp7475a", "paper", "carousel", 0),
    ("grblhal-servo-a3", "gcode", "receive_buffer", 10),
]


def _profile_probes(folder: Path) -> list[Probe]:
    out, count = [], 0

    def probe(base: str, section: str, key: str, value, name: str) -> None:
        nonlocal count
        table = shipped_table(base)
        table.setdefault(section, {})[key] = value
        path = f"profile{count}.toml"
        count += 1
        (folder / path).write_text(toml_text(table))
        output = "o.hpgl" if base.startswith("hp") else "o.gcode"
        out.append(
            Probe(
                "profiles",
                f"export {base} [{section}] {key} = {name}",
                ["export", "d.svg", "-o", output, "--profile", path, "-q"],
                keep=[path],
                absent=[output],
            )
        )

    for base in ("grbl-servo-a4", "axidraw-v3", "hp7475a"):
        table = shipped_table(base)
        for section, keys in table.items():
            if not isinstance(keys, dict):
                continue
            for key, value in keys.items():
                if isinstance(value, bool) or not isinstance(value, int | float):
                    continue
                for bad in _BAD_NUMBERS:
                    if (bad in (0.0, 1e-9) and key in _ZERO_OK) or (
                        bad == -1.0 and key in ("offset", "park")
                    ):
                        continue
                    if key in ("up", "down") and bad in (-1.0, 1e-9):
                        if base == "axidraw-v3" and bad == -1.0:
                            pass  # a percent below 0: wrong
                        else:
                            continue
                    probe(base, section, key, bad, repr(bad))
    for base, section, key, value in _FAMILY_BAD:
        probe(base, section, key, value, repr(value))
    return out


def _settings_probes(folder: Path) -> list[Probe]:
    (folder / "config-fifo").mkdir(exist_ok=True)
    if not (folder / "config-fifo" / "config.toml").exists():
        os.mkfifo(folder / "config-fifo" / "config.toml")
    (folder / "config-dev").mkdir(exist_ok=True)
    if not (folder / "config-dev" / "config.toml").exists():
        device(folder / "config-dev" / "config.toml", 5)
    out = []
    for value in (
        "dev.toml",
        "fifo.toml",
        "dir.toml",
        "sparse.toml",
        "empty.toml",
        "/nonexistent/p.toml",
        "no-such-name",
    ):
        out.append(
            Probe(
                "settings",
                f"PENCILBOT_PROFILE={value}",
                ["stat", "d.svg", "-q"],
                env={
                    "PENCILBOT_PROFILE": str(folder / value) if "." in value and "/" not in value else value
                },
            )
        )
    for sub in ("config-fifo", "config-dev"):
        out.append(
            Probe(
                "settings",
                f"config.toml in {sub}",
                ["stat", "d.svg", "-q"],
                env={"PENCILBOT_CONFIG_DIR": str(folder / sub)},
                keep=[f"{sub}/config.toml"],
            )
        )
    for journal in ("fifo.json", "dev.json", "dir.json", "sparse.json", "empty.json"):
        out.append(
            Probe(
                "settings",
                f"draw --resume {journal}",
                ["draw", "--resume", journal, "--port", "sim://"],
                keep=[journal],
            )
        )
    return out


def probes(folder: Path) -> list[Probe]:
    """Every probe of the sweep, with the files they read made in ``folder``."""
    _files(folder)
    return [
        *_file_probes(),
        *_gcode_probes(folder),
        *_hpgl_probes(folder),
        *_profile_probes(folder),
        *_settings_probes(folder),
    ]


def sample(every: list[Probe], size: int) -> list[Probe]:
    """About ``size`` probes spread over every surface (each surface's probes evenly)."""
    by_surface: dict[str, list[Probe]] = {}
    for p in every:
        by_surface.setdefault(p.surface, []).append(p)
    share = max(1, size // len(by_surface))
    out = []
    for group in by_surface.values():
        step = max(1, len(group) // share)
        out += group[::step][:share]
    return out
