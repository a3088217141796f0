"""What a G-code job draws: its pen-down polylines, whole arrays at once.

The job's modal state after every line (:func:`pencilbot.driver.gcode.modal.track`, which reads the pen
the way the profile's pen model says) gives where the pen is and whether it is down, from the
first line that changes the pen on (before it the pen's height is unknown). A path starts
where the pen goes down and takes every point the pen then moves to until it lifts; a pen that goes
down and up without moving draws a dot. Arcs (``G2``/``G3``) count as a straight move to their end.
Any program works, pencilbot's own or another tool's, in mm or inches, absolute or relative.
"""

from __future__ import annotations

import numpy as np

from pencilbot.driver.gcode.job import Job
from pencilbot.paths import Paths
from pencilbot.units import MM_PER_INCH


def drawn_paths(job: Job) -> Paths:
    """The pen-down paths of ``job`` in machine mm, in the order they are drawn.

    Parameters
    ----------
    job : Job
        A loaded G-code job (:func:`pencilbot.driver.gcode.job.load_job`); its profile's pen model
        says which commands put the pen down.

    Returns
    -------
    Paths
        Machine X and Y in mm; empty if the pen never goes down.
    """
    return drawn_with_lines(job)[0]


def drawn_with_lines(job: Job) -> tuple[Paths, np.ndarray]:
    """:func:`drawn_paths`, and for each of their points the job line (0-based) that reaches it:
    a front end that knows the line the machine runs shows what is on the paper so far.

    Returns
    -------
    Paths
        As :func:`drawn_paths`.
    numpy.ndarray
        ``(N,)`` int64, the job line index of each point.
    """
    if not len(job):
        return Paths.empty(), np.zeros(0, dtype=np.int64)
    states = job.states(0, len(job)).columns
    # Where the board puts the pen: machine mm, work offsets (G92, G10, G54-G59, G53) included;
    # where the file leaves an offset to the board, its work coordinates.
    scale = np.where(states["inches"], MM_PER_INCH, 1.0)
    on_machine = np.column_stack([states["mx"], states["my"]])
    xy = np.where(
        np.isnan(on_machine), np.column_stack([states["x"] * scale, states["y"] * scale]), on_machine
    )
    down = states["pen_down"].astype(bool)
    # Until the program first changes the pen, where it is is unknown (a Z pen at the power-up
    # height 0 reads as down): those lines draw nothing.
    down &= np.cumsum(down != down[0]) > 0
    if job.system.check_from is not None:  # the board parses the lines after a $C and moves for none
        down[job.system.check_from :] = False
    before = np.concatenate([[False], down[:-1]])
    moved = np.any(np.diff(xy, axis=0, prepend=xy[:1]) != 0, axis=1)
    starts = down & ~before  # the pen touches the paper here
    drawn = down & before & moved  # and goes on to each of these points
    kept = starts | drawn
    points = xy[kept]
    first = np.flatnonzero(starts[kept])
    if not len(points):
        return Paths.empty(), np.zeros(0, dtype=np.int64)
    return Paths(points, np.append(first, len(points))), np.flatnonzero(kept)
