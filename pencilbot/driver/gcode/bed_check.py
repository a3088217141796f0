"""Check every move of a job against the profile's bed before anything is sent.

With soft limits off (GRBL's default) a board drives into its frame or past the paper on a move
off the bed; `pencilbot export` never writes one, but a file from elsewhere (or for another
plotter) may. The moves are followed by the modal tracker (:mod:`pencilbot.driver.gcode.modal`):
inch and relative moves become absolute millimetres, and an arc (G2/G3 in the XY plane, by
``I J`` centre offsets or radius ``R``) is checked at its end and at every point where it crosses
an axis of its circle, so a bulge past the edge is caught too. The file's coordinate systems are
followed as the board runs them (:mod:`pencilbot.driver.gcode.coords`: ``G53``, ``G54``–``G59``,
``G10 L2/L20``, ``G92``/``G92.1``, ``G28``/``G30`` and their via points); the board is taken to
start in machine coordinates (``G54`` at zero), as pencilbot's G-code is written, and a move that
rests on an offset only the board knows (a ``G55`` the file never set) is refused by name.

The moves are looked at while the job is read (:class:`BedWatch`, fed the tracker's pieces by
:func:`~pencilbot.driver.gcode.job.load_job`), so the check costs no second pass over the file; a job
keeps the first move off the bed, and :func:`check_on_bed` refuses it before the port is opened.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import numpy as np

from pencilbot.errors import OutOfBedError, RefusedError
from pencilbot.units import MM_PER_INCH

if TYPE_CHECKING:  # the job module feeds the watch: no import at run time
    from pencilbot.driver.gcode.job import Job
    from pencilbot.driver.gcode.modal import Track
    from pencilbot.machine.bed import Bed

#: How far past an edge (mm) still counts as on the bed: a decimal in inches is not exact in mm.
TOLERANCE = 1e-4


class BedWatch:
    """The first move off ``bed`` among the tracked pieces of a job, seen in order.

    Attributes
    ----------
    first : tuple or None
        ``(job index, x, y, what)`` of the first line that leaves the bed (machine mm, and which
        of its points: ``"end"``, ``"arc"`` (a point of its arc), ``"via"`` (a ``G28``/``G30``
        line's via point) or ``"unknown"`` (its machine position rests on an offset the file never
        set; x, y NaN)); None while all are on it.
    """

    def __init__(self, bed: Bed):
        self.bed = bed
        self.before = np.zeros(2)  # machine X, Y (mm) before the next piece: a job starts at 0, 0
        self.first: tuple[int, float, float, str] | None = None

    def see(self, piece: Track, index: int) -> None:
        """Look at ``piece``, the states of job lines ``index`` onwards."""
        if self.first is not None or not len(piece):
            return
        c = piece.columns
        scale = np.where(c["inches"], MM_PER_INCH, 1.0)
        end = np.column_stack([c["mx"], c["my"]])
        start = np.vstack([self.before, end[:-1]])
        self.before = end[-1]
        # Points to check per line: its end, its via point (G28/G30) and each of its arc's four
        # axis crossings (NaN if none).
        via = np.column_stack([c["vx"], c["vy"]])
        points = np.concatenate(
            [end[:, None, :], via[:, None, :], _arc_extremes(start, end, c, scale)], axis=1
        )
        off = self.bed.outside(points.reshape(-1, 2), TOLERANCE).reshape(len(end), -1) & ~np.isnan(
            points[..., 0]
        )
        off[:, 0] |= np.isnan(end).any(axis=1)
        lines = np.flatnonzero(off.any(axis=1))
        if len(lines):
            line = int(lines[0])
            which = int(np.flatnonzero(off[line])[0])
            x, y = points[line, which]
            what = (
                "unknown"
                if np.isnan(end[line]).any()
                else "end"
                if which == 0
                else "via"
                if which == 1
                else "arc"
            )
            self.first = (index + line, float(x), float(y), what)


def check_on_bed(job: Job) -> None:
    """Refuse ``job`` if any move leaves ``job.profile``'s bed.

    Raises
    ------
    OutOfBedError
        Naming the first offending file line, its text, the coordinate it reaches (mm) and the
        bed's range, and what to do.
    """
    if job.off_bed is None:
        return
    index, x, y, what = job.off_bed
    if what == "unknown":
        _refuse_unknown(job, index)
    reaches = {"end": "moves to", "arc": "its arc reaches", "via": "passes through"}[what]
    _refuse(job, index, x, y, reaches=reaches)


def arc_geometry(start: np.ndarray, end: np.ndarray, c: dict[str, np.ndarray], scale: np.ndarray):
    """The arcs among job lines (G2/G3 in the XY plane) as GRBL draws them.

    Parameters
    ----------
    start, end : (N, 2) arrays
        Machine mm before and after each line.
    c : dict of arrays
        The lines' modal columns (``arc``, ``i``, ``j``, ``r``).
    scale : (N,) array
        mm per unit of each line (25.4 in inch mode).

    Returns
    -------
    rows, centre, radius, a0, sweep, ccw
        The arc lines' indices; per arc its centre (mm), radius (mm), start angle and sweep
        (rad, > 0; a full circle when start and end coincide) and whether it runs
        counter-clockwise (G3). The centre is given by ``I J`` offsets or computed from ``R``
        as GRBL does (negative R: the longer way round).
    """
    arc = c["arc"]
    # An arc line names its centre (a modal arc without one is an error the board reports).
    has_centre = ~np.isnan(c["i"]) | ~np.isnan(c["j"]) | ~np.isnan(c["r"])
    rows = np.flatnonzero((arc > 0) & has_centre)
    p0, p1, k = start[rows], end[rows], scale[rows]
    ccw = arc[rows] == 3
    r_word = c["r"][rows] * k
    by_radius = ~np.isnan(r_word)
    centre = p0 + np.column_stack([np.nan_to_num(c["i"][rows]), np.nan_to_num(c["j"][rows])]) * k[:, None]
    d = p1 - p0
    chord = np.hypot(d[:, 0], d[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        h = -np.sqrt(np.maximum(4 * r_word**2 - chord**2, 0.0)) / np.where(chord > 0, chord, 1.0)
    h = np.where(ccw, -h, h)
    h = np.where(r_word < 0, -h, h)
    by_r_centre = p0 + 0.5 * np.column_stack([d[:, 0] - d[:, 1] * h, d[:, 1] + d[:, 0] * h])
    centre = np.where(by_radius[:, None], by_r_centre, centre)
    radius = np.hypot(*(p0 - centre).T)
    a0 = np.arctan2(*(p0 - centre).T[::-1])
    a1 = np.arctan2(*(p1 - centre).T[::-1])
    full = np.where(ccw, a1 - a0, a0 - a1) % (2 * np.pi)
    sweep = np.where(np.isclose(full, 0.0, atol=1e-9), 2 * np.pi, full)  # same start and end: a circle
    return rows, centre, radius, a0, sweep, ccw


def _arc_extremes(
    start: np.ndarray, end: np.ndarray, c: dict[str, np.ndarray], scale: np.ndarray
) -> np.ndarray:
    """``(N, 4, 2)`` mm: where each arc line's arc crosses +X, +Y, −X, −Y of its centre; NaN
    where a line is no arc or its arc does not get there."""
    out = np.full((len(end), 4, 2), np.nan)
    rows, centre, radius, a0, sweep, ccw = arc_geometry(start, end, c, scale)
    if not len(rows):
        return out
    axes = np.arange(4) * (np.pi / 2)
    along = np.where(ccw[:, None], axes[None, :] - a0[:, None], a0[:, None] - axes[None, :]) % (2 * np.pi)
    reached = along <= sweep[:, None]
    crossing = (
        centre[:, None, :] + radius[:, None, None] * np.stack([np.cos(axes), np.sin(axes)], axis=1)[None]
    )
    out[rows] = np.where(reached[..., None], crossing, np.nan)
    return out


def _refuse(job: Job, index: int, x: float, y: float, reaches: str) -> None:
    (x0, x1), (y0, y1) = job.profile.bed.machine_range()
    raise OutOfBedError(
        f"line {job.number(index)} of {job.source} ({job.line(index)!r}) {reaches} X {x:.3f} Y {y:.3f} mm, "
        f"off the bed of plotter profile {job.profile.name} (X {x0:g} .. {x1:g}, Y {y0:g} .. {y1:g} mm); "
        "nothing was sent. Draw it with the profile it was made for, or export it again for this one "
        "(pencilbot export keeps every move on the bed)"
    )


def _refuse_unknown(job: Job, index: int) -> None:
    text = job.line(index)
    state = job.state_after(index)
    if stored := re.search(r"G0*(28|30)(?![0-9.])", text):
        code = stored.group(1)
        what = (
            f"goes to the position the board stored with G{code}.1, which {job.source} does not set before it"
        )
        fix = f"set it in the file first (G{code}.1 where it should go), or move there with G0 X.. Y.."
    elif any(v is None for v in state.frames.data[state.frames.select][:2]):
        system = 54 + state.frames.select
        what = (
            f"moves in coordinate system G{system}, whose offset the board keeps and {job.source} "
            "does not set before it"
        )
        fix = (
            f"set it in the file first (G10 L2 P{state.frames.select + 1} X.. Y..), or draw in G54 "
            "(machine coordinates, as pencilbot export writes)"
        )
    else:
        what = (
            f"moves by a G92 offset that was set in a coordinate system {job.source} never set, so its "
            "offset is the board's"
        )
        fix = "set that coordinate system in the file first (G10 L2 P.. X.. Y..), or use G54"
    raise OutOfBedError(
        f"line {job.number(index)} of {job.source} ({text!r}) {what}, so pencilbot cannot check it against "
        f"the bed of plotter profile {job.profile.name}; nothing was sent. To draw it, {fix}"
    )


def check_resumable(job: Job, start: int) -> None:
    """Refuse to start ``job`` at line ``start`` where the file has moved its coordinate system.

    A resume wakes a board in machine coordinates (``G54``, no ``G92``: a reset clears it) and
    re-sends none of the lines before ``start``, so a work offset those lines set up would be
    missing and every move after it misplaced.

    Raises
    ------
    PlotError
        Naming the line and what to do.
    """
    if start <= 0 or start >= len(job) or job.state_after(start - 1).frames.plain:
        return
    raise RefusedError(
        f"line {job.number(start)} of {job.source} comes after lines that change the work coordinates "
        "(G92, G10, G54-G59), which a resume cannot restore; nothing was sent. Draw the file from its "
        "start (a stopped job: --restart), or split it where the coordinates are machine coordinates"
    )
