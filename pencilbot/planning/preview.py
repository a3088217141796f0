"""A plan drawn on its page: what ``plan --preview`` and ``demo`` show, drawn one way."""

from __future__ import annotations

import numpy as np

from pencilbot.planning.plan import Plan
from pencilbot.render import Canvas, color_image


def preview(plan: Plan, dpi: float) -> Canvas:
    """The plan's layers inked on a canvas of its page, each with its own pen width.

    Parameters
    ----------
    plan : Plan
    dpi : float
        Pixels per inch.

    Returns
    -------
    Canvas
        Of the page's size; its pen (for overlays) is the plan's :attr:`~Plan.pen_width`.
    """
    canvas = Canvas(plan.page.width, plan.page.height, dpi=dpi, pen_width=plan.pen_width)
    for layer in plan.layers:
        canvas.draw_paths(layer.paths, pen_width=layer.pen_width)
    return canvas


def preview_image(plan: Plan, dpi: float) -> np.ndarray:
    """The plan as a picture: grey (H, W) uint8 for a plan of one pen, else each pen's ink as a
    transparent colour layer (:func:`~pencilbot.render.color_image`), (H, W, 3) uint8."""
    if len(plan.pens) < 2:
        return preview(plan, dpi).to_image()
    canvases, colors = [], []
    for _, layers in plan.pen_runs():
        canvas = Canvas(plan.page.width, plan.page.height, dpi=dpi, pen_width=layers[0].pen_width)
        for layer in layers:
            canvas.draw_paths(layer.paths, pen_width=layer.pen_width)
        canvases.append(canvas)
        colors.append(layers[0].color)
    return color_image(canvases, colors)
