"""Reordering other tools' drawings: `pencilbot optimize` against vpype's `linesort`.

Prints JSON. Eleven foreign drawings of different kinds on A4 (0.5 mm pen), made by
bench/foreign_drawings.py from data the packages ship (sources and licences:
bench/drawings/README.md): two line-drawing portraits and a photo plan whose order was lost
(shuffled, half reversed), hatching, contours, a topographic map, an edge tracer's line drawing,
Hershey text, stippling, a flow-field and random segments, each in the order its kind of tool
writes it. With ``--hatched PYTHON`` (a Python that has ``pip install hatched``; hatched 0.2
needs a shim for shapely 2, applied here) the hatching is the real hatched's output instead.

For each: pen-up travel and plot time (``planning.stats.estimate`` on grbl-servo-a4, from its
home and back) as written, after vpype ``linesort``, after ``linesort --two-opt`` and after
pencilbot's reordering (:func:`pencilbot.planning.optimize.reorder_plan`, what ``pencilbot
optimize`` runs), and each tool's CPU time (the reordering alone, in process, as vpype's
``vpype_cli.execute`` is timed; the median of ``--repeats`` runs). vpype starts at its origin, which is put at the plotter's home. Goal: pen-up <= 0.97 x ``linesort --two-opt`` on every drawing, in
less CPU time. Timings share 2 cores with other work.

Usage: ``python bench/optimize.py [--hatched PYTHON] [--repeats N] [--drawing NAME ...]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from skimage import data

from pencilbot.export.svg_read import read_svg
from pencilbot.machine.bed import Placement
from pencilbot.machine.profile import load_profile
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.optimize import reorder_plan
from pencilbot.planning.plan import Layer, Plan
from pencilbot.planning.stats import estimate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from foreign_drawings import DRAWINGS

PROFILE = "grbl-servo-a4"
PEN = 0.5
GOALS = {"pen_up_vs_two_opt_max": 0.97, "cpu_vs_two_opt_max": 1.0}  # issue 35: less time than vpype


def coffee_layout():
    grey = data.coffee().mean(axis=2) / 255.0
    page = page_size("A4", "auto", grey.shape, 15.0)
    return grey, Layout.fit(grey.shape, page)


def real_hatched(python: str) -> Plan:
    """hatched 0.2's own SVG of the photo (run in ``python``), read as pencilbot reads any SVG."""
    shim = f"""
import sys
sys.path.insert(0, {str(Path(__file__).resolve().parent)!r})
from hatched_compat import patch_hatched
hatched = patch_hatched()
hatched.hatch(sys.argv[1], hatch_pitch=float(sys.argv[2]), show_plot=False, save_svg=True)
"""
    import cv2

    grey, layout = coffee_layout()
    with tempfile.TemporaryDirectory() as tmp:
        photo = Path(tmp) / "coffee.png"
        cv2.imwrite(str(photo), np.rint(grey * 255).astype(np.uint8))
        subprocess.run(
            [python, "-c", shim, str(photo), str(1.0 / layout.mm_per_px)],
            check=True,
            capture_output=True,
            timeout=600,
        )
        drawn = read_svg(photo.with_suffix(".svg"), dpi=25.4 / layout.mm_per_px)  # 1 user unit = 1 px
    return Plan(drawn.page, [Layer("hatching", layer.paths, pen_width=PEN) for layer in drawn.layers])


def drawing(name: str) -> Plan:
    page, layers = DRAWINGS[name]()
    return Plan(page, [Layer(layer, paths, pen_width=PEN) for layer, paths in layers])


def timed(work, repeats: int):
    """``work()``'s result and its median CPU seconds over ``repeats`` runs."""
    seconds = []
    for _ in range(repeats):
        started = time.process_time()
        result = work()
        seconds.append(time.process_time() - started)
    return result, statistics.median(seconds)


