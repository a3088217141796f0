"""Where a plan's plotting time goes: each layer's pen-down, corners, pen lifts and pen-up travel.

The default style plans each photo on A4 as ``bench/fidelity.py`` does, and the plan's ordered
layers are costed as the plot budget costs them (:func:`pencilbot.planning.plot_budget.layer_costs`):
millimetres of pen-down of the same plotting time on grbl-servo-a4, and minutes at
``SECONDS_PER_MM``. Per layer: its paths, the shortest strokes' count (under 5 mm, the dashes of
light tones and the faces' dots, a lift each for little ink) and the median stroke. Per photo:
the sum, the plot budget it was held to, and grbl-servo-a4's own estimate of the plot.

On the face set at stop 45 (docs/faces.md, tenth round) it showed that pen lifts are about 40 % of
a photo's plot, and three quarters of the faces' runs'.

Usage: ``python bench/plot_cost.py [--photos coffee,astronaut,/path/to/photo.jpg] [--faceset]
[--time-budget X]``; prints JSON ``{photo: {"layers": [...], "total": {...}}}``.
"""

from __future__ import annotations

import argparse
import json

import faceset
import fidelity
import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.machine.profile import load_profile
from pencilbot.planning.build import HOME
from pencilbot.planning.layout import budget_area
from pencilbot.planning.plot_budget import PLOT_BUDGET, SECONDS_PER_MM, layer_costs, plot_cost
from pencilbot.planning.stats import estimate

SHORT_MM = 5.0


def _m(mm: float) -> float:
    return round(mm / 1e3, 2)


def breakdown(name: str) -> dict | None:
    """The plan of photo ``name`` costed layer by layer (None when its package is missing)."""
    image = fidelity.photo(name)
    if image is None:
        return None
    plan, _, layout, _ = fidelity.plan_photo(image)
    drawn = [layer for layer in plan.layers if len(layer.paths)]
    costs = layer_costs(plan.layers, HOME)
    layers = []
    for layer, cost in zip(drawn, costs, strict=True):
        lengths = layer.paths.drawn_lengths()
        layers.append(
            {
                "layer": cost.name,
                "paths": cost.paths,
                f"under_{SHORT_MM:g}mm": int(np.count_nonzero(lengths < SHORT_MM)),
                "median_mm": round(float(np.median(lengths)), 1),
                "drawn_m": _m(cost.drawn),
                "corners_m": _m(cost.corners),
                "lifts_m": _m(cost.lifts),
                "travel_m": _m(cost.travel),
                "cost_m": _m(cost.total),
                "minutes": round(cost.total * SECONDS_PER_MM / 60, 1),
            }
        )
    plan_time_budget = float(plan.meta["time_budget"])
    total = plot_cost(plan.layers, HOME).total  # the layers' and the way home
    return {
        "layers": layers,
        "total": {
            "cost_m": _m(total),
            "lifts_share": round(sum(cost.lifts for cost in costs) / total, 3) if total else 0.0,
            "budget_m": _m(PLOT_BUDGET * budget_area(layout, plan_time_budget)),
            "minutes": round(total * SECONDS_PER_MM / 60, 1),
            "estimate_min": round(estimate(plan, load_profile(fidelity.PROFILE)).total.seconds / 60, 1),
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", default="coffee,astronaut,messi5", help="comma-separated names or files")
    parser.add_argument("--faceset", action="store_true", help="the face set's photos (bench/faceset.py)")
    parser.add_argument("--time-budget", type=float, default=None, help="the style's time_budget")
    args = parser.parse_args()
    if args.time_budget is not None:
        fidelity.STYLE_OVERRIDES["time_budget"] = args.time_budget
    names = list(faceset.PHOTOS) if args.faceset else [name for name in args.photos.split(",") if name]
    try:
        result = {name: breakdown(name) for name in names}
    except PencilbotError as error:  # an unreadable photo, a time budget out of the style's range
        parser.error(str(error))
    missing = [name for name, value in result.items() if value is None]
    print(json.dumps({**{k: v for k, v in result.items() if v is not None}, "missing": missing}, indent=1))


if __name__ == "__main__":
    main()
