"""Cost at scale: CPU time, peak memory and fitted exponent of each stage over sizes spanning 100x.

Prints JSON. Every size of every stage runs in a fresh subprocess; its CPU time (user + system)
and peak resident memory are that process's own, read with ``os.wait4``. A stage either runs a
``pencilbot`` command end to end (what a user pays, start-up included) or a library call inside
a small child that also reports the call's own CPU time. ``exponent`` is the least-squares slope
of log CPU over log size.

Stages and their targets (issue 16):

* ``ordering`` — ``order_paths`` on random short strokes (1-5 mm on A4, bench/ordering.py),
  10k to 1M: CPU exponent <= 1.1 from 100k to 1M, 1M in <= 25 s CPU and <= 1.5 GB; travel <=
  1.35x the lower bound at 100k (``travel_lower_bound``: the LP dual of the matching of path ends
  that every order's pen-up moves form, raised by dual ascent) and <= vpype ``linesort --two-opt``
  at 10k (its travel counted from home, as a plotter draws it);
* ``plan`` — ``pencilbot plan PHOTO.jpg`` on A4 (default style) from 0.1 to 24 MP: <= 1.5 s CPU
  beyond the 0.1 MP case and <= 350 MB peak at 24 MP;
* ``sketch`` — ``pencilbot sketch PHOTO.jpg -o OUT.png`` from 0.12 to 12 MP (square, 3464² at
  12 MP): <= 3 s CPU at 12 MP;
* ``export`` — ``pencilbot export PLAN.svg`` of 10k to 1M random 1-5 mm strokes on A4
  (bench/gcode.py's plan, written by ``write_svg``): <= 4 s CPU at 1M;
* ``simulate`` — ``pencilbot simulate PLAN.svg --dpi D`` of 20 000 random 1-8 mm strokes on an A0
  sheet on an A0 GRBL bed (850 x 1200 mm, the shipped servo profile enlarged), 60 to 600 dpi
  (5.6 to 560 million bed pixels): <= 2 GB peak at 600 dpi; the exponent is over bed pixels;
* ``draw`` — ``pencilbot draw JOB.gcode --port /dev/pts/N`` of bench/gcode.py's plan, 15k to
  1.5M G-code lines, into a virtual plotter in a process of its own (``pencilbot sim-serve``,
  instant): a real serial port, so the figures are the driver's alone. ``bytes_per_line`` is
  the slope of its peak memory over lines (<= 120); ``lines_per_cpu_s`` its CPU throughput.
  ``traced_bytes_per_line`` is one more run, of ``draw`` over ``sim://`` (the virtual plotter in
  the same process, as ``pencilbot draw --port sim://`` and ``simulate`` run it) at 150k lines:
  what is held when it ends, per line, by the module that allocated it (tracemalloc).

* ``svg_stat``, ``svg_export`` — ``pencilbot stat`` / ``export`` of another tool's SVG of one
  straight path (a random walk on A4), 5 to 50 MB: <= 30 s CPU and <= 2 GB at 50 MB, linear;
* ``simulate_gcode`` — ``pencilbot simulate JOB.gcode`` of the draw stage's G-code, 0.3M to 3M
  lines: <= 30 s CPU and <= 2 GB at 3M, linear (issue 25; a plain job runs through the
  simulator's fast path, sim.bulk);
* ``tiny_stat``, ``tiny_optimize``, ``tiny_export``, ``tiny_simulate`` — whole commands on another
  tool's SVG of 10k to 1M tiny paths (bench/scale_tiny.py): <= 30 s CPU at 1M, exponent <= 1.1
  from 100k to 1M (issue 35);
* ``downscale_png`` — ``pencilbot sketch BIG.png --downscale --max-pixels 1000000`` of a 10 000²
  and a 30 000² RGB PNG (the astronaut enlarged): peak memory <= a quarter of the whole
  picture's decode (Pillow's 4 bytes a pixel), since a PNG is shrunk as it is read (issue 25).

Photos are skimage's astronaut enlarged (cubic) and saved as JPEG quality 90, like a camera's.
A new stage is one function decorated with ``@stage(...)``: it gets a size and a scratch folder
and returns the argv to measure (and, for a library child, its own figures); see ``ordering``.

Usage: ``python bench/scale.py [--stage NAME ...] [--quick] [--repeats N]``. Timings share 2
cores with other work: the median of ``--repeats`` runs is reported.
"""

