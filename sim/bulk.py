"""The virtual plotter's fast path for a big plain job: a whole G-code file at once.

``pencilbot simulate JOB.gcode`` of a job pencilbot exported (millions of lines) need not go
line by line through the serial protocol and the interpreter: such a job is made of a few plain
forms (``G0``/``G1`` with ``X Y Z F``, ``M3``/``M4``/``M5`` with ``S``: a pen on the spindle or on
Z, ``G4 P`` dwells, the ``G21 G90 G94 G17`` header). :func:`run_blocks` reads a file's text a block
of lines at a time, classifies every line with one regular expression over the block, follows
the parser's state through the lines in one lean loop and leaves the motion to the one motion
model: a move alone between two synchronisations (a pen change or a dwell empties GRBL's planner,
which is every pen-down stroke of a servo job) is a trapezoid from rest to rest, timed over all
such moves at once; a run of moves between two synchronisations goes through the look-ahead
:class:`~sim.planner.Planner` itself. What the pen drew goes into the machine's recorder in whole
arrays and the clock adds every duration and dwell in program order, so the machine ends exactly
as the full interpreter leaves it (the tests hold the two to equal strokes, travel and clock).

Anything else stops the fast path at its line (:class:`Stop`): a line of another form, a
refusal (``error:22``, G1 without a feed) or an alarm (a move past the soft limits). The caller
then runs the job the full way, which says what a board would.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from firmware_protocol import grbl
from pencilbot.machine.motion import axis_limited, block_duration
from sim.gcode.motion_control import SOFT_LIMIT_ALARM
from sim.gcode.parser import UNDEFINED_FEED
from sim.gcode.planner import Block, Planner

#: A number the fast path reads (no sign on F, S, P: a negative one is error 4); with at most 8
#: digits (:func:`_too_long`), GRBL's read_float gives what float() gives.
_NUM = rb"[+-]?(?:\d+\.?\d*|\.\d+)"
_UNUM = rb"(?:\d+\.?\d*|\.\d+)"
#: One filtered line (upper case, no spaces or comments) and its end: a move, modal G0/G1 or a
#: feed (groups 1-5), a spindle command (6-7), a dwell (8), a header mode GRBL starts in (9), or
#: anything else (10). Every line matches exactly one way, the empty line as a move of nothing.
_LINE = re.compile(
    rb"(?:(?:G0?([01]))?(?:X("
    + _NUM
    + rb"))?(?:Y("
    + _NUM
    + rb"))?(?:Z("
    + _NUM
    + rb"))?(?:F("
    + _UNUM
    + rb"))?"
    rb"|M0?([345])(?:S(" + _UNUM + rb"))?"
    rb"|G0?4P(" + _UNUM + rb")"
    rb"|(G(?:21|90|94|17))"
    rb"|([^\n]*))\n"
)

#: Bytes a plain job's lines are made of (after ``;`` comments): anything else (parentheses,
#: realtime bytes, ``$``, ``%``, non-ASCII) goes the full way.
_PLAIN_BYTES = re.compile(rb"[^A-Za-z0-9.+\- \t\n]")
_COMMENT = re.compile(rb";[^\n]*")
_SPACES = bytes(b for b in grbl.DROPPED_BYTES if b != ord("\n"))


def _too_long(number: bytes) -> bool:
    """More than the 8 digits read_float keeps (counted as :func:`sim.gcode_parser._grbl_float` does)."""
    return len(number) > 8 and len(number) - (b"." in number) - (number[:1] in (b"+", b"-")) > 8


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


class _Run:
    """The parser's state through a job and the moves it queues (machine mm, mm/min, mm/s)."""

    def __init__(self, machine):
        self.m = machine
        s = machine.state
        self.x, self.y, self.z = s.position
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
        self.commands = 0  # lines with a command
        self.chain: list[tuple] = []  # moves since the last synchronisation, not yet planned
        self.planner: Planner | None = None  # a run of moves going through the look-ahead planner
        self._clear()

    def _clear(self) -> None:
        # Completed moves in program order: start, end (x, y), pen down, whether a lift closed
        # the stroke before it; the clock's increments in order (a move alone: None, timed later).
        self.done: list[tuple] = []
        self.closed_before: list[bool] = []
        self.single: list[tuple] = []  # (length, accel, nominal) of each move alone, in order
        self.increments: list[float | None] = []
        self.close_pending = False

    def run(self, blocks: Iterable[bytes]) -> Stop | None:
        for block in blocks:
            stop = self._block(block)
            if stop is not None:
                return stop
            self._flush()
        if not self.commands:
            return Stop(0, "empty")  # the driver has its own word for a file with nothing to do
        self._synchronize()
        self._flush()
        self._leave_state()
        return None

    # --- reading ------------------------------------------------------------------------------

    def _block(self, block: bytes) -> Stop | None:
        if not block.endswith(b"\n"):
            block += b"\n"
        if b"\r" in block:
            block = block.replace(b"\r\n", b"\n")  # a lone \r ends a line too: another form
        if b";" in block:
            block = _COMMENT.sub(b"", block)
        bad = _PLAIN_BYTES.search(block)
        if bad is not None:
            return Stop(self.lines + block.count(b"\n", 0, bad.start()) + 1, "unsupported")
        text = block.translate(None, _SPACES).upper()
        for g, x, y, z, f, mcode, s, p, mode, other in _LINE.findall(text):
            self.lines += 1
            if other:
                return Stop(self.lines, "unsupported")
            if mcode:
                self.commands += 1
                if _too_long(s):
                    return Stop(self.lines, "unsupported")
                self._spindle(int(mcode), float(s) if s else self.speed)
            elif p:
                self.commands += 1
                if _too_long(p):
                    return Stop(self.lines, "unsupported")
                self._synchronize()
                self.increments.append(float(p))
            elif mode:
                self.commands += 1
            elif g or x or y or z or f:
                self.commands += 1
                stop = self._move(g, x, y, z, f)
                if stop is not None:
                    return stop
        return None

    def _move(self, g: bytes, x: bytes, y: bytes, z: bytes, f: bytes) -> Stop | None:
        if _too_long(x) or _too_long(y) or _too_long(z) or _too_long(f):
            return Stop(self.lines, "unsupported")
        if f:
            self.feed = float(f)
        motion = int(g) if g else self.motion
        axes = x or y or z
        if motion == 1 and (g or axes) and self.feed == 0.0:
            return Stop(self.lines, f"error:{UNDEFINED_FEED}")
        self.motion = motion
        if not axes:
            return None
        target = (float(x) if x else self.x, float(y) if y else self.y, float(z) if z else self.z)
        if self.m._soft_limit_exceeded(target):
            return Stop(self.lines, f"ALARM:{SOFT_LIMIT_ALARM}")
        start = (self.x, self.y, self.z)
        self.x, self.y, self.z = target
        was_down = self.pen_down
        if self.z_pen:
            self.pen_down = self.m.pen.is_down(target[2])
        delta = (target[0] - start[0], target[1] - start[1], target[2] - start[2])
        length = math.hypot(*delta)
        if length < 1e-9:
            if was_down and not self.pen_down and not (self.chain or self.planner):
                self.close_pending = True  # as Machine.execute: lifted with nothing queued
            return None
        # As MotionControl._line: the move's unit, its axis-limited rate and acceleration, nominal.
        unit = (delta[0] / length, delta[1] / length, delta[2] / length)
        rate, accel = axis_limited(unit, self.rates, self.accels)
        rate /= 60.0
        nominal = rate if motion == 0 else min(self.feed / 60.0, rate)
        move = (start, target, length, unit, nominal, accel, was_down and (not self.z_pen or self.pen_down))
        if self.planner is not None:
            self._plan(move)
        elif self.chain:  # a second move before a synchronisation: the look-ahead planner plans them
            self.planner = Planner(self.capacity)
            self._plan(self.chain.pop())
            self._plan(move)
        else:
            self.chain.append(move)
        return None

    def _spindle(self, mode: int, speed: float) -> None:
        """``M3``/``M4``/``M5`` [``S``]: as Machine.execute, a change waits for motion to end."""
        if (speed != self.speed and self.spindle != 5) or mode != self.spindle:
            self._synchronize()
        was_down = self.pen_down
        self.spindle, self.speed = mode, speed
        state = self.m.state
        state.modal.spindle, state.spindle_speed = mode, speed
        if not self.z_pen:
            self.pen_down = self.m.pen_down
        if was_down and not self.pen_down:
            self.close_pending = True  # lifted in place (motion has ended): the stroke is finished

    # --- motion -------------------------------------------------------------------------------

    def _plan(self, move: tuple) -> None:
        planner = self.planner
        while planner.free_blocks == 0:
            self._completed(planner.finish_one())
        planner.add(Block(*move), self.deviation)

    def _completed(self, block: Block) -> None:
        self._record(block.start, block.end, block.pen_down)
        self.increments.append(block.duration - 0.0)

    def _record(self, start, end, pen_down: bool) -> None:
        self.done.append((start[0], start[1], end[0], end[1], pen_down))
        self.closed_before.append(self.close_pending)
        self.close_pending = False

    def _synchronize(self) -> None:
        """GRBL's buffer synchronise: every queued move runs to its end, then the idle lock."""
        if self.planner is not None:
            for block in self.planner.finish_all():
                self._completed(block)
            self.planner = None
            self.increments.append(self.idle_lock)
        elif self.chain:
            start, end, length, _unit, nominal, accel, pen = self.chain.pop()
            self._record(start, end, pen)
            self.single.append((length, accel, nominal))
            self.increments += [None, self.idle_lock]

    # --- into the machine ---------------------------------------------------------------------

    def _flush(self) -> None:
        """The moves completed so far into the machine's recorder and clock."""
        m = self.m
        if self.single:
            length, accel, nominal = zip(*self.single)
            zeros = [0.0] * len(length)
            alone = iter(map(block_duration, length, accel, zeros, zeros, nominal))  # from rest to rest
            increments = [next(alone) if i is None else i for i in self.increments]
        else:
            increments = self.increments
        if increments:
            # Added one after another, as the planner's clock does (np.cumsum adds in order).
            m.planner.clock = float(np.cumsum(np.array([m.planner.clock, *increments]))[-1])
        if self.done:
            _record_moves(m, np.array(self.done, dtype=np.float64), np.array(self.closed_before))
        if self.close_pending:
            m._close_stroke()
        self._clear()

    def _leave_state(self) -> None:
        """The parser's state as the last line left it (position, feed, modes)."""
        s = self.m.state
        s.position = (self.x, self.y, self.z)
        s.feed, s.modal.motion = self.feed, self.motion


