"""A G-code job's moves for an EBB board, planned on the host: machine mm and pen state after every
job line, arcs as chords (:func:`rows`), and the commands from any line on (:func:`plan_from`):
the stretches between program pauses and dwells planned from rest to rest
(:func:`pencilbot.machine.ebb_motion.plan_ebb`), each dwell as ``SM`` delays."""

from __future__ import annotations

import re
from collections import deque

import numpy as np

from pencilbot.driver.gcode.bed_check import arc_geometry
from pencilbot.machine.ebb_motion import EbbMove, plan_ebb
from pencilbot.units import MM_PER_INCH

ARC_TOLERANCE = 0.002  # mm a chord of an arc may stray from it (GRBL's $12 default)


def rows(job) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Machine mm and pen state after every job line, and each row's job line: arcs (G2/G3)
    become chords within :data:`ARC_TOLERANCE`, one row per chord end (as
    :mod:`pencilbot.driver.gcode.drawn` reads the pen)."""
    if not len(job):
        return np.zeros((0, 2)), np.zeros(0, bool), np.zeros(0, np.int64)
    c = job.states(0, len(job)).columns
    xy = np.column_stack([c["x_mm"], c["y_mm"]])
    down = c["pen_down"].astype(bool)
    down &= np.cumsum(down != down[0]) > 0  # before the first pen command: up
    lines = np.arange(len(job))
    rows, centre, radius, a0, sweep, ccw = arc_geometry(
        np.vstack([np.zeros(2), xy[:-1]]), xy, c, np.where(c["inches"], MM_PER_INCH, 1.0)
    )
    if not len(rows):
        return xy, down, lines
    with np.errstate(invalid="ignore"):
        step = 2 * np.arccos(np.clip(1 - ARC_TOLERANCE / np.maximum(radius, ARC_TOLERANCE), -1, 1))
    count = np.maximum(np.ceil(sweep / np.maximum(step, 1e-6)).astype(np.int64), 1)
    extra = np.zeros(len(job), np.int64)
    extra[rows] = count - 1  # points inside each arc, before its end
    at = np.repeat(np.arange(len(job)), extra + 1)
    out_xy = xy[at].copy()
    first = np.cumsum(extra + 1) - (extra + 1)  # where each line's rows begin
    for k, row in enumerate(rows.tolist()):
        n = int(count[k])
        turn = np.where(ccw[k], 1.0, -1.0) * sweep[k] * np.arange(1, n) / n
        angle = a0[k] + turn
        out_xy[first[row] : first[row] + n - 1] = centre[k] + radius[k] * np.column_stack(
            [np.cos(angle), np.sin(angle)]
        )
    return out_xy, down[at], lines[at]


def plan_from(job, xy, down, rows_line, profile, first: int, here, pen_down, dwells=None) -> deque:
    """The commands from job line ``first`` on, from motor position ``here``: the stretches
    between program pauses and dwells planned one after the other (each from rest to rest),
    each pause (its job line) and each dwell (``SM,ms,0,0``: the board waits) in between."""
    work: deque = deque()
    dwells = dwells or {}
    for a, b in chunks(job, first, len(job), dwells):
        if a in job.pauses:
            work.append(a)
        for ms in dwell_pieces(dwells.get(a, 0.0)):
            work.append(EbbMove(f"SM,{ms},0,0", a, tuple(here), tuple(here), ms / 1000.0, bool(pen_down)))
        ra, rb = np.searchsorted(rows_line, [a, b])  # the rows of job lines a..b-1
        moves = plan_ebb(
            xy[ra:rb], down[ra:rb], rows_line[ra:rb], profile, start_steps=here, pen_down=pen_down
        )
        work.extend(moves)
        if moves:
            here, pen_down = moves[-1].end, moves[-1].down
    return work


_G4 = re.compile(rb"G0*4(?![0-9.])")  # a dwell word in a cleaned job line (not G40..G49, not G4.1)
MAX_DELAY_MS = 100_000  # SM as a delay is capped at 100 s (EBB reference, SM)


def job_dwells(job) -> dict[int, float]:
    """The job lines that dwell (``G4``) and for how long, s (read only when the job has any)."""
    at = [m.start() for m in _G4.finditer(job.frames)]
    if not at:
        return {}
    seconds = job.states(0, len(job)).seconds
    lines = np.unique(np.searchsorted(job.offsets, at, side="right") - 1)
    return {int(i): float(seconds[i]) for i in lines if seconds[i] > 0}


def dwell_pieces(seconds: float) -> list[int]:
    """A dwell as ``SM`` delays, ms (none for a dwell under half a millisecond)."""
    ms = int(round(seconds * 1000))
    return [min(MAX_DELAY_MS, ms - k) for k in range(0, ms, MAX_DELAY_MS)]


def chunks(job, start: int, stop: int, dwells=None) -> list[tuple[int, int]]:
    """Job line ranges between program pauses (a pen change waits for the motion to end) and dwells."""
    cuts = sorted(i for i in (*job.pauses, *(dwells or ())) if start < i < stop)
    edges = [start, *cuts, stop]
    return [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]
