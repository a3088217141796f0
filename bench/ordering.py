"""Pen-up travel and ordering time: our order_paths against plain greedy nearest neighbour.

Prints JSON. Target: pen-up travel ≤ 0.85 × greedy nearest neighbour with reversal on the same
strokes; 100 000 strokes ordered within a few seconds. Stroke sets: synthetic short strokes
(uniform, and clustered like contours) and the strokes of the coffee and astronaut plans (each layer shuffled, then ordered both ways from the same start).
Timings are wall-clock (and CPU for order_paths) on a shared machine: expect noise.

Usage: python bench/ordering.py [--rounds N] [--quick]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from skimage import data

from pencilbot.imaging.io import image_from_array
from pencilbot.paths import Paths
from pencilbot.planning.build import make_plan
from pencilbot.planning.ordering import DEFAULT_ROUNDS, greedy_order, order_paths, travel_length


def synthetic_uniform(n: int, rng) -> Paths:
    """Short random strokes (1–5 mm) scattered over an A4 drawing area."""
    start = rng.uniform([15, 15], [195, 282], (n, 2))
    step = rng.normal(0, 2.0, (n, 2))
    return Paths(np.stack([start, start + step], axis=1).reshape(-1, 2), np.arange(0, 2 * n + 1, 2))


def synthetic_contours(n: int, rng) -> Paths:
    """Overlapping 3 mm strokes along random circles, like vectorised image edges."""
    per = 40
    circles = max(n // per, 1)
    centre = rng.uniform([40, 40], [170, 257], (circles, 2))
    radius = rng.uniform(5, 40, circles)
    t = rng.uniform(0, 2 * np.pi, (circles, per))
    a = centre[:, None] + radius[:, None, None] * np.stack([np.cos(t), np.sin(t)], -1)
    d = 3.0 / radius[:, None]
    b = centre[:, None] + radius[:, None, None] * np.stack([np.cos(t + d), np.sin(t + d)], -1)
    strokes = np.stack([a, b], axis=2).reshape(-1, 2, 2)[:n]
    return Paths(strokes[rng.permutation(len(strokes))].reshape(-1, 2), np.arange(0, 2 * len(strokes) + 1, 2))


def measure(paths: Paths, rounds: int, start=(0.0, 0.0)) -> dict:
    t0 = time.perf_counter()
    greedy = greedy_order(paths, start)
    t1, c1 = time.perf_counter(), time.process_time()
    ours = order_paths(paths, start=start, join_tolerance=-1, rounds=rounds)
    t2, c2 = time.perf_counter(), time.process_time()
    joined = order_paths(paths, start=start, rounds=rounds)  # default: join within 0.5 mm
    g, o, j = travel_length(greedy, start), travel_length(ours, start), travel_length(joined, start)
    return {
        "strokes": len(paths),
        "greedy_pen_up_mm": round(g, 1),
        "ordered_pen_up_mm": round(o, 1),
        "ratio_vs_greedy": round(o / g, 3) if g else None,
        "joined_pen_up_mm": round(j, 1),
        "joined_paths": len(joined),
        "greedy_seconds": round(t1 - t0, 3),
        "order_seconds": round(t2 - t1, 3),
        "order_cpu_seconds": round(c2 - c1, 3),  # less noisy than wall time on a shared machine
    }


def real_sets(rng) -> dict[str, Paths]:
    """Per-layer strokes of the coffee and astronaut plans (A4 portrait, 0.5 mm pen)."""
    sets = {}
    for name in ("coffee", "astronaut"):
        plan = make_plan(image_from_array(getattr(data, name)(), source=name))
        for layer in plan.layers:
            sets[f"{name}/{layer.name}"] = layer.paths.take(rng.permutation(len(layer.paths)))
    return sets


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=DEFAULT_ROUNDS, help="improvement rounds per set")
    parser.add_argument("--quick", action="store_true", help="skip the 100 000-stroke sets")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    results = {}
    sizes = (1_000, 10_000) if args.quick else (1_000, 10_000, 100_000)
    for n in sizes:
        results[f"uniform_{n}"] = measure(synthetic_uniform(n, rng), args.rounds)
        results[f"contours_{n}"] = measure(synthetic_contours(n, rng), args.rounds)
    for name, paths in real_sets(rng).items():
        results[name] = measure(paths, args.rounds)
    plans = {}
    for image in ("coffee", "astronaut"):
        layers = [r for name, r in results.items() if name.startswith(image + "/")]
        greedy = sum(r["greedy_pen_up_mm"] for r in layers)
        ordered = sum(r["ordered_pen_up_mm"] for r in layers)
        plans[image] = {
            "greedy_pen_up_mm": round(greedy, 1),
            "ordered_pen_up_mm": round(ordered, 1),
            "ratio_vs_greedy": round(ordered / greedy, 3),
        }
    ratios = [r["ratio_vs_greedy"] for r in results.values() if r["ratio_vs_greedy"]]
    print(
        json.dumps(
            {
                "rounds": args.rounds,
                "target_ratio": 0.85,
                "worst_ratio": max(ratios),
                "whole_plans": plans,
                "sets": results,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
