"""The inputs a hostile sweep broke (issue 25), each run through the CLI under a 2 GB address-space
limit set in the child (``resource.setrlimit``): exit non-zero, exactly one ``pencilbot: error:``
line, no traceback, no output file, every input byte for byte as it was.

One child process runs a whole table of cases through :func:`pencilbot.cli.main` (a process
start costs about a second); the picture bombs, whose failure was the process dying, each get a
process of their own. Hypothesis covers the large spaces in process: numbers for options and
style keys, and SVG coordinates, transforms and sizes.
"""

from __future__ import annotations

import hashlib
import json
import os
import resource
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from pencilbot.cli import main
from pencilbot.commands import build_parser
from pencilbot.configs_io import config_folder
from pencilbot.errors import PencilbotError
from pencilbot.export import svg_read, svg_straight
from pencilbot.export.svg_checks import MAX_DRAWING_MM

LIMIT = 2 << 30  # bytes of address space the child may have

# Runs each case of a JSON table through the CLI's main() in this one process and prints what
# happened: exit code, stderr, and the exception if main() let one out.
_RUNNER = r"""
import contextlib, io, json, os, sys, traceback
from pencilbot.cli import main
results = []
for case in json.load(sys.stdin):
    os.chdir(case["cwd"])
    err, out = io.StringIO(), io.StringIO()
    escaped = ""
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(case["argv"])
        except BaseException:
            code, escaped = -1, traceback.format_exc()
    results.append({"code": code, "err": err.getvalue(), "escaped": escaped})
print(json.dumps(results))
"""


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT, LIMIT))


def _child(args: list[str], stdin: str = "", timeout: float = 120) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONFAULTHANDLER": "0", "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    return subprocess.run(
        [sys.executable, *args],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=timeout,
        preexec_fn=_limit_memory,
        env=env,
    )


