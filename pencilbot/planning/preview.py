"""A plan drawn on its page: what ``plan --preview`` and ``demo`` show, drawn one way."""

from __future__ import annotations

from pencilbot.planning.plan import Plan
from pencilbot.render import Canvas


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
