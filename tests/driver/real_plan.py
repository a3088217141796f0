"""A real plan to plot in the driver's tests: a small pencil drawing of skimage's coffee photo.

Its G-code has what a toy drawing lacks and every fault test needs: multi-segment paths, hatch
lines and edges of the real planner, the profile's pen commands and dwells, and strokes whose
segments overlap collinear ones (a path that runs back along a hatch line), so a point is
passed twice.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from skimage import data

import pencilbot


@lru_cache(maxsize=None)
def plan_lines(profile: str = "grbl-servo-a4", step: int = 12, page: str = "40x30") -> tuple[str, ...]:
    """The G-code lines of coffee (every ``step``-th pixel) planned on a ``page`` (mm) sheet."""
    plan = pencilbot.plan(data.coffee()[::step, ::step], page=page, margin=2)
    return tuple(pencilbot.gcode(plan, profile))


def pen_down_moves(lines, pen_down_text: str = "M3S90") -> np.ndarray:
    """0-based indices of the drawing moves (``G1``) among ``lines``, as the driver indexes them
    (comment-only and blank lines left out)."""
    from pencilbot.driver.modal import clean_line

    cleaned = [c for c in (clean_line(line) for line in lines) if c]
    return np.array([i for i, c in enumerate(cleaned) if c.startswith("G1")])