def vpype_sorted(plan: Plan, home: np.ndarray, repeats: int, *options: str) -> tuple[Plan, float]:
    """Each layer through vpype's ``linesort``, which starts at its origin (put at ``home``); its CPU seconds."""
    import vpype
    import vpype_cli

    def run():
        document = vpype.Document()
        for lid, layer in enumerate(plan.layers, start=1):
            document.add(
                vpype.LineCollection([(p[:, 0] - home[0]) + 1j * (p[:, 1] - home[1]) for p in layer.paths]),
                lid,
            )
        return vpype_cli.execute(" ".join(["linesort", *options]), document=document)

    document, seconds = timed(run, repeats)
    layers = [
        Layer(
            layer.name,
            [np.column_stack([line.real, line.imag]) + home for line in document.layers[lid]],
            pen_width=layer.pen_width,
        )
        for lid, layer in enumerate(plan.layers, start=1)
    ]
    return Plan(plan.page, layers), seconds


def figures(plan: Plan, profile) -> dict:
    total = estimate(plan, profile).total
    return {
        "pen_up_m": round(total.pen_up_mm / 1000, 3),
        "plot_s": round(total.seconds, 1),
        "lifts": total.lifts,
    }


def compare(plan: Plan, profile, repeats: int) -> dict:
    # vpype drops one-point paths: they leave every tool's result alike.
    plan = Plan(
        plan.page,
        [Layer(l.name, [p for p in l.paths if len(p) > 1], pen_width=l.pen_width) for l in plan.layers],
    )
    home = Placement.on_bed(plan.page, profile.bed).home()
    row = {"paths": len(plan.paths()), "as_written": figures(plan, profile)}
    greedy, greedy_s = vpype_sorted(plan, home, repeats)
    row["vpype_linesort"] = {**figures(greedy, profile), "cpu_s": round(greedy_s, 3)}
    two_opt, two_opt_s = vpype_sorted(plan, home, repeats, "--two-opt")
    row["vpype_linesort_two_opt"] = {**figures(two_opt, profile), "cpu_s": round(two_opt_s, 3)}
    ours, ours_s = timed(lambda: reorder_plan(plan, start=tuple(home)), repeats)
    row["pencilbot_optimize"] = {
        **figures(ours.plan, profile),
        "cpu_s": round(ours_s, 3),
        "specks_dropped": ours.specks,
    }
    pen_up = row["pencilbot_optimize"]["pen_up_m"] / row["vpype_linesort_two_opt"]["pen_up_m"]
    cpu = ours_s / two_opt_s
    row["vs_two_opt"] = {
        "pen_up": round(pen_up, 3),
        "cpu": round(cpu, 3),
        "met": pen_up <= GOALS["pen_up_vs_two_opt_max"] and cpu <= GOALS["cpu_vs_two_opt_max"],
    }
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--hatched", metavar="PYTHON", help="a Python with hatched installed: use its real output"
    )
    parser.add_argument(
        "--repeats", type=int, default=3, help="runs of each tool; the median CPU time is reported"
    )
    parser.add_argument(
        "--drawing", action="append", choices=sorted(DRAWINGS), help="drawings to run (default: all)"
    )
    args = parser.parse_args()
    profile = load_profile(PROFILE)
    names = args.drawing or list(DRAWINGS)
    report = {
        "setup": f"A4, {PEN} mm pen, {PROFILE}; CPU seconds of the reordering alone, median of "
        f"{args.repeats} runs; drawings: bench/foreign_drawings.py (sources: bench/drawings/README.md)",
        "goals": GOALS,
    }
    for name in names:
        plan = real_hatched(args.hatched) if (name == "hatching" and args.hatched) else drawing(name)
        report[name] = compare(plan, profile, args.repeats)
        print(f"{name}: {report[name]['vs_two_opt']}", file=sys.stderr)
    report["all_met"] = all(report[name]["vs_two_opt"]["met"] for name in names)
    report["worst_pen_up_ratio"] = max(report[name]["vs_two_opt"]["pen_up"] for name in names)
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
