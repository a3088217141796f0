"""Rebuild the machine state to continue a job from the middle.

A resumed job must look, to the paper, like the job never stopped: the lines before the resume
point are not sent again, but their lasting effects are — units, absolute/relative mode, feed,
the motion mode — and the pen travels *up* from wherever the machine is to the resume point
before it goes down again (if it was down there). Where that point is comes from where the
machine stopped, located on the job's lines (:func:`locate_stop`, :class:`StopLocator`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from pencilbot.driver import position
from pencilbot.driver.gcode.modal import ModalState, clean_line
from pencilbot.machine.pen import PenModel
from pencilbot.units import MM_PER_INCH

_CHUNK = 256  # job lines tracked at a time when counting moves back
#: mm: GRBL reports positions to 3 decimals, so a reported point is within this of the true one.
REPORT_RESOLUTION = 0.001
#: mm: how far a point rounded to :data:`REPORT_RESOLUTION` in X and in Y can be from the true
#: one (half a digit in each): a reported point this close to a move's end may be either side.
REPORT_ROUNDING = REPORT_RESOLUTION / 2 * 2**0.5


def resume_preamble(
    state: ModalState,
    pen: PenModel,
    *,
    stop_xy: tuple[float, float] | None = None,
    decimals: int = 3,
    dwell=None,
) -> list[str]:
    """G-code that puts a freshly woken machine into ``state``, travelling with the pen up.

    Parameters
    ----------
    state : ModalState
        The state the next job line expects (:meth:`pencilbot.driver.gcode.job.Job.state_after`).
    pen : PenModel
        Pen commands of the plotter.
    stop_xy : (float, float), optional
        Where the pen stopped inside the next line's move (job units). In absolute mode the next
        line, sent from there, draws exactly the rest of that move; without it the pen travels to
        the end of the previous line.
    decimals : int
        Digits after the point for coordinates and feed.
    dwell : callable, optional
        ``dwell(seconds)`` → the firmware's ``G4`` line (``""`` for none): the pen waits its
        ``up_delay`` / ``down_delay`` after moving, as the job's own pen changes do, so a
        servo pen is up before the travel and down before the first stroke.

    Returns
    -------
    list of str
        Cleaned lines to send before the job's remaining lines.
    """
    x, y = stop_xy if (stop_xy is not None and not state.relative) else (state.x, state.y)
    fmt = f"{{:.{decimals}f}}"
    up, down = [clean_line(line) for line in pen.up_lines], [clean_line(line) for line in pen.down_lines]
    if dwell is not None:
        up += [clean_line(line) for line in [dwell(pen.up_delay)] if line]
        down += [clean_line(line) for line in [dwell(pen.down_delay)] if line]
    # The profile's pen commands are in mm (a Z pen's heights); the job's coordinates may be inches.
    job_units = ["G20"] if state.inches else []
    lines = ["G21", "G90", *up, *job_units, f"G0X{fmt.format(x)}Y{fmt.format(y)}"]
    if state.pen_down:
        lines.extend(["G21", *down, *job_units] if state.inches else down)
    mode = f"G{state.motion}"
    lines.append(mode + (f"F{fmt.format(state.feed)}" if state.feed else ""))
    if state.relative:
        lines.append("G91")
    return lines


def flight_start(job, last: int, receive_buffer: int, moves: int) -> int:
    """The earliest job line the machine can still have been running when it stopped, with
    lines up to ``last`` (0-based) sent: what can be in flight follows from the firmware.

    Going back from ``last``: the lines whose bytes fit in the board's receive buffer may not
    have been read at all; before them, ``moves`` moves (:meth:`Firmware.moves_in_flight
    <pencilbot.firmware.base.Firmware.moves_in_flight>`: its planner depth) may have been
    answered and still not run, with any lines that are no moves between them.

    Parameters
    ----------
    job : pencilbot.driver.gcode.job.Job
    last : int
        The last line sent (−1: none).
    receive_buffer : int
        Bytes of the board's receive buffer.
    moves : int
        Moves the board can hold answered and not yet run.

    Returns
    -------
    int
        A job line ≤ ``last`` (0 when the search reaches the start).
    """
    if last <= 0:
        return 0
    offsets = job.offsets
    # Unread: the lines i..last whose bytes together fit in the receive buffer.
    unread = int(np.searchsorted(offsets[: last + 2], offsets[last + 1] - receive_buffer, side="left"))
    first = min(max(unread, 0), last)
    found = 0
    while first > 0 and found < moves:
        lo = max(first - _CHUNK, 0)
        states = job.states(max(lo - 1, 0), first)
        x, y, z = (states.columns[axis] for axis in ("x", "y", "z"))
        moved = (np.diff(x) != 0) | (np.diff(y) != 0) | (np.diff(z) != 0)  # lines lo..first-1
        if lo == 0:
            moved = np.r_[x[0] != 0 or y[0] != 0 or z[0] != 0, moved]
        at = np.flatnonzero(moved)[::-1] + lo  # moves before ``first``, latest first
        if len(at) >= moves - found:
            return int(at[moves - found - 1])
        found += len(at)
        first = lo
    return first


def locate_stop(
    states,
    last: int,
    position: tuple[float, float] | None,
    *,
    window: int = 40,
    tolerance: float = REPORT_RESOLUTION,
    pen_down: bool | None = None,
    floor: int | None = None,
    after: tuple[float, float] | None = None,
    coast: float = 0.0,
) -> tuple[int, tuple[float, float] | None] | None:
    """Where to resume after the machine stopped at ``position``, or ``None`` if it is not on
    the last moves sent (unknown, or the machine was power-cycled or moved by hand).

    The plotter has received lines up to ``last`` (0-based; −1 for none), but the last ones
    may still have been waiting in its planner or receive buffer when it stopped (acknowledged
    or not), so the stop position, not the acknowledgement count, tells what was drawn. The
    latest move (within ``window`` lines) that passes through the position is taken: the
    machine runs moves in order and a plot rarely passes the very same point twice within a
    planner's length. Only lines whose start state ``states`` holds are searched: a window
    larger than what was kept is cut to it, never read past.

    Parameters
    ----------
    states : indexable by job line
        ``states[i]`` is the :class:`ModalState` after job line ``i``, for ``i`` within
        ``window`` lines of ``last`` and the line before them (a
        :class:`~pencilbot.driver.gcode.modal.Track` of them, whose ``first`` says where it starts).
    last : int
        Index of the last line sent.
    position : (float, float) or None
        Work position where the machine stopped (job units); ``None`` if unknown.
    window : int
        How many lines back to look (:func:`flight_start` says how many can be in flight).
    tolerance : float
        Distance (job units) under which the position counts as on a move: the board's report
        resolution for a position it reported, more for one found by a hand jog. A point counts
        as at a move's end or start (a vertex) within the tolerance of a hand, but a reported
        point only within its rounding (:data:`REPORT_ROUNDING`): one a digit from a vertex
        is inside the move (the board stood a micrometre short of the corner).
    pen_down : bool, optional
        Whether the pen was down when the machine stopped, if the board said (its spindle
        value or Z): a stop inside a move is only on a move drawn with the pen so (a travel
        that crosses the stroke being drawn is not where the machine stopped).
    floor : int, optional
        A line the machine was running earlier (an earlier status report's position): it runs
        lines in order, so the earliest move from ``floor`` on that passes through the position
        is taken instead of the latest (a closed stroke begins and ends at the same point).
    after : (float, float), optional
        Where on ``floor``'s move the machine was then (that report's position): it went on
        from there, so on that move only a point at or past it counts (a stroke that runs back
        over itself passes the point on its way out before the report and on its way back
        after it).
    coast : float
        How far (job units) the carriage may have run on past the end of a move, in its
        direction, after the motors stopped (a reset or alarm in motion): such a point means
        that move was finished (and overrun), so the next line is where to resume.

    Returns
    -------
    next_index : int
        First line to send on resume.
    stop_xy : (float, float) or None
        Set when the machine stopped inside ``next_index``'s move: the point of the move
        nearest ``position`` (a reported position is rounded; the resume stays on the move).
    """
    if position is None or last < 0:
        return None
    kept = getattr(states, "first", 0)
    lowest = max(last - window + 1, kept + 1 if kept > 0 else 0, 0)
    snap = REPORT_ROUNDING if tolerance <= REPORT_RESOLUTION else tolerance
    search = _Search(states, complex(*position), tolerance, snap, pen_down, floor, after, coast, lowest, last)
    return search.run()


@dataclass(frozen=True)
class _Search:
    """One stop point searched for on the moves sent, lines ``lowest``..``last`` (see
    :func:`locate_stop`; ``snap``: how near a vertex counts as at it)."""

    states: Any
    p: complex
    tolerance: float
    snap: float
    pen_down: bool | None
    floor: int | None
    after: tuple[float, float] | None
    coast: float
    lowest: int
    last: int

    def run(self) -> tuple[int, tuple[float, float] | None] | None:
        """The latest move through the point (from ``floor`` on: the earliest), as locate_stop's."""
        if self.floor is None:
            lines = range(self.last, self.lowest - 1, -1)
        else:
            lines = range(max(self.floor, self.lowest), self.last + 1)
        ran_past = None  # a move the point is beyond the end of: only if it is on no move
        for i in lines:
            kind, on = self.meets(i)
            if kind == "end":
                return i + 1, None
            if kind == "start":
                return i, None
            if kind == "inside":
                return self.nearer(i, on)
            if kind == "past" and ran_past is None:
                ran_past = i + 1, None  # ran on past the move's end (straight on: the next may be collinear)
        return ran_past

    def meets(self, i: int) -> tuple[str | None, complex]:
        """How the point meets move ``i``: ``"end"`` at its end, ``"start"`` at its start,
        ``"inside"`` on it (with its nearest point; drawn with the pen as the board said, and
        not behind ``after`` on ``floor``'s move), ``"past"`` beyond its end within ``coast``."""
        p, snap, states = self.p, self.snap, self.states
        end = complex(states[i].x, states[i].y)
        start = complex(states[i - 1].x, states[i - 1].y) if i > 0 else 0j
        if abs(p - end) <= snap:
            return "end", end
        seg = end - start
        if seg == 0:
            return None, end
        t = ((p - start) / seg).real
        on = start + t * seg
        if abs(on - p) > self.tolerance:
            return None, on
        after = self.after if i == self.floor else None
        if after is not None and t < ((complex(*after) - start) / seg).real - snap / abs(seg):
            return None, on  # behind where the machine already was on this move
        if 0.0 <= t < 1.0 and abs(on - start) > snap:
            drawn_so = self.pen_down is None or states[i].pen_down == self.pen_down
            return ("inside" if drawn_so else None), on
        if abs(on - start) <= snap:
            return "start", on
        if t >= 1.0 and abs(on - end) <= self.coast:
            return "past", on
        return None, on

    def nearer(self, i: int, on: complex) -> tuple[int, tuple[float, float] | None]:
        """Move ``i`` at ``on``, or the next move in the search's order if the point is nearer it.

        Near a corner a rounded point lies within the tolerance of both moves that meet there:
        the one it lies nearer to is where it is (the next move, which shares a vertex with this
        one; collinear moves are a tie: this one)."""
        k = i + 1 if self.floor is not None else i - 1
        if self.lowest <= k <= self.last:
            other = _inside(self.states, k, self.p, self.tolerance, self.snap, self.pen_down)
            if other is not None and other[0] < abs(on - self.p) - 1e-12:
                return k, other[1]
        return i, (on.real, on.imag)