def _digests(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


def _one_error_line(err: str) -> bool:
    lines = err.strip().splitlines()
    return (
        "Traceback" not in err
        and sum(line.startswith("pencilbot: error: ") for line in lines) == 1
        and lines[-1].startswith("pencilbot: error: ")
    )


# --- the files the cases read ------------------------------------------------------------------


def _png_header(path: Path, width: int, height: int) -> None:
    """A PNG that claims ``width`` x ``height`` grey pixels but holds almost none (a bomb)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    rows = zlib.compress(b"\0" * (min(width, 4096) + 1) * min(height, 16))
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
        + chunk(b"IDAT", rows)
        + chunk(b"IEND", b"")
    )


def _svg(body: str, width: str = "100mm", height: str = "100mm", view: str = "0 0 100 100") -> str:
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="{width}" '
        f'height="{height}" viewBox="{view}">{body}</svg>'
    )


_LINE = '<path d="M 1 1 L 5 5" stroke="black"/>'
SVGS = {
    "c308.svg": _svg(f'<path d="M 0 0 L 1e308 20 L 10 10" stroke="black"/>{_LINE}'),
    "c309.svg": _svg(f'<path d="M 0 0 L 1e309 20" stroke="black"/>{_LINE}'),
    "nan.svg": _svg(f'<path d="M 0 0 L nan 20" stroke="black"/>{_LINE}'),
    "inf.svg": _svg(f'<polyline points="0,0 inf,3" stroke="black"/>{_LINE}'),
    "scale.svg": _svg(f'<g transform="scale(1e308)"><path d="M 0 0 L 10 20"/></g>{_LINE}'),
    "times.svg": _svg(
        '<g transform="scale(99999)"><g transform="scale(99999)"><path d="M 0 0 L 9 5"/></g></g>'
    ),
    "width.svg": _svg(_LINE, width="1e308mm"),
    "use.svg": _svg(
        "<defs>"
        + '<path id="p0" d="M 0 0 L 10 10" stroke="black"/>'
        + "".join(
            f'<g id="p{i}"><use xlink:href="#p{i - 1}"/><use xlink:href="#p{i - 1}" transform="translate(0.1 0)"/></g>'
            for i in range(1, 25)
        )
        + '</defs><use xlink:href="#p24"/>'
    ),
    "loop.svg": _svg('<g id="a"><use xlink:href="#a"/></g>' + _LINE),
}


def _profile(folder: Path, name: str, old: str, new: str) -> str:
    text = (config_folder("plotters") / "grbl-servo-a4.toml").read_text()
    assert old in text
    (folder / name).write_text(text.replace(old, new, 1))
    return name


def _pens(folder: Path, name: str, count: int) -> str:
    (folder / name).write_text(
        "".join(
            f'[[pen]]\nname = "p{i}"\ncolor = "#{i * 4:02x}{255 - i * 4:02x}80"\nwidth = 0.5\n'
            for i in range(count)
        )
    )
    return name


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("hostile")
    rng = np.random.default_rng(5)
    Image.fromarray((rng.random((24, 32)) * 255).astype(np.uint8)).save(folder / "p.png")
    Image.fromarray((rng.random((1, 5000)) * 255).astype(np.uint8)).save(folder / "strip.png")
    (folder / "link.png").symlink_to("p.png")
    os.link(folder / "p.png", folder / "hard.png")
    (folder / "stages").mkdir()
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(folder / "stages" / "edges.png")
    (folder / "demo").mkdir()
    Image.fromarray(np.zeros((8, 8), np.uint8)).save(folder / "demo" / "sketch.png")
    _png_header(folder / "wide.png", 2147483647, 1)
    _png_header(folder / "huge.png", 100000, 100000)
    _png_header(folder / "big.png", 30000, 30000)
    for name, text in SVGS.items():
        (folder / name).write_text(text)
    (folder / "ok.svg").write_text(_svg(_LINE))
    (folder / "square.gcode").write_text("G21\nG90\nG0 X10 Y10\nG1 X20 Y10 F1000\nG1 X20 Y20\n")
    with open(folder / "oneline.gcode", "wb") as handle:  # 30 MB on one line: 2.2 GB and 16 s before
        handle.write(b"G21\nG90\nG1 X1 Y1 (" + b"A" * (30 << 20) + b")\n")
    (folder / "blur.toml").write_text("hatch_blur = 1e6\n")
    (folder / "form.toml").write_text("hatch_form = 1e9\n")
    (folder / "angles.toml").write_text(f"hatch_angles = {[float(a % 180) for a in range(1000)]}\n")
    _pens(folder, "pens60.toml", 60)
    _profile(folder, "slow.toml", "acceleration = 800.0", "acceleration = 1e-300")
    _profile(folder, "cancel.toml", 'footer = ""', 'footer = "M5\\u0018"')
    _profile(folder, "hold.toml", 'footer = ""', 'footer = "M5 !"')
    _profile(folder, "tape.toml", 'footer = ""', 'footer = "%"')
    _profile(folder, "resume.toml", 'footer = ""', 'footer = "M5 ~"')
    _profile(folder, "status.toml", 'footer = ""', 'footer = "?"')
    _profile(folder, "stuck.toml", "down = 90 ", "down = 30 ")
    _profile(folder, "far.toml", 'footer = ""', 'footer = "G0 X5000 Y10"')
    return folder


# (argv, files the run must not leave behind); {d} is the inputs' folder.
CASES = [
    # Data loss: an output that is an input, the same file or a link to it.
    (["sketch", "p.png", "-o", "p.png"], []),
    (["simulate", "p.png", "-o", "link.png"], []),
    (["plan", "p.png", "-o", "x.svg", "--preview", "hard.png"], ["x.svg"]),
    (["plan", "p.png", "-o", "x.svg", "--preview", "p.png"], ["x.svg"]),
    (["optimize", "ok.svg", "-o", "./ok.svg"], []),
    (["export", "ok.svg", "-o", "ok.svg"], []),
    (["sketch", "stages/edges.png", "-o", "x.png", "--stages", "stages"], ["x.png"]),
    (["demo", "--input", "demo/sketch.png", "--out", "demo"], ["demo/plan.svg"]),
    # Pictures: headers read without decoding, the strip refused, the limit before any decode.
    (["plan", "strip.png", "-o", "x.svg"], ["x.svg"]),
    (["export", "strip.png", "-o", "x.gcode"], ["x.gcode"]),
    (["plan", "big.png", "-o", "x.svg"], ["x.svg"]),
    (["sketch", "big.png", "-o", "x.png", "--downscale"], ["x.png"]),
    # SVGs: numbers that are not, transforms past any bed, <use> bombs and loops.
    *[
        ([command, name, *extra], out)
        for name in (
            "c308.svg",
            "c309.svg",
            "nan.svg",
            "inf.svg",
            "scale.svg",
            "times.svg",
            "width.svg",
            "use.svg",
            "loop.svg",
        )
        for command, extra, out in (
            ("stat", [], []),
            ("export", ["-o", "x.gcode"], ["x.gcode"]),
            ("optimize", ["-o", "x.svg"], ["x.svg"]),
        )
    ],
    (["simulate", "c309.svg", "-o", "x.png"], ["x.png"]),
    # Options and configs that hung or blew up.
    (["simulate", "square.gcode", "-o", "x.png", "--realtime", "1e-9"], ["x.png"]),
    (["simulate", "square.gcode", "-o", "x.png", "--dpi", "1e-300"], ["x.png"]),
    (["sim-serve", "--dpi", "1e-300", "-o", "x.png"], ["x.png"]),
    (["sim-serve", "-o", "/proc/x.png"], []),
    *[
        (["plan", "p.png", "-o", "x.svg", "--style", style], ["x.svg"])
        for style in ("blur.toml", "form.toml", "angles.toml")
    ],
    (["plan", "p.png", "-o", "x.svg", "--pens", "pens60.toml"], ["x.svg"]),
    *[
        (["export", "ok.svg", "-o", "x.gcode", "--profile", profile], ["x.gcode"])
        for profile in (
            "slow.toml",
            "cancel.toml",
            "hold.toml",
            "tape.toml",
            "resume.toml",
            "status.toml",
            "stuck.toml",
            "far.toml",
        )
    ],
    # Resources: a G-code line of 30 MB, a page past this process's own memory limit.
    (["stat", "oneline.gcode"], []),
    (["simulate", "oneline.gcode", "-o", "x.png"], ["x.png"]),
    (["plan", "p.png", "-o", "x.svg", "--page", "2500x2500"], ["x.svg"]),
    # Usage mistakes: one line, not argparse's usage text.
    (["plan", "--page", "-1x-1", "p.png", "-o", "x.svg"], ["x.svg"]),
    (["plan"], []),  # no INPUT (-o has a default: beside the input)
    (["frobnicate"], []),
]


def test_every_hostile_case_is_one_line_and_costs_nothing(inputs):
    before = _digests(inputs)
    table = [{"argv": argv, "cwd": str(inputs)} for argv, _ in CASES]
    proc = _child(["-c", _RUNNER], json.dumps(table), timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = json.loads(proc.stdout.strip().splitlines()[-1])
    failures = [
        (argv, result)
        for (argv, _), result in zip(CASES, results)
        if result["code"] in (0, -1) or not _one_error_line(result["err"])
    ]
    assert not failures, failures
    left = [name for _, names in CASES for name in names if (inputs / name).exists()]
    assert not left and not (inputs / "x.png").exists(), left
    assert _digests(inputs) == before  # no input touched, none replaced
    assert os.path.islink(inputs / "link.png") and os.path.samefile(inputs / "hard.png", inputs / "p.png")
    said = {" ".join(argv): result["err"] for (argv, _), result in zip(CASES, results)}
    assert (
        "is an input" in said["simulate p.png -o link.png"]
        and "the same file as the input p.png" in said["plan p.png -o x.svg --preview hard.png"]
    )
    assert (
        "<path>" in said["stat nan.svg"]
        and "<g>" in said["stat scale.svg"]
        and "<use>" in said["stat use.svg"]
    )
    assert "left under this process's limit" in said["plan p.png -o x.svg --page 2500x2500"]
    assert "longer than 1 MB" in said["stat oneline.gcode"]


@pytest.mark.parametrize(
    "argv",
    [
        ["plan", "wide.png", "-o", "x.svg", "--downscale"],  # its EXIF read decoded 8 GB: MemoryError
        ["plan", "huge.png", "-o", "x.svg", "--downscale", "--max-pixels", "10000000000"],
    ],
)
def test_a_picture_bomb_is_refused_from_its_header_in_a_process_of_its_own(inputs, argv):
    proc = _child(["-m", "pencilbot.cli", *argv], timeout=60)
    assert proc.returncode == 2 and _one_error_line(proc.stderr), proc.stderr[-2000:]
    assert not (inputs / "x.svg").exists()


def test_a_strip_a_few_pixels_wide_is_drawn(tmp_path, capsys):
    Image.fromarray(np.full((3, 1), 90, np.uint8)).save(tmp_path / "three.png")
    assert main(["plan", str(tmp_path / "three.png"), "-o", str(tmp_path / "t.svg"), "-q"]) == 0
    assert svg_read.read_svg(tmp_path / "t.svg").layers


def test_stages_that_fail_leave_no_folder(tmp_path, monkeypatch, capsys):
    from pencilbot.commands import sketch

    written = []

    def full_disk(array, path):
        if written:
            raise PencilbotError(
                f"cannot write {path} (No space left on device); check the path and free space"
            )
        written.append(path)
        path.write_bytes(b"png")

    monkeypatch.setattr(sketch, "write_image", full_disk)
    Image.fromarray(np.full((16, 16), 90, np.uint8)).save(tmp_path / "p.png")
    code = main(
        ["sketch", str(tmp_path / "p.png"), "-o", str(tmp_path / "o.png"), "--stages", str(tmp_path / "st")]
    )
    assert code == 2 and _one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png"]  # no stages folder, no hidden one


# --- the large spaces, in process --------------------------------------------------------------

_WILD = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(
        [
            "1e308",
            "1e309",
            "-1e999",
            "nan",
            "inf",
            "-Infinity",
            "1e-300",
            "0",
            "-0",
            "9" * 40,
            "1e9",
            "123456789012",
        ]
    ).map(str),
)


def _text(value) -> str:
    return value if isinstance(value, str) else repr(value)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(x=_WILD, y=_WILD, factor=_WILD, where=st.sampled_from(["d", "transform", "points", "width"]))
def test_any_svg_number_gives_a_sane_plan_or_one_message(tmp_path, x, y, factor, where):
    shape = {
        "d": f'<path d="M 1 1 L {_text(x)} {_text(y)}" stroke="black"/>',
        "points": f'<polyline points="1,1 {_text(x)},{_text(y)}" stroke="black"/>',
        "transform": f'<g transform="translate({_text(x)} 0) scale({_text(factor)})">{_LINE}</g>',
        "width": _LINE,
    }[where]
    path = tmp_path / "w.svg"
    path.write_text(_svg(shape + _LINE, width=f"{_text(factor)}mm" if where == "width" else "100mm"))
    try:
        plan = svg_read.read_svg(path)
    except PencilbotError as err:
        assert "\n" not in str(err)
        return
    for layer in plan.layers:
        assert (
            np.isfinite(layer.paths.points).all()
            and np.abs(layer.paths.points).max() <= MAX_DRAWING_MM + plan.page.height
        )
    assert 0 < plan.page.width <= MAX_DRAWING_MM and 0 < plan.page.height <= MAX_DRAWING_MM


_COORD = st.floats(-500, 500, allow_nan=False).map(lambda v: round(v, 3))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    paths=st.lists(
        st.tuples(
            st.sampled_from(["M", "m"]),
            st.lists(
                st.tuples(st.sampled_from(["L", "l", "H", "h", "V", "v", ""]), _COORD, _COORD),
                min_size=1,
                max_size=6,
            ),
            st.booleans(),
        ),
        min_size=1,
        max_size=4,
    ),
    stroke=st.sampled_from([None, "0.5", "1.2"]),
    view=st.sampled_from(["0 0 100 100", "-20 10 50 50", None]),
    corners=st.lists(st.sampled_from([(0, 0), (1, 2), (5, 5)]), min_size=1, max_size=5),
    closed=st.booleans(),
)
def test_straight_lines_read_in_arrays_as_vpype_reads_them(tmp_path, paths, stroke, view, corners, closed):
    def data(moves, close):
        words = []
        for command, x, y in moves:
            words.append(
                {"H": f"H {x}", "h": f"h {x}", "V": f"V {y}", "v": f"v {y}"}.get(
                    command, f"{command} {x},{y}"
                )
            )
        return " ".join(words) + (" Z" if close and all(c.isupper() or c == "" for c, _, _ in moves) else "")

    d = " ".join(f"{start} 3 4 " + data(moves, close) for start, moves, close in paths)
    width = f' stroke-width="{stroke}"' if stroke else ""
    shape = "polygon" if closed else "polyline"  # repeated corners: vpype keeps a polyline's
    corners_text = " ".join(f"{x},{y}" for x, y in corners)
    body = f'<g id="one"{width}><path d="{d}" stroke="black"/></g><{shape} points="{corners_text}" stroke="red"/>'
    text = _svg(body, view=view) if view else _svg(body).replace(' viewBox="0 0 100 100"', "")
    path = tmp_path / "s.svg"
    path.write_text(text)
    original = svg_straight.read_straight
    taken = []
    svg_read.read_straight = lambda *a: taken.append(original(*a)) or taken[-1]
    try:
        fast = svg_read.read_svg(path)
    finally:
        svg_read.read_straight = original
    assert taken and (taken[0] is not None or ("Z" in d and any(c in d for c in "mlhv")))  # arrays, not vpype
    try:
        svg_read.read_straight = lambda *_: None  # the same file through vpype
        slow = svg_read.read_svg(path)
    finally:
        svg_read.read_straight = original
    assert [(l.name, l.role, l.color) for l in fast.layers] == [
        (l.name, l.role, l.color) for l in slow.layers
    ]
    for a, b in zip(fast.layers, slow.layers):
        # svgelements rounds its mm-per-pixel factor (about 1e-6 relative): a micrometre at most here
        assert a.pen_width == pytest.approx(b.pen_width, rel=1e-5)
        assert np.array_equal(a.paths.offsets, b.paths.offsets)
        assert np.allclose(a.paths.points, b.paths.points, rtol=0, atol=1e-3)


_STYLE_KEYS = [
    "hatch_blur",
    "hatch_form",
    "margin",
    "pen_width",
    "min_hatch_run",
    "hatch_join",
    "edge_join",
    "edge_clutter",
]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    key=st.sampled_from(_STYLE_KEYS),
    value=st.floats(allow_nan=False, allow_infinity=False),
    angles=st.integers(0, 40),
)
def test_a_style_loads_only_within_bounds_that_keep_planning_cheap(tmp_path, key, value, angles):
    from pencilbot.planning.style import MAX_BLUR_MM, MAX_FORM_MM, MAX_PEN_WIDTH, load_style

    path = tmp_path / "s.toml"
    path.write_text(f"{key} = {value!r}\nhatch_angles = {[float(a) for a in range(angles)]}\n")
    try:
        style = load_style(str(path))
    except PencilbotError as err:
        assert "\n" not in str(err) and (key in str(err) or "hatch_angles" in str(err))
        return
    assert 1 <= len(style.hatch_angles) <= 8
    assert (
        style.hatch_blur <= MAX_BLUR_MM
        and style.hatch_form <= MAX_FORM_MM
        and style.pen_width <= MAX_PEN_WIDTH
    )
    assert getattr(style, key) == value


@settings(max_examples=80, deadline=None)
@given(
    option=st.sampled_from(
        [
            ("simulate", "--dpi"),
            ("simulate", "--realtime"),
            ("sim-serve", "--dpi"),
            ("sim-serve", "--realtime"),
        ]
    ),
    value=st.one_of(st.floats(), st.sampled_from(["1e-300", "1e-9", "-0", "0.0999", "1e309"])),
)
def test_render_and_speed_options_take_only_values_that_finish(option, value):
    command, flag = option
    parser = build_parser(only=command.replace("-", "_"))
    argv = [command, *(["x.gcode", "-o", "x.png"] if command == "simulate" else []), f"{flag}={value}"]
    try:
        args = parser.parse_args(argv)
    except PencilbotError as err:
        assert str(err).startswith(flag) and "\n" not in str(err)
        return
    got = getattr(args, flag.lstrip("-"))
    assert (1 <= got <= 10_000) if flag == "--dpi" else (got == 0 or 0.1 <= got <= 1e6)
