"""Stroke-plan figures: size, plot time, planning speed, pen-up travel and fidelity.

Runs coffee (600×400), astronaut (512×512) and a 1 MP photo (astronaut upscaled to 1024×1024)
on A4 portrait, 15 mm margins, 0.5 mm pen, the default style, and prints JSON:

* paths (pen-down polylines: strokes joined where they meet), segments (straight strokes plus
  the short joins), pen-down / pen-up length, lifts and the estimated plot time on the
  grbl-servo-a4 profile (acceleration-aware, ``planning.stats.estimate``);
* ``planning_s``: :func:`plan_from_sketch` alone (after imaging; imaging time listed apart);
* ``pen_up_vs_greedy``: the plan's pen-up travel over that of plain nearest-neighbour ordering
  with reversal on the same paths, layer after layer from home, measured in the same run;
* ``line_fidelity``: Pearson r between the edge layer rendered on the image's pixel grid and the
  raster line drawing 1 − L, both Gaussian-blurred with σ = 2 px;
* ``tone_fidelity``: Pearson r and mean absolute difference between the whole plan's darkness
  and the raster pencil drawing 1 − R, both blurred with σ = 3 mm at plot scale.

Timings share 2 cores with other work: they are noisy, rerun before concluding.
Usage: ``python bench/plan.py``.
"""

from __future__ import annotations

import json
import time

import cv2
from skimage import data

from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.machine.profile import load_profile
from pencilbot.paths import Paths
from pencilbot.planning.build import HOME, plan_from_sketch
from pencilbot.planning.fidelity import fidelity
from pencilbot.planning.layout import Layout, ink_on_image_grid, page_size
from pencilbot.planning.ordering import greedy_order, travel_length
from pencilbot.planning.stats import estimate
from pencilbot.planning.style import load_style

PROFILE = "grbl-servo-a4"
TARGETS = {
    "planning_s": {"coffee": 1.0, "photo_1mp": 3.0},
    "pen_up_vs_greedy_max": 0.85,
    "line_fidelity_min": 0.85,
    "tone_fidelity_r_min": 0.90,
    "tone_fidelity_mae_max": 0.08,
}


def greedy_travel(plan) -> float:
    """Pen-up travel of plain greedy NN with reversal on the plan's own paths, layer by layer."""
    position, ordered = HOME, []
    for layer in plan.layers:
        paths = greedy_order(layer.paths, start=position)
        if len(paths):
            position = tuple(paths.points[-1])
        ordered.append(paths)
    return travel_length(Paths.concat(ordered), HOME)


def measure(name: str, rgb) -> dict:
    image = image_from_array(rgb, source=f"skimage.data.{name}")
    style = load_style("default")
    page = page_size("A4", "portrait", margin=15.0)
    started = time.perf_counter()
    drawing = sketch(image, line_length=style.line_length, texture_seed=style.seed)
    imaging_s = time.perf_counter() - started
    started = time.perf_counter()
    plan = plan_from_sketch(drawing, page, style, source=image.source)
    planning_s = time.perf_counter() - started

    stats = estimate(plan, load_profile(PROFILE))
    total = stats.total
    pen_up = travel_length(plan.paths(), HOME)

    layout = Layout.fit(image.shape, page)
    ink = ink_on_image_grid(plan.paths(), layout, pen_width=style.pen_width)
    faithful = fidelity(plan, drawing)
    return {
        "image_px": list(image.shape),
        "mm_per_px": round(layout.mm_per_px, 4),
        "paths_per_layer": {layer.name: len(layer.paths) for layer in plan.layers},
        "paths": total.paths,
        "segments": total.segments,
        "pen_down_mm": round(total.pen_down_mm, 1),
        "pen_up_mm": round(total.pen_up_mm, 1),
        "lifts": total.lifts,
        "plot_time_min": round(total.seconds / 60, 1),
        "imaging_s": round(imaging_s, 3),
        "planning_s": round(planning_s, 3),
        "pen_up_vs_greedy": round(pen_up / greedy_travel(plan), 3),
        "line_fidelity": round(faithful.line_r, 3),
        "tone_fidelity_r": round(faithful.tone_r, 3),
        "tone_fidelity_mae": round(faithful.tone_mae, 4),
        "darkness_mean": {
            "plot": round(float(ink.mean()), 3),
            "raster": round(float(1 - drawing.result.mean()), 3),
        },
    }


def main() -> None:
    astronaut = data.astronaut()
    photos = {
        "coffee": data.coffee(),
        "astronaut": astronaut,
        "photo_1mp": cv2.resize(astronaut, (1024, 1024), interpolation=cv2.INTER_CUBIC),
    }
    results = {name: measure(name, rgb) for name, rgb in photos.items()}
    results["targets"] = TARGETS
    results["setup"] = "A4 portrait, 15 mm margins, 0.5 mm pen, style 'default', profile " + PROFILE
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