def _inside(states, i: int, p: complex, tolerance: float, snap: float, pen_down: bool | None):
    """(distance, point) of ``p`` from move ``i`` if it lies inside it (not at its ends, drawn
    with the pen as the board said), else None."""
    end = complex(states[i].x, states[i].y)
    start = complex(states[i - 1].x, states[i - 1].y) if i > 0 else 0j
    seg = end - start
    if seg == 0 or abs(p - end) <= snap or (pen_down is not None and states[i].pen_down != pen_down):
        return None
    t = ((p - start) / seg).real
    on = start + t * seg
    if abs(on - p) > tolerance or not 0.0 <= t < 1.0 or abs(on - start) <= snap:
        return None
    return abs(on - p), (on.real, on.imag)


#: A cleaned line a GRBL-protocol board answers only after every earlier move has run.
_SYNCHRONIZING = re.compile(r"^(?:N\d+)?(?:[^G]*G0*4(?![0-9.])|[^M]*M0*[01](?![0-9.]))")


class StopLocator:
    """Where on a job's lines a machine stands, from the position it reports: the lines that can
    have been in flight (its receive buffer and planner), the dwells it answered, its planner
    count, and the last report taken while it moved.

    Parameters
    ----------
    job : Job
        The job being drawn.
    profile : Profile
        The plotter's profile: its receive buffer, firmware and pen.
    """

    def __init__(self, job, profile):
        self.job, self.profile = job, profile
        self.firmware = profile.firmware
        self.pen = profile.pen_model

    def job_units(self, xy, index: int):
        """A work position X, Y (mm) in the units the job uses at line ``index``."""
        if xy is not None and self.job.state_after(max(index, 0)).inches:
            return xy[0] / MM_PER_INCH, xy[1] / MM_PER_INCH
        return xy

    def locate(
        self,
        last: int,
        position_xy,
        pen_down: bool | None = None,
        floor: int | None = None,
        answered: int | None = None,
        window: int | None = None,
        after=None,
        **how,
    ):
        """:func:`~pencilbot.driver.gcode.resume.locate_stop` over the lines up to ``last`` (sent) that
        can have been in flight, or the ``window`` lines before it (``how``: its tolerance and
        coast); ``after``: where on ``floor``'s move the machine was then."""
        if position_xy is None or last < 0:
            return None
        last = min(last, len(self.job) - 1)
        first = self.flight_start(last) if window is None else max(last - window, 0)
        # GRBL answers a dwell (or a program pause) only once every move before it has run:
        # from the last one answered, the machine runs lines in order, so the first pass
        # through the position after it is where it stood (a stroke that runs back over
        # itself passes a point twice; strokes drawn before the dwell are finished).
        sync = self.synchronized(min(last - 1 if answered is None else answered, last), first)
        if sync is not None and (floor is None or sync > floor):
            floor, after = sync, None
        # The state before the window's first line too: its move starts there.
        return locate_stop(
            self.job.states(max(first - 1, 0), last + 1),
            last,
            position_xy,
            window=last - first + 1,
            pen_down=pen_down,
            floor=floor,
            after=after,
            **how,
        )

    def coasted(self, at, count, here, tolerance: float):
        """Where to resume after the carriage coasted on from the board's count (a reset or
        alarm in motion): ``at`` is the count located on the lines (:meth:`locate`), ``count``
        and ``here`` (job units) where the count and the carriage stand. The carriage ran on
        along the move the count is on (at a vertex: the move ending or the one starting
        there): inside it, the stop is the carriage's point on it; past its end, that move was
        drawn (its overrun is ink no sender can take back) and the next line is next.
        ``None`` if ``here`` is not straight on from the count along such a move (within
        ``tolerance`` and both points' rounding)."""
        index, stop_xy = at
        slack = tolerance + 2 * REPORT_ROUNDING
        c, p = complex(*count), complex(*here)
        for move in [index] if stop_xy is not None else [index - 1, index]:
            if not 0 <= move < len(self.job):
                continue
            states = self.job.states(max(move - 1, 0), move + 1)
            start = complex(states[move - 1].x, states[move - 1].y) if move > 0 else 0j
            end = complex(states[move].x, states[move].y)
            if end == start:
                continue
            unit = (end - start) / abs(end - start)
            run = (p - c) / unit  # along the move (real) and across it (imag)
            if abs(run.imag) > slack or run.real < -slack:
                continue
            if run.real >= ((end - c) / unit).real - slack:
                return move + 1, None
            on = c + run.real * unit
            return move, (on.real, on.imag)
        return None

    def synchronized(self, answered: int, first: int) -> int | None:
        """The last line at or before ``answered`` (down to ``first``) that the firmware answers
        only after all motion before it ran: a dwell or a program pause."""
        for i in range(answered, max(first, 0) - 1, -1):
            if _SYNCHRONIZING.match(self.job.line(i)):
                return i
        return None

    def flight_start(self, last: int) -> int:
        """The earliest line the machine can have been running with lines up to ``last`` sent:
        what the board's receive buffer and planner hold (its firmware's figures)."""
        return flight_start(
            self.job,
            min(last, len(self.job) - 1),
            self.profile.receive_buffer,
            self.firmware.moves_in_flight(),
        )

    def planner_floor(self, status, acked: int, refused: int | None = None) -> int | None:
        """The line the machine was running when it came to rest, from the planner count of the
        status report (GRBL's ``Bf:``, reported when ``$10`` asks for it): the blocks still
        planned are the moves of the lines answered up to ``acked``, one block per move (a
        ``refused`` line planned none; an empty planner: it ran them all)."""
        if status is None or status.buffer is None or acked < 0:
            return None
        queued = self.firmware.planner_blocks - status.buffer[0]
        if queued <= 0:  # every line answered has run: the machine stands at the end of the last
            return acked
        first = max(self.flight_start(acked) - 1, 0)
        states = self.job.states(first, acked + 1)
        moves = 0
        for i in range(acked, first, -1):
            state, before = states[i], states[i - 1]
            if i != refused and (state.x, state.y, state.z) != (before.x, before.y, before.z):
                moves += 1
                if moves == queued:
                    return i
        return None

    def floor(self, stream, last: int) -> tuple[int, tuple[float, float]] | None:
        """The line the machine was running at the last status report taken while it moved
        (it can only have moved on from there) and that report's position on it (job units),
        if that position is on the lines sent."""
        if stream.seen is None:
            return None
        xy, status, answered = stream.seen
        bound = min(last, answered + 1)  # then, too, it ran only lines it had answered
        here = self.job_units(xy, bound)
        found = self.locate(bound, here, position.pen_down_in(status, self.pen), answered=answered)
        return None if found is None else (found[0] - (found[1] is None and found[0] > 0), here)
