"""The virtual plotter's fast path for a big plain job: a whole G-code file at once.

``pencilbot simulate JOB.gcode`` of a job pencilbot exported (millions of lines) need not go
line by line through the serial protocol and the interpreter: such a job is made of a few plain
forms (``G0``/``G1`` with ``X Y Z F``, ``M3``/``M4``/``M5`` with ``S``: a pen on the spindle or on
Z, ``G4 P`` dwells, the ``G21 G90 G94 G17`` header). :func:`run_blocks` takes a file's text a block
of lines at a time and does each block in whole arrays, with no work per line in Python:
:mod:`sim.bulk_lines` reads the lines, the parser's state through them is a forward fill of what
each line sets (feed, motion, position, spindle, pen), and the motion goes to the one motion model
in :mod:`sim.bulk_timing`, which times the moves as GRBL's look-ahead planner does (a move alone
between two synchronisations — a pen change or a dwell empties the planner — from rest to rest,
a run of moves with the planner's passes). What the pen drew goes into the machine's recorder in
whole arrays and the clock adds every duration, idle lock and dwell in program order, so the
machine ends exactly as the full interpreter leaves it (the tests hold the two to equal strokes,
travel and clock). The last moves of a run a block ends in wait for the next block, as they wait
in the planner for the moves after them.

Anything else stops the fast path at its line (:class:`Stop`): a line of another form, a
refusal (``error:22``, G1 without a feed) or an alarm (a move past the soft limits). The caller
then runs the job the full way, which says what a board would.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from sim.bulk_lines import DWELL_LINE, MOVE, SPINDLE_LINE, Lines, read_lines
from sim.bulk_timing import Moves, axis_limited, max_entries, time_moves
from sim.gcode.motion_control import SOFT_LIMIT_ALARM
from sim.gcode.parser import UNDEFINED_FEED

#: Shortest move the machine plans (mm; as MotionControl._line).
_MIN_LENGTH = 1e-9


@dataclass(frozen=True)
class Stop:
    """Where the fast path stopped: the file ``line`` (1-based; 0: before any) and why
    (``"unsupported"``, ``"empty"``, or the board's answer, e.g. ``"error:22"``, ``"ALARM:2"``)."""

    line: int
    reason: str


def fast_path_possible(machine) -> bool:
    """Whether :func:`run_blocks` can play ``machine``: instant clock, a pen on the spindle or Z, a
    machine fresh from power-up (nothing queued, no offsets, GRBL's default modes)."""
    s = machine.state
    return (
        machine.instant
        and machine.pen.kind in ("spindle", "z")
        and not machine.planner.busy
        and not machine.check_mode
        and s.work_offset() == (0.0, 0.0, 0.0)
        and s.modal.units_mm
        and s.modal.absolute
        and not s.modal.inverse_time
        and machine.slip == (0.0, 0.0, 0.0)
    )


def run_blocks(machine, blocks: Iterable[bytes]) -> Stop | None:
    """Run a job's text on ``machine`` (see :func:`fast_path_possible`), a block of whole lines
    at a time; None when every line ran, else where and why the fast path stopped (the machine
    is then half-way and must be thrown away)."""
    return _Run(machine).run(blocks)


@dataclass
class _Lines:
    """A block's lines (their count ``n``) as the parser's state leaves each: after it, and
    (``*_before``) as the line before left it."""

    n: int
    feed: np.ndarray
    motion: np.ndarray
    position: np.ndarray  # (n, 3) mm
    position_before: np.ndarray
    pen: np.ndarray
    pen_before: np.ndarray
    spindle: np.ndarray  # M3, M4 or M5
    speed: np.ndarray  # S
    sync: np.ndarray  # the line waits for motion to end (a pen change, a dwell)


class _Run:
    """The parser's state through a job, and the moves of the run still in the planner."""

    def __init__(self, machine):
        self.m = machine
        s = machine.state
        self.position = np.array(s.position, dtype=np.float64)
        self.feed, self.motion = s.feed, s.modal.motion
        self.spindle, self.speed = s.modal.spindle, s.spindle_speed
        self.pen_down = machine.pen_down
        self.z_pen = machine.pen.kind == "z"  # else on the spindle: down while M3/M4 S is near "down"
        settings = machine.settings
        self.rates = (settings[110], settings[111], settings[112])
        self.accels = (settings[120], settings[121], settings[122])
        self.deviation = settings[11]
        self.capacity = machine.planner.capacity
        self.idle_lock = machine.planner.idle_lock
        self.lines = 0  # file lines read so far
        self.commands = False  # a line with a command seen
        # The run of moves since the last synchronisation: whether it has any, the last one's
        # direction and nominal speed (for the corner with the next), and those not yet timed
        # (their file lines, and the entry speed of the first).
        self.queued = False
        self.last_unit, self.last_nominal = np.zeros(3), 0.0
        self.waiting, self.waiting_lines, self.entry = Moves.empty(), np.zeros(0, np.int64), 0.0

    def run(self, blocks: Iterable[bytes]) -> Stop | None:
        for block in blocks:
            stop = self._block(read_lines(block))
            if stop is not None:
                return stop
        if not self.commands:
            return Stop(0, "empty")  # the driver has its own word for a file with nothing to do
        seconds, _ = time_moves(self.waiting, self.entry, open_run=False, capacity=self.capacity)
        self._add_time(np.append(seconds, [self.idle_lock] if self.queued else []))
        s = self.m.state
        s.position = tuple(self.position.tolist())
        s.feed, s.modal.motion = self.feed, self.motion
        return None

    # --- one block ----------------------------------------------------------------------------

    def _block(self, lines: Lines) -> Stop | None:
        stop = self._stop(lines)
        if stop is not None:
            return stop
        state = self._state(lines)
        self.commands |= bool((lines.form != 0).any())
        moving = lines.has_axis.any(axis=1) & (lines.form == MOVE)
        at = np.flatnonzero(moving)  # lines with a move
        start, end = state.position_before[at], state.position[at]
        delta = end - start
        length = np.fromiter(map(math.hypot, *delta.T.tolist()), np.float64, len(at))
        planned = ~(length < _MIN_LENGTH)
        queued, syncs = self._queued(state, at[planned])
        # Lifted in place with nothing queued (a pen change, a Z pen's lift of no length): the
        # stroke is finished.
        lifted = state.pen_before & ~state.pen
        still = np.zeros(state.n, bool)
        still[at[~planned]] = True
        closes = np.cumsum(lifted & ((lines.form == SPINDLE_LINE) | (still & ~queued)))
        moved = at[planned]
        pen = state.pen_before[moved] & (state.pen[moved] if self.z_pen else True)
        if len(moved):
            ends = np.concatenate([start[planned, :2], end[planned, :2], pen[:, None]], axis=1)
            self.m.record_moves(ends, np.diff(closes[moved], prepend=0) > 0)
        if closes[-1:].sum() > (closes[moved[-1]] if len(moved) else 0):
            self.m.close_stroke()
        unit = delta[planned] / length[planned, None]
        self._time(lines, state, moved, unit, length[planned], syncs, queued)
        self._carry(lines, state)
        return None

    def _stop(self, lines: Lines) -> Stop | None:
        """The first line the board refuses or alarms on, or the first of another form."""
        move = lines.form == MOVE
        feed = _ffill(lines.has_feed, lines.feed, self.feed)
        motion = _ffill(lines.motion >= 0, lines.motion, self.motion)
        axes = lines.has_axis.any(axis=1)
        refused = move & ((lines.motion >= 0) | axes) & (motion == 1) & (feed == 0.0)
        position = self._positions(lines)
        alarm = move & axes & self._outside(position)
        first = np.flatnonzero(refused | alarm)
        if len(first):
            line = int(first[0])
            reason = f"error:{UNDEFINED_FEED}" if refused[line] else f"ALARM:{SOFT_LIMIT_ALARM}"
            return Stop(self.lines + line + 1, reason)
        if lines.other:
            return Stop(self.lines + lines.count + 1, "unsupported")
        return None

    def _positions(self, lines: Lines) -> np.ndarray:
        given = lines.has_axis & (lines.form == MOVE)[:, None]
        return np.stack([_ffill(given[:, k], lines.axis[:, k], self.position[k]) for k in range(3)], axis=1)

    def _outside(self, position: np.ndarray) -> np.ndarray:
        """Targets past the soft limits (as Machine._soft_limit_exceeded)."""
        settings, bed = self.m.settings, self.m.profile.bed
        if not settings[20]:
            return np.zeros(len(position), bool)
        eps, out = 1e-6, np.zeros(len(position), bool)
        for value, travel, inverted in (
            (position[:, 0], settings[130], bed.invert_x),
            (position[:, 1], settings[131], bed.invert_y),
        ):
            lo, hi = (-travel, 0.0) if inverted else (0.0, travel)
            out |= ~((lo - eps <= value) & (value <= hi + eps))
        return out

    def _state(self, lines: Lines) -> _Lines:
        """The parser's state line by line (the block has nothing the board refuses)."""
        spindle_line = lines.form == SPINDLE_LINE
        mode = _ffill(spindle_line, lines.spindle, self.spindle)
        speed = _ffill(spindle_line & lines.has_speed, lines.speed, self.speed)
        mode_before, speed_before = _before(mode, self.spindle), _before(speed, self.speed)
        # As Machine.execute: a new speed while the spindle runs, or a new spindle mode, waits
        # for motion to end; so does a dwell.
        changed = ((speed != speed_before) & (mode_before != 5)) | (mode != mode_before)
        sync = (spindle_line & changed) | (lines.form == DWELL_LINE)
        position = self._positions(lines)
        pen = self.m.pen
        if self.z_pen:
            z = position[:, 2]
            down = np.abs(z - pen.down) < np.abs(z - pen.up)
        else:
            at = np.zeros(len(mode), bool)
            if spindle_line.any():
                at[spindle_line] = self._spindle_pen(mode[spindle_line], speed[spindle_line])
            down = _ffill(spindle_line, at, self.pen_down)
        return _Lines(
            lines.count,
            _ffill(lines.has_feed, lines.feed, self.feed),
            _ffill(lines.motion >= 0, lines.motion, self.motion),
            position,
            np.concatenate([self.position[None], position])[: lines.count],
            down,
            _before(down, self.pen_down),
            mode,
            speed,
            sync,
        )

    def _spindle_pen(self, mode: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """Whether the spindle pen is down under each (mode, speed), as the machine says."""
        pairs, which = np.unique(np.stack([mode, speed], axis=1), axis=0, return_inverse=True)
        state, down = self.m.state, []
        for spindle, s in pairs.tolist():
            state.modal.spindle, state.spindle_speed = int(spindle), s
            down.append(self.m.pen_down)
        return np.array(down, bool)[which.reshape(-1)]

    def _queued(self, state: _Lines, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whether moves wait in the planner as each line starts, and each line's count of
        synchronisations up to it."""
        n = state.n
        before = np.zeros(n + 1, np.int64)
        np.add.at(before, moved + 1, 1)
        before = np.cumsum(before)  # moves planned by the lines before each
        last = _before(np.maximum.accumulate(np.where(state.sync, np.arange(n), -1)), -1)
        since = before[:n] - before[np.maximum(last, -1) + 1]
        queued = np.where(last >= 0, since > 0, self.queued | (before[:n] > 0))
        return queued, np.cumsum(state.sync)

    def _time(self, lines: Lines, state: _Lines, moved, unit, length, syncs, queued) -> None:
        """The planned moves into the planner's run, and what is known of the clock into it."""
        rate, accel = axis_limited(unit, self.rates, self.accels)
        rate = rate / 60.0
        nominal = np.where(state.motion[moved] == 0, rate, np.minimum(state.feed[moved] / 60.0, rate))
        run = syncs[moved]  # synchronisations before each move
        start = np.concatenate([[run[:1].sum() > 0 or not self.queued], run[1:] != run[:-1]])[: len(moved)]
        corners = max_entries(
            np.concatenate([self.last_unit[None], unit[:-1]]),
            unit,
            accel,
            self.deviation,
            nominal,
            np.concatenate([[self.last_nominal], nominal[:-1]]),
        )
        moves = Moves.join(self.waiting, Moves(length, accel, nominal, np.where(start, 0.0, corners), start))
        keys = np.concatenate([self.waiting_lines, self.lines + moved])
        open_run = bool(syncs[-1:].sum() == (syncs[moved[-1]] if len(moved) else 0))
        seconds, self.entry = time_moves(moves, self.entry, open_run=open_run, capacity=self.capacity)
        timed = len(seconds)
        self.waiting, self.waiting_lines = moves.take(slice(timed, None)), keys[timed:]
        self.queued = open_run and len(moves) > 0
        if len(moved):
            self.last_unit, self.last_nominal = unit[-1], float(nominal[-1])
        # The clock: each move's time at its line; at a synchronisation the idle lock (when it
        # ran the planner out), then a dwell's time.
        synced = np.flatnonzero(state.sync)
        idle = synced[queued[synced]]
        dwell = np.flatnonzero(lines.form == DWELL_LINE)
        at = np.concatenate([keys[:timed], self.lines + idle, self.lines + dwell])
        then = np.concatenate([np.zeros(timed), np.ones(len(idle)), np.full(len(dwell), 2)])
        values = np.concatenate([seconds, np.full(len(idle), self.idle_lock), lines.dwell[dwell]])
        self._add_time(values[np.lexsort((then, at))])

    def _add_time(self, increments: np.ndarray) -> None:
        """Onto the clock one after another, as the planner's clock adds them (np.cumsum adds in order)."""
        if len(increments):
            planner = self.m.planner
            planner.clock = float(np.cumsum(np.concatenate([[planner.clock], increments]))[-1])

    def _carry(self, lines: Lines, state: _Lines) -> None:
        """The parser's state as the block's last line leaves it."""
        self.lines += lines.count
        if state.n:
            self.feed, self.motion = float(state.feed[-1]), int(state.motion[-1])
            self.position = state.position[-1].copy()
            self.spindle, self.speed = int(state.spindle[-1]), float(state.speed[-1])
            self.pen_down = bool(state.pen[-1])
        s = self.m.state
        s.modal.spindle, s.spindle_speed = self.spindle, self.speed


def _ffill(given: np.ndarray, values: np.ndarray, initial) -> np.ndarray:
    """Each line's value: the last one given at or before it, else ``initial``."""
    last = np.maximum.accumulate(np.where(given, np.arange(len(given)), -1))
    return np.where(last >= 0, values[np.maximum(last, 0)], initial)


def _before(values: np.ndarray, initial) -> np.ndarray:
    """Each line's value as the line before left it (``initial`` before the first)."""
    return np.concatenate([[initial], values])[: len(values)]