def _record_moves(machine, moves: np.ndarray, closed_before: np.ndarray) -> None:
    """Completed moves ``(start x, y, end x, y, pen down)`` into ``machine``'s recorder, as
    :meth:`~sim.recorder.StrokeRecorder._record` takes them one by one (no slip on this path)."""
    start, end, pen = moves[:, 0:2], moves[:, 2:4], moves[:, 4] != 0
    up = ~pen
    # A pen-down move goes on with the stroke being drawn when the move before it was pen-down,
    # no lift came between and it starts where that one ended; else it starts a new stroke.
    follows = np.zeros(len(moves), bool)
    follows[1:] = pen[:-1] & (start[1:] == end[:-1]).all(axis=1)
    head = machine._stroke
    follows[0] = bool(head) and head[-1] == (float(start[0, 0]), float(start[0, 1]))
    follows &= pen & ~closed_before
    if up.any():
        machine._travel.extend(
            np.stack([start[up], end[up]], axis=1).reshape(-1, 2), np.arange(2, 2 * up.sum() + 1, 2)
        )
    down = np.flatnonzero(pen)
    if not len(down):
        if up.any() or closed_before.any():
            machine._close_stroke()
        return
    if not follows[down[0]]:
        machine._close_stroke()
        head = []
    new = ~follows[down]
    # Points: a new stroke's start, then every move's end.
    slots = np.cumsum(1 + new) - 1
    points = np.empty((len(head) + slots[-1] + 1, 2))
    if head:
        points[: len(head)] = head
    points[len(head) + slots] = end[down]
    firsts = len(head) + slots[new] - 1
    points[firsts] = start[down[new]]
    bounds = np.append(firsts if not len(head) else np.concatenate([[0], firsts]), len(points))
    tail_closed = up[down[-1] + 1 :].any() or closed_before[down[-1] + 1 :].any()
    done = len(bounds) - 1 if tail_closed else len(bounds) - 2  # strokes finished
    if done:
        machine._strokes.extend(points[: bounds[done]], bounds[1 : done + 1])
        machine._stroke_pauses.extend([machine.pauses] * done)
    machine._stroke = [] if tail_closed else list(map(tuple, points[bounds[-2] :].tolist()))
    machine._stroke_pause = machine.pauses
