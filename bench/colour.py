"""Colour on paper: how close the simulated colour plot comes to the colour sketch and to the photo
(issues 14, 35).

For each photo (skimage.data coffee, astronaut, chelsea, rocket; also any photo of
``bench/fidelity.py``, e.g. grace_hopper, a portrait the colour planning was not tuned on, or
messi5) the default style plans an A4
sheet (15 mm margin, orientation auto) with each pen set asked for (default ``cmyk``) and, as
the baseline, with the one black pen. Each plan is written as G-code for grbl-servo-a4 and
streamed through the driver into the virtual plotter (``sim://``, its operator loading each pen
at the pen change); the plotter's pen-down strokes, told apart by the pen changes they followed,
are stacked as ink layers on paper (:func:`pencilbot.colors.inks_on_paper`). The yardstick:

* ``delta_e00_vs_sketch``: mean CIEDE2000 ΔE00 between the colour sketch (``sketch --color``,
  what the plan is planned from) and the simulated plot, both Gaussian-blurred by σ (each of
  ``--scales``, mm; default 1 and 3) in linear light (:func:`pencilbot.planning.fidelity.color_difference`);
  ``delta_e00_plan_vs_sketch`` the same of the plan's own strokes (no plotter between);
* ``delta_e00_vs_photo``: the same between the photo itself (at the sketch's resolution) and the
  simulated plot. The sketch is a pencil drawing: its tone is the pencil model's (light, the
  paper showing), only its hue and chroma are the photo's, so this figure says how far the
  drawing's style is from the photo, not how well the pens mix;
* per pen: pen-down length (m) and plot time (acceleration-aware estimate, min); in all: the
  simulated plot time (pen changes not counted: the operator is instant).

``--montage DIR`` writes ``DIR/<photo>.png``: photo | colour sketch | each pen set's simulated plot
| black plot, side by side at one height.

Usage: ``python bench/colour.py [--photos coffee,astronaut,grace_hopper] [--pens cmyk,primaries]
[--scales 1,3] [--montage DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import urllib.parse
from pathlib import Path

import cv2
import numpy as np

# bench/fidelity.py: the bench photos and where each comes from
from fidelity import PHOTOS as SOURCES
from fidelity import photo

import sim
from pencilbot.commands.simulate import strokes_by_pen
from pencilbot.driver import draw
from pencilbot.export.gcode import PenInFile, gcode_program, pens_at_pauses
from pencilbot.machine.bed import Placement
from pencilbot.machine.pens import load_pens
from pencilbot.machine.profile import load_profile
from pencilbot.planning.build import sketch_and_plan
from pencilbot.planning.fidelity import color_difference, plan_color
from pencilbot.planning.plan import BLACK, Layer, Plan
from pencilbot.planning.stats import estimate
from sim import protocol_sim

PROFILE = "grbl-servo-a4"
PHOTOS = ("coffee", "astronaut", "chelsea", "rocket")
TARGETS = {"delta_e00_vs_sketch_3mm_max": 3.0, "delta_e00_vs_sketch_1mm_max": 4.0}


def simulated_plan(plan: Plan, profile) -> tuple[Plan, float]:
    """What the virtual plotter drew of ``plan``'s G-code, as a plan of one layer per pen (page
    mm), and the simulated seconds."""
    sim.register()
    program = gcode_program(plan, profile)
    pens = pens_at_pauses(program)
    name = f"bench-colour-{os.getpid()}"
    query = urllib.parse.urlencode({"profile": PROFILE, **({"operator": "auto"} if pens else {})})
    try:
        draw(program, f"sim://{name}?{query}", profile=PROFILE, progress="quiet")
        plotter = protocol_sim.plotter(name)
        plotter.firmware.finish()
        placement = Placement.on_bed(plan.page, profile.bed)
        default = PenInFile("", plan.layers[0].color if plan.layers else BLACK, plan.pen_width)
        layers = [
            Layer(
                ink.name or "drawn",
                [placement.to_page(s[:, :2]) for s in strokes],
                pen_width=ink.width,
                pen=ink.name,
                color=ink.color,
            )
            for ink, strokes in strokes_by_pen(plotter.machine, pens, default=default)
        ]
        seconds = plotter.seconds
    finally:
        protocol_sim.forget(name)
    return Plan(page=plan.page, layers=layers, meta=plan.meta), seconds


def per_pen(plan: Plan, profile) -> dict:
    """Pen-down metres and estimated minutes of each pen run of ``plan``."""
    out = {}
    for pen, layers in plan.pen_runs():
        total = estimate(Plan(page=plan.page, layers=layers), profile).total
        out[pen or "black"] = {
            "pen_down_m": round(total.pen_down_mm / 1000, 1),
            "plot_min": round(total.seconds / 60, 1),
        }
    return out


def measure(name: str, pen_sets: list[str], scales: list[float], montage: Path | None) -> dict:
    image = photo(name)
    if image is None:
        raise SystemExit(f"{name}: not installed ({SOURCES.get(name, ('', 'no such photo'))[1]})")
    profile = load_profile(PROFILE)
    result, pictures, reference = {}, [], None
    for pens in [*pen_sets, None]:
        drawing, plan = sketch_and_plan(image, pens=None if pens is None else load_pens(pens))
        if reference is None:
            if drawing.result.ndim != 3:
                raise SystemExit(
                    "give at least one pen set of several pens: the colour sketch is the reference"
                )
            reference = drawing.result  # every plan is of the same image at the same plot size
            original = cv2.resize(
                np.asarray(image.rgb, np.float32), reference.shape[1::-1], interpolation=cv2.INTER_AREA
            )
        drawn, seconds = simulated_plan(plan, profile)
        result[pens or "black_only"] = {
            **{
                f"delta_e00_{key}": {
                    f"{s:g}mm": round(color_difference(what, against, blur=s), 2) for s in scales
                }
                for key, what, against in (
                    ("vs_sketch", drawn, reference),
                    ("vs_photo", drawn, original),
                    ("plan_vs_sketch", plan, reference),
                )
            },
            "simulated_plot_min": round(seconds / 60, 1),
            "pens": per_pen(plan, profile),
        }
        pictures.append(plan_color(drawn, reference.shape[:2])[0])
    if montage is not None:
        write_montage(montage / f"{name}.png", [image.rgb, reference, *pictures])
    return result


def write_montage(path: Path, pictures: list[np.ndarray], height: int = 500) -> None:
    panels = []
    for picture in pictures:
        h, w = picture.shape[:2]
        panels += [
            cv2.resize(
                np.asarray(picture, np.float32), (round(w * height / h), height), interpolation=cv2.INTER_AREA
            ),
            np.ones((height, 12, 3), np.float32),
        ]
    row = np.concatenate(panels[:-1], axis=1)
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(
        str(path), cv2.cvtColor(np.rint(np.clip(row, 0, 1) * 255).astype(np.uint8), cv2.COLOR_RGB2BGR)
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", default=",".join(PHOTOS))
    parser.add_argument("--pens", default="cmyk", help="pen sets to measure, comma-separated (default cmyk)")
    parser.add_argument(
        "--scales", default="1,3", help="Gaussian blurs (mm) to compare at, comma-separated (default 1,3)"
    )
    parser.add_argument("--montage", type=Path, help="write photo | sketch | plots PNGs here")
    args = parser.parse_args()
    scales = [float(s) for s in args.scales.split(",")]
    results: dict = {
        "setup": f"default style, A4 auto, 15 mm margin, {PROFILE}, simulated through sim://; "
        "mean CIEDE2000 after a Gaussian blur (each scale) in linear light, of the simulated plot "
        "against the colour sketch it was planned from (vs_sketch) and against the photo (vs_photo), "
        "of the plan's own strokes against the sketch (plan_vs_sketch)"
    }
    for name in args.photos.split(","):
        results[name] = measure(name, args.pens.split(","), scales, args.montage)
    results["targets"] = TARGETS
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
