"""bench/scale.py's stages for a million tiny paths (issue 35): another tool's SVG of SIZE paths,
each one straight segment of at most 0.7 mm at a random place on A4 (a stippled or generative
drawing), through whole ``pencilbot`` commands: ``tiny_stat``, ``tiny_optimize``, ``tiny_export``
(G-code for grbl-servo-a4) and ``tiny_simulate`` (the virtual plotter, a 150 dpi PNG), at 10k,
100k and 1M paths. Targets: each <= 30 s CPU at 1M, exponent <= 1.1 from 100k to 1M.

Run through bench/scale.py: ``python bench/scale.py --stage tiny_stat --stage tiny_optimize
--stage tiny_export --stage tiny_simulate``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

SIZES = (10_000, 100_000, 1_000_000)
CPU_MAX = 30.0
EXPONENT_MAX = 1.1


def tiny_svg_child(spec: str) -> None:
    """Write the drawing of SIZE tiny paths to PATH (``SIZE:PATH``)."""
    size, path = spec.split(":", 1)
    rng = np.random.default_rng(0)
    a = rng.uniform([10, 10], [200, 287], (int(size), 2))
    b = a + rng.uniform(-0.5, 0.5, a.shape)
    with open(path, "w") as out:
        out.write(
            '<?xml version="1.0"?>\n<svg xmlns="http://www.w3.org/2000/svg" width="210mm" height="297mm" '
            'viewBox="0 0 210 297">\n<g stroke="black" stroke-width="0.3" fill="none">\n'
        )
        for lo in range(0, len(a), 100_000):
            out.write(
                "".join(
                    f'<path d="M{x:.2f},{y:.2f} L{u:.2f},{v:.2f}"/>\n'
                    for (x, y), (u, v) in zip(a[lo : lo + 100_000].tolist(), b[lo : lo + 100_000].tolist())
                )
            )
        out.write("</g>\n</svg>\n")


def commands(svg: Path, scratch: Path) -> dict[str, list[str]]:
    """Each stage's pencilbot arguments for the drawing ``svg``."""
    return {
        "tiny_stat": ["stat", str(svg), "-q"],
        "tiny_optimize": ["optimize", str(svg), "-o", str(scratch / "tiny-opt.svg"), "-q"],
        "tiny_export": [
            "export",
            str(svg),
            "-o",
            str(scratch / "tiny.gcode"),
            "-q",
            "--profile",
            "grbl-servo-a4",
        ],
        "tiny_simulate": ["simulate", str(svg), "-o", str(scratch / "tiny.png"), "-q"],
    }


def summary(runs: list[dict]) -> dict:
    """Exponent from 100k to 1M (and over all sizes); the targets at 1M."""
    at = {r["paths"]: r["process_cpu_s"] for r in runs}
    figures: dict = {}
    if 100_000 in at and 1_000_000 in at:
        figures["exponent_100k_1m"] = round(math.log(at[1_000_000] / at[100_000]) / math.log(10), 3)
    if 1_000_000 in at:
        figures["targets"] = {"cpu_s_max": CPU_MAX, "exponent_max": EXPONENT_MAX}
        figures["met"] = {
            "cpu": at[1_000_000] <= CPU_MAX,
            "exponent": figures.get("exponent_100k_1m", 0) <= EXPONENT_MAX,
        }
    return figures


if __name__ == "__main__":
    sys.exit("run through bench/scale.py --stage tiny_…")
