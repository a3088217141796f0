"""The virtual EBB's checks of motion commands and its timed moves (:mod:`sim.ebb.board`).

Refusals as the firmware makes them (limit checks on, as at boot):

* ``LM`` (3.0.3 ``parse_LM_packet``, 2.8.1 alike): both axes idle (no steps, or neither rate
  nor acceleration) is ``!6``; so is a negative step count with a negative rate (3.0.3) and any
  negative rate (2.8.1 reads it unsigned).
* ``SM``/``XM`` over 25 kHz or under one step per 2^31 ticks on a motor: 3.0.3 prints
  ``!0 Err: <axis1> step rate too high`` (or ``too slow``) itself, 2.8.1
  ``!0 Err: <axis1> step rate > 25K steps/second.`` (or ``< 1.31Hz.``); the move is not queued.
* ``T3``/``TD`` with zero intervals: ``!6``.

``T3`` (and ``TD``, two of them, the second with the jerk negated) run for Intervals ticks, each
tick adding jerk to the acceleration, acceleration to the rate and the rate to the accumulator
(the firmware starts from Rate − Accel/2 + Jerk/6 and Accel − Jerk, so the sums have closed
forms); a motor steps each time the accumulator passes 2^31, in the direction of the rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firmware_protocol import ebb as protocol
from firmware_protocol.ebb import CommandError
from pencilbot.firmware.ebb import MICROSTEPS
from sim.ebb.run import Run

_SM_SCALE = 85_899_345.92  # the firmware's rate = steps × this / ms


def check(command: protocol.Command, version: tuple[int, ...]) -> str | None:
    """Refuse ``command`` as the firmware does: raises CommandError for ``!6``; returns the
    text of a printed ``!0`` refusal; None if the board takes it."""
    name, args = command.name, command.args
    if name == "LM":
        r1, s1, a1, r2, s2, a2 = args[:6]
        idle = [((r == 0 and a == 0) or s == 0) for r, s, a in ((r1, s1, a1), (r2, s2, a2))]
        negative = any((s < 0 and r < 0) if version >= (3, 0) else r < 0 for r, s in ((r1, s1), (r2, s2)))
        if all(idle) or negative:
            raise CommandError(name, 6, "Invalid parameter value")
    if name in ("T3", "TD") and args[0] == 0:
        raise CommandError(name, 6, "Invalid parameter value")
    if name in ("SM", "XM"):
        ms, a = args[0], args[1]
        b = args[2] if len(args) > 2 else 0
        if name == "SM" and not (a or b):
            return None  # a delay
        steps = (a + b, a - b) if name == "XM" else (a, b)
        for axis, n in enumerate(steps, 1):
            n = abs(n)
            if not n:
                continue
            if version >= (3, 0):
                rate = int(n * (_SM_SCALE / ms))
                if rate > protocol.ACCUMULATOR or rate == 0:
                    return f"!0 Err: <axis{axis}> step rate too {'high' if rate else 'slow'}"
            elif n // ms > 25:
                return f"!0 Err: <axis{axis}> step rate > 25K steps/second."
            elif ms // 1311 >= n:
                return f"!0 Err: <axis{axis}> step rate < 1.31Hz."
    return None


def printed_refusal(name: str, text: str, *, future: bool, version: tuple[int, ...]) -> bytes:
    """The bytes of a refusal the command printed itself (then the error handler's line end)."""
    if version < (3, 0):
        return f"{text}\n\r".encode()
    return f"{name},{text}\n\n".encode() if future else f"{text}\n\r\r\n".encode()


@dataclass
class TimedRun(Run):
    """A ``T3``/``TD`` running: its signed steps after each tick, looked up."""

    table: np.ndarray | None = None  # (ticks + 1, 2) int64

    def steps_at(self, t: int) -> np.ndarray:
        table = self.table
        assert table is not None  # (a run's table is set when it starts)
        return table[min(max(t, 0), len(table) - 1)].copy()


def _axis(ticks: int, rate: int, accel: int, jerk: int) -> np.ndarray:
    """Signed steps after each tick 0..ticks of one axis of a T3 (accumulator cleared)."""
    k = np.arange(ticks + 1, dtype=np.float64)
    r0, a0 = rate - accel // 2 + jerk // 6, accel - jerk
    # sum over i = 1..k of (r0 + i·a0 + J·i(i+1)/2)
    total = r0 * k + a0 * k * (k + 1) / 2 + jerk * k * (k + 1) * (k + 2) / 6
    return np.trunc(total / protocol.ACCUMULATOR).astype(np.int64)


def timed_run(command: protocol.Command, counters: np.ndarray, clock: float) -> TimedRun:
    """The run of a ``T3`` or ``TD`` starting now."""
    a = command.args
    if command.name == "T3":
        ticks = int(a[0])
        table = np.column_stack([_axis(ticks, a[1], a[2], a[3]), _axis(ticks, a[4], a[5], a[6])])
    else:  # TD: rate A then B, the second half with the jerk negated
        ticks = int(a[0])
        first = np.column_stack([_axis(ticks, a[1], 0, a[4]), _axis(ticks, a[5], 0, a[8])])
        second = np.column_stack([_axis(ticks, a[2], a[3], -a[4]), _axis(ticks, a[6], a[7], -a[8])])
        table = np.vstack([first, first[-1] + second[1:]])
        ticks *= 2
    steps = table[-1].copy()
    return TimedRun(
        command, counters.copy(), steps, (0, 0), (0, 0), (0, 0), (ticks, ticks), ticks, clock, table
    )


def stop(board) -> str:
    """ES: the move running stops where it is, the FIFO is emptied. 2.8.1 says what was
    cut (``interrupted,fifo1,fifo2,left1,left2``: the steps of the move waiting in the FIFO
    and those the running move had still to take), 3.0.3 only whether anything was."""
    interrupted = board.running is not None or bool(board.fifo)
    waiting = [abs(int(v)) for v in _planned_steps(board.fifo[0])] if board.fifo else [0, 0]
    left = [0, 0]
    if board.running is not None:
        t = int((board.clock - board.running.t0) / protocol.TICK)
        left = [abs(int(v)) for v in board.running.steps - board.running.steps_at(t)]
        board._complete(board.running, t)
    board.fifo.clear()
    if board.old:
        return f"{int(interrupted)},{waiting[0]},{waiting[1]},{left[0]},{left[1]}"
    return "1" if interrupted else "0"


def _planned_steps(command: protocol.Command) -> tuple[int, int]:
    """The steps a queued motion command would take (0, 0 for anything else)."""
    a = command.args
    if command.name == "LM":
        return abs(a[1]), abs(a[4])
    if command.name in ("SM", "XM"):
        b = a[2] if len(a) > 2 else 0
        return (a[1] + b, a[1] - b) if command.name == "XM" else (a[1], b)
    return 0, 0


def start_run(board, command: protocol.Command) -> Run | None:
    """Start a queued command on ``board``: its steps and how long it lasts (None: done at once)."""
    name, args = command.name, command.args
    if name == "EM":
        _enable_motors(board, args)
        return None
    if name in ("LM", "SM", "XM", "HM"):  # motion enables both motors (CU,50 default)
        board.enabled = (board.microsteps, board.microsteps)
    if name in ("SP", "TP", "S2"):
        return _servo_run(board, command)
    if name in ("T3", "TD"):
        return timed_run(command, board.counters, board.clock)
    if name == "LM":
        steps, rates, accels, carry = _lm_plan(board, args)
    else:  # SM, XM, HM: constant rate
        ticks, steps = _constant_rate_plan(board, name, args)
        rates = [
            min(int(abs(v) * protocol.ACCUMULATOR // ticks) + 1, protocol.ACCUMULATOR) if v else 0
            for v in steps
        ]  # (over 25 kHz was refused: check)
        accels, carry = [0, 0], (0, 0)
        if not any(steps):  # a delay
            return _idle_run(board, command, ticks)
    axis_ticks = tuple(
        protocol.lm_ticks(abs(steps[i]), rates[i], accels[i], carry[i]) if steps[i] else 0 for i in range(2)
    )
    if min(axis_ticks) < 0:  # an axis that never arrives: the board would hang; refuse to pretend
        axis_ticks = tuple(t if t >= 0 else 0 for t in axis_ticks)
    return Run(
        command,
        board.counters.copy(),
        np.array(steps, dtype=np.int64),
        tuple(rates),
        tuple(accels),
        carry,
        axis_ticks,
        max(axis_ticks),
        board.clock,
    )


def _idle_run(board, command: protocol.Command, ticks: int) -> Run:
    """A command that moves no motor for ``ticks`` (a servo move's delay, an ``SM`` delay)."""
    zero = np.zeros(2, dtype=np.int64)
    return Run(command, board.counters.copy(), zero, (0, 0), (0, 0), (0, 0), (0, 0), ticks, board.clock)


def _enable_motors(board, args) -> None:
    """``EM``: microstepping and the motors on or off; the step counters from zero here."""
    if args[0]:
        board.microsteps = MICROSTEPS[args[0]]
    second = args[1] if len(args) > 1 else (1 if board.enabled[1] else 0)
    board.enabled = (board.microsteps if args[0] else 0, board.microsteps if second else 0)
    board.origin = board.true_steps()
    board.counters = np.zeros(2, dtype=np.int64)
    board.carry = [0, 0]


def _servo_run(board, command: protocol.Command) -> Run:
    """``SP``, ``TP``, ``S2``: the servo set moving; the command lasts its delay."""
    name, args = command.name, command.args
    if name == "S2":  # S2,Position,RPn,Rate,Delay
        a = (*args, 0, 0, 0, 0)
        board.servos.move(a[1], a[0], a[2], board.clock)
        ms = a[3]
    else:
        up = (not board.pen_up) if name == "TP" else min(args[0], 3) != 0
        board.pen_side.move_servo(up)
        ms = args[1] if (name == "SP" and len(args) > 1) else (args[0] if name == "TP" and args else 0)
    return _idle_run(board, command, int(round(ms / 1000 / protocol.TICK)))


def _lm_plan(board, args) -> tuple[list[int], list[int], list[int], tuple[int, int]]:
    """``LM``: steps, rates and accelerations per axis, and the accumulators it starts from."""
    steps, rates, accels = [], [], []
    for i in range(2):
        rate, n, accel = args[3 * i : 3 * i + 3]
        if rate < 0:  # deprecated: the rate's sign gives the direction
            rate, n = -rate, -abs(n)
        steps.append(n)
        rates.append(rate)  # (the firmware starts at Rate − Accel/2: its sum is the closed form)
        accels.append(accel)
    clear = args[6] if len(args) > 6 else 0
    carry = (0 if clear & 1 else board.carry[0], 0 if clear & 2 else board.carry[1])
    return steps, rates, accels, carry


def _constant_rate_plan(board, name: str, args) -> tuple[int, list[int]]:
    """``SM``, ``XM``, ``HM``: the ticks the move lasts and its steps per axis."""
    if name == "HM":
        rate = args[0]
        target = np.array(args[1:3] if len(args) == 3 else (0, 0), dtype=np.int64)
        n = target - board.counters
        seconds = max(abs(int(n[0])), abs(int(n[1]))) / rate if n.any() else 0.0
    else:
        seconds = args[0] / 1000.0
        a = args[1]
        b = args[2] if len(args) > 2 else 0
        if name == "SM" and not (a or b):
            seconds = min(seconds, protocol.MAX_DELAY_MS / 1000.0)
        n = np.array((a + b, a - b) if name == "XM" else (a, b), dtype=np.int64)
    return max(int(round(seconds / protocol.TICK)), 1), [int(v) for v in n]
