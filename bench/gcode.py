"""How fast a plan becomes G-code: seconds to write a 100 000-stroke plan, bytes per stroke.

Run: ``python bench/gcode.py [--strokes N] [--profile NAME]``. Prints one JSON object. The plan is
100 000 short two-point strokes (the shape of an edge or hatch layer) spread over an A4 page with a
fixed seed. ``write_seconds`` is the whole :func:`write_gcode` call (placement, bed check, time
estimate, formatting, atomic write), wall clock; ``write_cpu_seconds`` the CPU time of the same
call, which stays meaningful when other jobs share the machine; ``estimate_seconds`` is the part
spent in :func:`pencilbot.planning.stats.estimate`. Target: ``write_seconds`` ≤ 1 s on the
2-core reference machine (the best of ``--repeat`` runs is reported).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from pencilbot.machine.profile import load_profile
from pencilbot.export.gcode import write_gcode
from pencilbot.planning.stats import estimate
from pencilbot.planning.plan import Layer, Page, Plan


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--strokes", type=int, default=100_000)
    parser.add_argument("--profile", default="grbl-servo-a4")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    plan = stroke_plan(args.strokes)
    profile = load_profile(args.profile)
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "bench.gcode"
        seconds = best_of(args.repeat, lambda: write_gcode(plan, profile, out, source="bench"))
        cpu = best_of(args.repeat, lambda: write_gcode(plan, profile, out, source="bench"), time.process_time)
        summary = write_gcode(plan, profile, out, source="bench")
    estimate_seconds = best_of(args.repeat, lambda: estimate(plan, profile))
    print(json.dumps({
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
    }))


if __name__ == "__main__":
    main()