from __future__ import annotations

import argparse
import atexit
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Stage:
    """A measured stage: ``command(size, scratch)`` gives the argv of one fresh subprocess."""

    name: str
    unit: str
    sizes: tuple[int, ...]
    quick_sizes: tuple[int, ...]
    command: Callable[[int, Path], list[str]]
    summary: Callable[[list[dict]], dict]
    extra: Callable[[Path], dict] | None = None


STAGES: dict[str, Stage] = {}


def stage(
    name: str,
    *,
    unit: str,
    sizes: tuple[int, ...],
    quick: tuple[int, ...],
    summary: Callable,
    extra: Callable[[Path], dict] | None = None,
):
    """Register ``command(size, scratch) -> argv`` as stage ``name`` (``extra(scratch)``: more
    figures from runs of its own)."""

    def register(command: Callable[[int, Path], list[str]]) -> Callable[[int, Path], list[str]]:
        STAGES[name] = Stage(name, unit, sizes, quick, command, summary, extra)
        return command

    return register


# -- measuring ----------------------------------------------------------------------------------


def measure(argv: list[str]) -> dict:
    """Run argv as a fresh process: its own CPU seconds and peak RSS, and its stdout JSON if any."""
    wall = time.perf_counter()
    with tempfile.TemporaryFile("w+") as errors:
        process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=errors, text=True)
        # Read the output to its end (a full pipe would block the child), then reap the child
        # with os.wait4, which gives that child's own resource usage.
        out = process.stdout.read()
        _, status, usage = os.wait4(process.pid, 0)
        process.returncode = os.waitstatus_to_exitcode(status)
        if process.returncode != 0:
            errors.seek(0)
            raise RuntimeError(f"{' '.join(argv)} failed:\n{errors.read()}")
    figures = json.loads(out) if out.strip().startswith("{") else {}
    return {
        "process_cpu_s": round(usage.ru_utime + usage.ru_stime, 3),
        "peak_rss_mb": round(usage.ru_maxrss / 1024, 1),
        "wall_s": round(time.perf_counter() - wall, 2),
        **figures,
    }


def exponent(sizes: list[float], seconds: list[float]) -> float | None:
    """Least-squares slope of log(seconds) over log(size)."""
    if len(sizes) < 2:
        return None
    x, y = [math.log(s) for s in sizes], [math.log(t) for t in seconds]
    mx, my = sum(x) / len(x), sum(y) / len(y)
    return round(sum((a - mx) * (b - my) for a, b in zip(x, y)) / sum((a - mx) ** 2 for a in x), 3)


def run_stage(stage_: Stage, sizes: tuple[int, ...], repeats: int, scratch: Path) -> dict:
    runs = []
    for size in sizes:
        results = [measure(stage_.command(size, scratch)) for _ in range(repeats)]
        # Timings take the median over repeats; everything else is the same in every run.
        row = {
            key: statistics.median(r[key] for r in results)
            if key.endswith("_s") or key == "peak_rss_mb"
            else value
            for key, value in results[0].items()
        }
        runs.append({stage_.unit: size, **row})
    extra = stage_.extra(scratch) if stage_.extra else {}
    return {"unit": stage_.unit, "runs": runs, **stage_.summary(runs), **extra}


def _child(argv: list[str]) -> list[str]:
    return [sys.executable, str(Path(__file__).resolve()), "--child", *argv]


def _pencilbot(*args: str) -> list[str]:
    return [sys.executable, "-m", "pencilbot.cli", *args]


# -- stage: ordering ----------------------------------------------------------------------------


