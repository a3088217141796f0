"""How faithfully a plan draws its pencil sketch: the figures ``bench/plan.py`` and ``demo`` report.

* **Line fidelity**: Pearson r between the edge layer rendered on the image's pixel grid and the
  raster line drawing 1 − L, both Gaussian-blurred with σ = 2 px (strokes may sit a pixel off
  the raster line and still draw the same contour).
* **Tone fidelity**: Pearson r and mean absolute difference between the darkness of the whole
  plan and of the raster pencil drawing 1 − R, both blurred with σ = 3 mm at plot scale (the
  distance at which a viewer judges shading rather than single lines).

A correlation is NaN where it is undefined: one of the two pictures is flat (a blank photo has
no edges to draw, an outline plan of it draws nothing).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage as ndi

from pencilbot.imaging.pencil import Sketch
from pencilbot.planning.build import ink_on_image_grid
from pencilbot.planning.layout import Layout
from pencilbot.planning.plan import Plan

LINE_SIGMA_PX = 2.0
TONE_SIGMA_MM = 3.0


@dataclass(frozen=True)
class Fidelity:
    """Line r, tone r and tone mean absolute difference (darkness in [0, 1])."""

    line_r: float
    tone_r: float
    tone_mae: float


def fidelity(plan: Plan, drawing: Sketch) -> Fidelity:
    """Compare a plan with the sketch it was planned from.

    Parameters
    ----------
    plan : Plan
        With a layer of role ``"edges"``, planned from ``drawing`` on ``plan.page``.
    drawing : Sketch
        A full (not lines-only) sketch; its image grid is the one the plan was laid out on.

    Returns
    -------
    Fidelity
    """
    layout = Layout.fit(drawing.line.edges.shape, plan.page)
    pen_width = plan.pen_width
    edges = ink_on_image_grid(plan.paths("edges"), layout, pen_width=pen_width)
    line_r = pearson(
        ndi.gaussian_filter(edges, LINE_SIGMA_PX),
        ndi.gaussian_filter(1.0 - drawing.line.drawing, LINE_SIGMA_PX),
    )
    ink = ink_on_image_grid(plan.paths(), layout, pen_width=pen_width)
    sigma = TONE_SIGMA_MM / layout.mm_per_px
    plotted = ndi.gaussian_filter(ink, sigma)
    raster = ndi.gaussian_filter(1.0 - drawing.result, sigma)
    return Fidelity(line_r, pearson(plotted, raster), float(np.abs(plotted - raster).mean()))


def pearson(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two same-sized pictures; NaN (without a warning) if either is flat."""
    a, b = np.ravel(a), np.ravel(b)
    if np.ptp(a) == 0 or np.ptp(b) == 0:
        return float("nan")
    return float(np.corrcoef(a, b)[0, 1])
