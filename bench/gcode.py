"""How fast a plan becomes G-code: seconds to write a 100 000-stroke plan, bytes per stroke.

Run: ``python bench/gcode.py [--strokes N] [--profile NAME] [--from-svg]``. Prints one JSON object. The plan is
100 000 short two-point strokes (the shape of an edge or hatch layer) spread over an A4 page with a
fixed seed. ``write_seconds`` is the whole :func:`write_gcode` call (placement, bed check, time
estimate, formatting, atomic write), wall clock; ``write_cpu_seconds`` the CPU time of the same
call, which stays meaningful when other jobs share the machine; ``estimate_seconds`` is the part
spent in :func:`pencilbot.planning.stats.estimate`. Target: ``write_seconds`` ≤ 1 s on the
2-core reference machine (the best of ``--repeat`` runs is reported).

``--from-svg`` measures instead what a user pays to export the plan from its SVG (issue 16: a
million strokes in <= 4 s CPU): the plan is written with ``write_svg``, then ``pencilbot export
PLAN.svg`` runs as a fresh process (start-up included) whose CPU time (user + system, from
``os.wait4``) and peak memory are its own; ``read_svg_cpu_seconds`` is reading the SVG alone,
in this process.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pencilbot.export.gcode import write_gcode
from pencilbot.export.svg import write_svg
from pencilbot.export.svg_read import read_svg
from pencilbot.machine.profile import load_profile
from pencilbot.planning.plan import Layer, Page, Plan
from pencilbot.planning.stats import estimate


def stroke_plan(strokes: int, seed: int = 0) -> Plan:
    """``strokes`` random 1–5 mm strokes inside the margins of an A4 portrait page."""
    rng = np.random.default_rng(seed)
    start = rng.uniform([15, 15], [195, 282], size=(strokes, 2))
    angle = rng.uniform(0, np.pi, strokes)
    length = rng.uniform(1, 5, strokes)
    end = start + length[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    paths = list(np.stack([start, end], axis=1))
    return Plan(Page(210.0, 297.0, name="A4"), [Layer("strokes", paths)])


def best_of(repeat: int, run, clock=time.perf_counter) -> float:
    times = []
    for _ in range(repeat):
        t0 = clock()
        run()
        times.append(clock() - t0)
    return min(times)


def export_from_svg(plan: Plan, profile_name: str, repeat: int) -> dict:
    """CPU and peak memory of ``pencilbot export PLAN.svg`` as its own process; reading alone."""
    with tempfile.TemporaryDirectory() as folder:
        svg, out = Path(folder) / "plan.svg", Path(folder) / "plan.gcode"
        write_svg(plan, svg)
        runs = []
        for _ in range(repeat):
            child = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "pencilbot.cli",
                    "export",
                    str(svg),
                    "-o",
                    str(out),
                    "--profile",
                    profile_name,
                    "-q",
                ]
            )
            _, status, usage = os.wait4(child.pid, 0)
            assert os.waitstatus_to_exitcode(status) == 0
            runs.append((usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024))
        read = best_of(repeat, lambda: read_svg(svg), time.process_time)
        size = svg.stat().st_size
    cpu, peak = min(runs)
    return {
        "svg_bytes": size,
        "export_cpu_seconds": round(cpu, 3),
        "export_peak_rss_mb": round(peak),
        "read_svg_cpu_seconds": round(read, 3),
        "target_cpu_seconds": 4.0,
        "meets_target": cpu <= 4.0,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--strokes", type=int, default=100_000)
    parser.add_argument("--profile", default="grbl-servo-a4")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--from-svg", action="store_true", help="time `pencilbot export PLAN.svg` as a user runs it"
    )
    args = parser.parse_args()
    plan = stroke_plan(args.strokes)
    profile = load_profile(args.profile)
    if args.from_svg:
        print(
            json.dumps(
                {
                    "profile": profile.name,
                    "strokes": args.strokes,
                    **export_from_svg(plan, args.profile, args.repeat),
                }
            )
        )
        return
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "bench.gcode"
        seconds = best_of(args.repeat, lambda: write_gcode(plan, profile, out, source="bench"))
        cpu = best_of(args.repeat, lambda: write_gcode(plan, profile, out, source="bench"), time.process_time)
        summary = write_gcode(plan, profile, out, source="bench")
    estimate_seconds = best_of(args.repeat, lambda: estimate(plan, profile))
    print(
        json.dumps(
            {
                "profile": profile.name,
                "strokes": args.strokes,
                "write_seconds": round(seconds, 3),
                "write_cpu_seconds": round(cpu, 3),
                "estimate_seconds": round(estimate_seconds, 3),
                "target_seconds": 1.0,
                "meets_target": seconds <= 1.0,
                "bytes": summary.bytes,
                "lines": summary.lines,
                "bytes_per_stroke": round(summary.bytes / args.strokes, 1),
            }
        )
    )


if __name__ == "__main__":
    main()