def _ordering_summary(runs: list[dict]) -> dict:
    big = [r for r in runs if r["paths"] >= 100_000]
    at = {r["paths"]: r for r in runs}
    figures = {
        "exponent_all": exponent([r["paths"] for r in runs], [r["cpu_s"] for r in runs]),
        "exponent_100k_to_1m": exponent([r["paths"] for r in big], [r["cpu_s"] for r in big]),
    }
    targets = {
        "exponent_100k_to_1m_max": 1.1,
        "cpu_s_1m_max": 25.0,
        "peak_rss_mb_1m_max": 1536,
        "travel_vs_bound_100k_max": 1.35,
        "travel_vs_vpype_10k_max": 1.0,
    }
    met = {}
    if figures["exponent_100k_to_1m"] is not None:
        met["exponent"] = figures["exponent_100k_to_1m"] <= 1.1
    if 1_000_000 in at:
        met["cpu_1m"] = at[1_000_000]["cpu_s"] <= 25.0
        met["memory_1m"] = at[1_000_000]["peak_rss_mb"] <= 1536
    if 100_000 in at:
        met["travel_vs_bound_100k"] = at[100_000]["travel_vs_bound"] <= 1.35
    if 10_000 in at and "vpype_two_opt_pen_up_mm" in at[10_000]:
        met["beats_vpype_10k"] = at[10_000]["pen_up_mm"] <= at[10_000]["vpype_two_opt_pen_up_mm"]
    return {**figures, "targets": targets, "met": met}


@stage(
    "ordering",
    unit="paths",
    sizes=(10_000, 30_000, 100_000, 300_000, 1_000_000),
    quick=(10_000, 30_000, 100_000, 300_000),
    summary=_ordering_summary,
)
def ordering_command(size: int, scratch: Path) -> list[str]:
    return _child(["ordering", str(size)])


