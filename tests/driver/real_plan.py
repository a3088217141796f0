"""A real plan to plot in the driver's tests: a small pencil drawing of skimage's coffee photo.

Its G-code has what a toy drawing lacks and every fault test needs: multi-segment paths, hatch
lines and edges of the real planner, the profile's pen commands and dwells, and strokes whose
segments overlap collinear ones (a path that runs back along a hatch line), so a point is
passed twice.

The plan is frozen (``data/coffee-40x30.svg``, written by the planner of December 2026): the
fault tests name lines of it (a stroke passing a point twice, a corner the carriage coasts past),
and a change to the planner's look must not move them. The G-code is written from it for each
profile by today's writer.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

import pencilbot

PLAN = Path(__file__).with_name("data") / "coffee-40x30.svg"


@cache
def plan_lines(profile: str = "grbl-servo-a4") -> tuple[str, ...]:
    """The G-code lines of the frozen plan of coffee (every 12th pixel on a 40 × 30 mm sheet,
    margin 2 mm) for ``profile``."""
    return tuple(pencilbot.gcode(pencilbot.read_svg(PLAN), profile))


def pen_down_moves(lines, pen_down_text: str = "M3S90") -> np.ndarray:
    """0-based indices of the drawing moves (``G1``) among ``lines``, as the driver indexes them
    (comment-only and blank lines left out)."""
    from pencilbot.driver.gcode.modal import clean_line

    cleaned = [c for c in (clean_line(line) for line in lines) if c]
    return np.array([i for i, c in enumerate(cleaned) if c.startswith("G1")])
