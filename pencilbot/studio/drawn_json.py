"""A plot's pen-down paths for the page, from the G-code the plotter gets.

The points are the bed seen from above (mm from its bottom-left corner, Y up, as
:meth:`~pencilbot.machine.bed.Bed.to_view` gives them), each with the file line that reaches it,
so the page draws what is on the paper up to the line the machine runs, and the rest as to come.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np


def job_drawing(gcode: Path, profile: str) -> dict:
    """``{"bed": [w, h], "points": [x0, y0, x1, ...], "offsets": [...], "lines": [...]}`` (mm)."""
    from pencilbot.driver.gcode.drawn import drawn_with_lines
    from pencilbot.driver.gcode.job import load_job
    from pencilbot.machine.profile import load_profile

    plotter = load_profile(profile)
    job = load_job(gcode, plotter)
    paths, indices = drawn_with_lines(job)
    view = plotter.bed.to_view(paths.points) if len(paths.points) else np.zeros((0, 2))
    return {
        "bed": [plotter.bed.width, plotter.bed.height],
        "points": np.round(view, 2).ravel().tolist(),
        "offsets": paths.offsets.tolist(),
        "lines": job.numbers[indices].tolist() if len(indices) else [],
        "total_lines": int(job.numbers[-1]) if len(job) else 0,
    }


@functools.lru_cache(maxsize=8)
def _bed(profile: str):
    from pencilbot.machine.profile import load_profile

    return load_profile(profile).bed


def view_of(profile: str, xy) -> list[float]:
    """A machine position (mm) on the bed seen from above."""
    point = _bed(profile).to_view(np.array([xy], dtype=np.float64))[0]
    return [round(float(point[0]), 2), round(float(point[1]), 2)]