def ordering_child(size: int) -> dict:
    """Order ``size`` random strokes with the defaults; travel against bounds and baselines."""
    import numpy as np

    sys.path.insert(0, str(HERE))
    from ordering import synthetic_uniform

    from pencilbot.planning.ordering import (
        DEFAULT_ROUNDS,
        MIN_ROUNDS,
        ROUND_WORK,
        greedy_order,
        order_paths,
        travel_length,
        travel_lower_bound,
    )

    paths = synthetic_uniform(size, np.random.default_rng(0))
    home = (0.0, 0.0)
    cpu = time.process_time()
    ordered = order_paths(paths, start=home, join_tolerance=-1)
    cpu = time.process_time() - cpu
    travel = travel_length(ordered, home)
    figures = {
        "cpu_s": round(cpu, 3),
        "rounds": min(DEFAULT_ROUNDS, max(MIN_ROUNDS, ROUND_WORK // size)),
        "pen_up_mm": round(travel, 1),
    }
    if size <= 100_000:
        bound = travel_lower_bound(paths, home)
        figures.update(
            lower_bound_mm=round(bound, 1),
            travel_vs_bound=round(travel / bound, 4),
            vs_greedy=round(travel / travel_length(greedy_order(paths, home), home), 4),
        )
    if size <= 10_000:
        figures.update(_vpype_two_opt(paths, home))
    return figures


def _vpype_two_opt(paths, home) -> dict:
    """vpype's ``linesort --two-opt`` on the same strokes; its pen-up counted from home."""
    import numpy as np
    import vpype
    import vpype_cli

    from pencilbot.paths import Paths
    from pencilbot.planning.ordering import travel_length

    document = vpype.Document()
    document.add(vpype.LineCollection([p[:, 0] + 1j * p[:, 1] for p in paths]), 1)
    cpu = time.process_time()
    document = vpype_cli.execute("linesort --two-opt", document=document)
    cpu = time.process_time() - cpu
    lines = Paths.of(np.stack([line.real, line.imag], axis=1) for line in document.layers[1])
    return {
        "vpype_two_opt_pen_up_mm": round(travel_length(lines, home), 1),
        "vpype_two_opt_cpu_s": round(cpu, 2),
    }


# -- stages on photos ---------------------------------------------------------------------------


def photo(pixels: int, aspect: float, scratch: Path) -> Path:
    """A JPEG of about ``pixels`` pixels (width / height = ``aspect``), made once per scratch folder.

    Made by a child process: a child's peak memory (ru_maxrss) starts from its parent's at the
    fork, so this process stays small.
    """
    width = round(math.sqrt(pixels * aspect))
    height = round(pixels / width)
    path = scratch / f"photo-{width}x{height}.jpg"
    if not path.exists():
        subprocess.run(_child(["photo", f"{width}x{height}:{path}"]), check=True)
    return path


def photo_child(spec: str) -> None:
    import cv2
    from skimage import data

    size, path = spec.split(":", 1)
    width, height = map(int, size.split("x"))
    rgb = cv2.resize(data.astronaut(), (width, height), interpolation=cv2.INTER_CUBIC)
    cv2.imwrite(path, cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 90])


def _command_summary(
    target_size: int,
    cpu_max: float | None,
    extra_cpu_max: float | None,
    rss_max: float | None,
    unit: str = "pixels",
    size_of: Callable[[int], float] = float,
):
    """Exponent of CPU over ``size_of(size)``; targets at ``target_size``: CPU, CPU beyond the
    smallest size, peak memory."""

    def summary(runs: list[dict]) -> dict:
        at = {r[unit]: r for r in runs}
        smallest, largest = runs[0], at.get(target_size)
        figures = {
            "exponent_all": exponent([size_of(r[unit]) for r in runs], [r["process_cpu_s"] for r in runs])
        }
        targets, met = {}, {}
        if largest is not None:
            figures["cpu_s_beyond_smallest"] = round(largest["process_cpu_s"] - smallest["process_cpu_s"], 3)
            if extra_cpu_max is not None:
                targets["cpu_s_beyond_smallest_max"] = extra_cpu_max
                met["cpu_beyond_smallest"] = figures["cpu_s_beyond_smallest"] <= extra_cpu_max
            if cpu_max is not None:
                targets["cpu_s_max"] = cpu_max
                met["cpu"] = largest["process_cpu_s"] <= cpu_max
            if rss_max is not None:
                targets["peak_rss_mb_max"] = rss_max
                met["memory"] = largest["peak_rss_mb"] <= rss_max
        return {**figures, "targets": targets, "met": met}

    return summary


@stage(
    "plan",
    unit="pixels",
    sizes=(100_000, 400_000, 1_500_000, 6_000_000, 24_000_000),
    quick=(100_000, 1_500_000, 6_000_000, 24_000_000),
    summary=_command_summary(24_000_000, None, 1.5, 350),
)
def plan_command(size: int, scratch: Path) -> list[str]:
    return _pencilbot(
        "plan", str(photo(size, 1.5, scratch)), "-o", str(scratch / "plan.svg"), "-q", "--page", "A4"
    )


@stage(
    "sketch",
    unit="pixels",
    sizes=(120_000, 500_000, 2_000_000, 5_000_000, 12_000_000),
    quick=(120_000, 2_000_000, 12_000_000),
    summary=_command_summary(12_000_000, 3.0, None, None),
)
def sketch_command(size: int, scratch: Path) -> list[str]:
    return _pencilbot("sketch", str(photo(size, 1.0, scratch)), "-o", str(scratch / "sketch.png"), "-q")


# -- stages on plans and G-code -----------------------------------------------------------------


def made_by_child(kind: str, size: int, suffix: str, scratch: Path) -> Path:
    """``scratch/KIND-SIZE.SUFFIX``, made once by a child process (so this process stays small)."""
    path = scratch / f"{kind}-{size}{suffix}"
    if not path.exists():
        subprocess.run(_child([kind, f"{size}:{path}"]), check=True)
    return path


def plan_svg_child(spec: str) -> None:
    """bench/gcode.py's plan of SIZE random strokes on A4, as pencilbot's plan SVG."""
    from pencilbot.export.svg import write_svg

    size, path = spec.split(":", 1)
    sys.path.insert(0, str(HERE))
    from gcode import stroke_plan

    write_svg(stroke_plan(int(size)), path)


def job_gcode_child(spec: str) -> None:
    """bench/gcode.py's plan of SIZE random strokes on A4 as G-code for grbl-servo-a4."""
    from pencilbot.export.gcode import write_gcode
    from pencilbot.machine.profile import load_profile

    size, path = spec.split(":", 1)
    sys.path.insert(0, str(HERE))
    from gcode import stroke_plan

    write_gcode(stroke_plan(int(size)), load_profile("grbl-servo-a4"), path)


A0_BED = (850.0, 1200.0)  # mm
A0_STROKES = 20_000


def a0_child(spec: str) -> None:
    """An A0 GRBL profile (the shipped servo one, bed enlarged) and a plan of SIZE strokes on A0."""
    import numpy as np

    from pencilbot.export.svg import write_svg
    from pencilbot.planning.plan import Layer, Page, Plan

    size, path = spec.split(":", 1)
    shipped = (HERE.parent / "configs" / "plotters" / "grbl-servo-a4.toml").read_text()
    profile = shipped.replace('name = "grbl-servo-a4"', 'name = "grbl-servo-a0"')
    profile = profile.replace("width = 220.0 ", f"width = {A0_BED[0]} ").replace(
        "height = 310.0 ", f"height = {A0_BED[1]} "
    )
    Path(path).with_suffix(".toml").write_text(profile)
    rng = np.random.default_rng(0)
    n = int(size)
    start = rng.uniform([20, 20], [821, 1169], size=(n, 2))
    angle, length = rng.uniform(0, np.pi, n), rng.uniform(1, 8, n)
    end = start + length[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    write_svg(
        Plan(Page(841.0, 1189.0, name="A0"), [Layer("strokes", list(np.stack([start, end], axis=1)))]), path
    )


@stage(
    "export",
    unit="strokes",
    sizes=(10_000, 30_000, 100_000, 300_000, 1_000_000),
    quick=(10_000, 100_000, 300_000, 1_000_000),
    summary=_command_summary(1_000_000, 4.0, None, None, unit="strokes"),
)
def export_command(size: int, scratch: Path) -> list[str]:
    svg = made_by_child("plan_svg", size, ".svg", scratch)
    return _pencilbot(
        "export", str(svg), "-o", str(scratch / "plan.gcode"), "-q", "--profile", "grbl-servo-a4"
    )


def _bed_pixels(dpi: float) -> float:
    return math.ceil(A0_BED[0] / 25.4 * dpi) * math.ceil(A0_BED[1] / 25.4 * dpi)


@stage(
    "simulate",
    unit="dpi",
    sizes=(60, 120, 300, 600),
    quick=(60, 300, 600),
    summary=_command_summary(600, None, None, 2048, unit="dpi", size_of=_bed_pixels),
)
def simulate_command(size: int, scratch: Path) -> list[str]:
    svg = made_by_child("a0", A0_STROKES, ".svg", scratch)
    return _pencilbot(
        "simulate",
        str(svg),
        "-o",
        str(scratch / "a0.png"),
        "-q",
        "--dpi",
        str(size),
        "--profile",
        str(svg.with_suffix(".toml")),
    )


def _draw_summary(runs: list[dict]) -> dict:
    small, big = runs[0], runs[-1]
    per_line = (big["peak_rss_mb"] - small["peak_rss_mb"]) * 2**20 / (big["lines"] - small["lines"])
    return {
        "exponent_all": exponent([r["lines"] for r in runs], [r["process_cpu_s"] for r in runs]),
        "bytes_per_line": round(per_line, 1),
        "lines_per_cpu_s": round(big["lines"] / big["process_cpu_s"]),
        "targets": {"bytes_per_line_max": 120},
        "met": {"bytes_per_line": per_line <= 120},
    }


_SERVER: dict[str, str] = {}  # the one `pencilbot sim-serve` of a draw stage: its pty, once started


def _plotter_port() -> str:
    """The pty of a virtual plotter in its own process (started once, stopped when the bench ends)."""
    if not _SERVER:
        server = subprocess.Popen(
            _pencilbot("sim-serve", "--realtime", "0", "--power", "keep", "--abort", "keep", "-q"),
            stdout=subprocess.PIPE,
            text=True,
        )
        atexit.register(lambda: (server.terminate(), server.wait()))
        _SERVER["port"] = server.stdout.readline().strip()  # it prints its device path first
    return _SERVER["port"]


def _draw_traced(scratch: Path) -> dict:
    job = made_by_child("job_gcode", 25_000, ".gcode", scratch)
    return {"traced_bytes_per_line": measure(_child(["draw_traced", str(job)]))}


@stage(
    "draw",
    unit="lines",
    sizes=(15_014, 50_014, 150_014, 1_500_014),
    quick=(15_014, 150_014, 1_500_014),
    summary=_draw_summary,
    extra=_draw_traced,
)
def draw_command(size: int, scratch: Path) -> list[str]:
    job = made_by_child("job_gcode", (size - 14) // 6, ".gcode", scratch)  # 6 lines a stroke, 14 around
    return _pencilbot("draw", str(job), "--port", _plotter_port(), "-q")


def draw_traced_child(job: str) -> dict:
    """Bytes per line held after ``draw`` of ``job`` over sim://, by the part that holds them."""
    import tracemalloc

    import sim
    from pencilbot.driver import draw

    sim.register()
    program = Path(job).read_bytes()
    lines = program.count(b"\n")
    tracemalloc.start()
    draw(program, "sim://traced", profile="grbl-servo-a4", progress="quiet")
    snapshot = tracemalloc.take_snapshot()
    parts: dict[str, int] = {}
    for stat in snapshot.statistics("filename"):
        name = stat.traceback[0].filename
        part = next(
            (p for p in ("sim/gcode/firmware.py", "sim/", "pencilbot/driver/", "pencilbot/") if p in name),
            "other",
        )
        parts[part] = parts.get(part, 0) + stat.size
    return {"lines": lines, **{part: round(size / lines, 1) for part, size in sorted(parts.items())}}


# -- stages on inputs at the door (issue 25) -----------------------------------------------------


def walk_svg_child(spec: str) -> None:
    """Another tool's SVG of SIZE MB: one path, a random walk of 0.6 mm steps over A4 (a
    vpype- or hatching-tool-like straight-line file; 16 bytes a point)."""
    import numpy as np

    size, path = spec.split(":", 1)
    steps = np.random.default_rng(1).normal(0, 0.6, (int(float(size) * 1e6 / 16), 2))
    points = 10 + np.abs(np.cumsum(steps, axis=0) % 380 - 190)  # folded into 10..200 mm
    with open(path, "w") as out:
        out.write(
            '<svg xmlns="http://www.w3.org/2000/svg" width="210mm" height="297mm" viewBox="0 0 210 297">'
            '<path stroke="black" fill="none" stroke-width="0.3" d="M'
        )
        for block in np.array_split(points, max(1, len(points) // 100_000)):
            out.write(" L".join(f" {x:.2f} {y:.2f}" for x, y in block.tolist()) + " L")
        out.write(f' {points[-1, 0]:.2f} {points[-1, 1]:.2f}"/></svg>')


_SVG_MB = (5, 15, 50)


@stage(
    "svg_stat",
    unit="megabytes",
    sizes=_SVG_MB,
    quick=(5, 50),
    summary=_command_summary(50, 30.0, None, 2048, unit="megabytes"),
)
def svg_stat_command(size: int, scratch: Path) -> list[str]:
    return _pencilbot("stat", str(made_by_child("walk_svg", size, ".svg", scratch)), "-q")


@stage(
    "svg_export",
    unit="megabytes",
    sizes=_SVG_MB,
    quick=(5, 50),
    summary=_command_summary(50, 30.0, None, 2048, unit="megabytes"),
)
def svg_export_command(size: int, scratch: Path) -> list[str]:
    svg = made_by_child("walk_svg", size, ".svg", scratch)
    return _pencilbot(
        "export", str(svg), "-o", str(scratch / "walk.gcode"), "-q", "--profile", "grbl-servo-a4"
    )


@stage(
    "simulate_gcode",
    unit="lines",
    sizes=(300_014, 1_000_014, 3_000_014),
    quick=(300_014, 3_000_014),
    summary=_command_summary(3_000_014, 30.0, None, 2048, unit="lines"),
)
def simulate_gcode_command(size: int, scratch: Path) -> list[str]:
    job = made_by_child("job_gcode", (size - 14) // 6, ".gcode", scratch)  # 6 lines a stroke, 14 around
    return _pencilbot("simulate", str(job), "-o", str(scratch / "job.png"), "-q")


# -- stages on a million tiny paths (issue 35; bench/scale_tiny.py) -------------------------------

sys.path.insert(0, str(HERE))
import scale_tiny  # noqa: E402


def _tiny_stage(name: str) -> None:
    def command(size: int, scratch: Path) -> list[str]:
        svg = made_by_child("tiny_svg", size, ".svg", scratch)
        return _pencilbot(*scale_tiny.commands(svg, scratch)[name])

    stage(name, unit="paths", sizes=scale_tiny.SIZES, quick=scale_tiny.SIZES[1:], summary=scale_tiny.summary)(
        command
    )


for _name in ("tiny_stat", "tiny_optimize", "tiny_export", "tiny_simulate"):
    _tiny_stage(_name)


def big_png_child(spec: str) -> None:
    """A SIZE x SIZE RGB PNG of skimage's astronaut (nearest-neighbour enlarged), written a strip
    of rows at a time with PNG's Up filter (this process never holds the picture either)."""
    import struct
    import zlib

    import numpy as np
    from skimage import data

    size, path = spec.split(":", 1)
    side = int(size)
    source = data.astronaut()
    columns = np.arange(side) * source.shape[1] // side

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    squeeze = zlib.compressobj(1)
    with open(path, "wb") as out:
        out.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", side, side, 8, 2, 0, 0, 0)))
        previous = np.zeros(side * 3, np.uint8)
        for top in range(0, side, 1000):
            rows = source[np.arange(top, min(top + 1000, side)) * source.shape[0] // side][
                :, columns
            ].reshape(-1, side * 3)
            up = np.diff(np.vstack([previous, rows]), axis=0)  # uint8: modulo 256, as the Up filter
            previous = rows[-1]
            out.write(
                chunk(
                    b"IDAT", squeeze.compress(np.hstack([np.full((len(up), 1), 2, np.uint8), up]).tobytes())
                )
            )
        out.write(chunk(b"IDAT", squeeze.flush()) + chunk(b"IEND", b""))


def _downscale_summary(runs: list[dict]) -> dict:
    big = runs[-1]
    full = big["pixels"] * 4 / 2**20  # Pillow's RGBA-sized buffer of the whole picture, MB
    return {
        "full_picture_mb": round(full),
        "targets": {"peak_rss_mb_max": round(full / 4)},
        "met": {"memory": big["peak_rss_mb"] <= full / 4},
    }


@stage(
    "downscale_png",
    unit="pixels",
    sizes=(100_000_000, 900_000_000),
    quick=(900_000_000,),
    summary=_downscale_summary,
)
def downscale_png_command(size: int, scratch: Path) -> list[str]:
    png = made_by_child("big_png", round(math.sqrt(size)), ".png", scratch)
    return _pencilbot(
        "sketch",
        str(png),
        "-o",
        str(scratch / "big-sketch.png"),
        "-q",
        "--downscale",
        "--max-pixels",
        "1000000",
    )


CHILDREN = {
    "tiny_svg": scale_tiny.tiny_svg_child,
    "walk_svg": walk_svg_child,
    "ordering": lambda size: ordering_child(int(size)),
    "photo": photo_child,
    "plan_svg": plan_svg_child,
    "job_gcode": job_gcode_child,
    "a0": a0_child,
    "draw_traced": draw_traced_child,
    "big_png": big_png_child,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--stage", action="append", choices=sorted(STAGES), help="stages to run (default: all)"
    )
    parser.add_argument("--quick", action="store_true", help="fewer sizes")
    parser.add_argument("--repeats", type=int, default=1, help="runs per size; the median is reported")
    parser.add_argument("--child", nargs=2, metavar=("STAGE", "SIZE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        figures = CHILDREN[args.child[0]](args.child[1])
        if figures is not None:
            print(json.dumps(figures))
        return
    report = {
        "cpu": "user + system seconds of the whole fresh process (cpu_s: the call alone)",
        "memory": "peak resident set of that process (os.wait4 ru_maxrss)",
        "stages": {},
    }
    with tempfile.TemporaryDirectory() as scratch:
        for name in args.stage or list(STAGES):
            chosen = STAGES[name]
            report["stages"][name] = run_stage(
                chosen, chosen.quick_sizes if args.quick else chosen.sizes, args.repeats, Path(scratch)
            )
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
