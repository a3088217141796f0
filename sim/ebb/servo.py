"""The virtual EBB's RC servo outputs (:mod:`sim.ebb.board`): channels, pins, PWM period, the pen.

As firmware 3.0.3's ``RCServo2.c`` and ``ebb.c`` have it: up to 8 channels, each bound to an
``RPn`` pin on first use (port B pin n is RPn n+3: the standard pen servo on RB1 is RP4, the
narrow-band one of penlift 3 / the NextDraw 8511 on RB2 is RP5); ``SC,8,n`` keeps n of them
running (default 8) and ``SC,9,ms`` gives each a slot of ms (default 3), so a channel's pulse,
and its rate step, comes every n × ms (24 ms at boot, 3 ms after ``SC,8,1``). A move to a
channel beyond the slots running is dropped, as the firmware drops it. ``SP`` drives the pin
of ``g_servo2_RPn`` (its third word, port B pin, 1 when absent or over 7); ``S2`` any RPn.

Only one servo lifts the pen: the one on the profile's ``[ebb] servo_pin``. Moves to any other
pin run (they take their time in the queue) but do not move the pen.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

MAX_CHANNELS = 8
DEFAULT_PIN = 1  # DEFAULT_EBB_SERVO_PORTB_PIN

if TYPE_CHECKING:
    from sim.ebb.board import EbbBoard


def rpn(port_b_pin: int) -> int:
    """The RPn number of port B pin ``port_b_pin``."""
    return port_b_pin + 3


class Servos:
    """Servo channels and the pen's servo. Times are the board's clock (s)."""

    def __init__(self, pen_pin: int, start: float):
        self.pen_rpn = rpn(pen_pin)
        self.slots, self.slot_ms = MAX_CHANNELS, 3
        self.channels: list[int] = [0] * MAX_CHANNELS  # the RPn bound to each channel, 0: free
        self.sp_rpn = rpn(DEFAULT_PIN)  # g_servo2_RPn: SP's pin
        self.pos_from = self.target = float(start)  # the pen servo's signal, 83.3 ns units
        self.t0 = self.t1 = 0.0
        self.powered = False  # QR: the servo's power (off at boot, on with a move to RB1 / SP)

    @property
    def period(self) -> float:
        """Seconds between two pulses (and two rate steps) of one channel."""
        return self.slots * self.slot_ms / 1000.0

    def channel(self, pin_rpn: int) -> int:
        """The channel (0-based) ``pin_rpn`` is bound to, binding a free one; -1: none free."""
        if pin_rpn in self.channels:
            return self.channels.index(pin_rpn)
        if 0 in self.channels:
            return self.channels.index(0)
        return -1

    def set_sp_pin(self, port_b_pin: int) -> None:
        """SP's Pin word: a new pin stops the old one's pulses."""
        new = rpn(port_b_pin if port_b_pin <= 7 else DEFAULT_PIN)
        if new != self.sp_rpn:
            self.release(self.sp_rpn)
            self.sp_rpn = new

    def release(self, pin_rpn: int) -> None:
        if pin_rpn in self.channels:
            self.channels[self.channels.index(pin_rpn)] = 0

    def accepts(self, pin_rpn: int) -> bool:
        """Whether a move to ``pin_rpn`` is queued (a channel among the slots running)."""
        k = self.channel(pin_rpn)
        return 0 <= k < self.slots and pin_rpn <= 24

    def at(self, when: float) -> float:
        """The pen servo's signal at ``when``."""
        if when >= self.t1 or self.t1 <= self.t0:
            return self.target
        f = (when - self.t0) / (self.t1 - self.t0)
        return self.pos_from + f * (self.target - self.pos_from)

    def move(self, pin_rpn: int, position: int, rate: int, now: float) -> None:
        """A servo move taken from the queue at ``now``: position 0 stops the pin's pulses."""
        if position == 0:
            self.release(pin_rpn)
            return
        k = self.channel(pin_rpn)
        if not 0 <= k < self.slots:
            return
        self.channels[k] = pin_rpn
        if pin_rpn == rpn(DEFAULT_PIN):
            self.powered = True
        if pin_rpn != self.pen_rpn:
            return
        start = self.at(now)
        self.pos_from, self.target, self.t0 = start, float(position), now
        self.t1 = now + travel_seconds(start, position, rate, self.period)


def travel_seconds(start: float, end: float, rate: int, period: float) -> float:
    """Seconds the signal takes from ``start`` to ``end`` at ``rate`` units per pulse (0: at once)."""
    if rate <= 0 or start == end:
        return 0.0
    return math.ceil(abs(end - start) / rate) * period


class PenSide:
    """The pen side of an :class:`sim.ebb.board.EbbBoard`, held by it: where the pen is (its
    servo's moves, whether it touches the paper) and what the carriage draws with it."""

    def __init__(self, board: EbbBoard) -> None:
        self.board = board

    def record_move(self, before: np.ndarray, run, t: int) -> None:
        after = self.board.true_steps()
        points = [before]
        ticks = [k for k in run.axis_ticks if 0 < k < t]
        if len(ticks) == 1 or (len(ticks) == 2 and ticks[0] != ticks[1]):  # one axis finished first
            bend = self.board.origin + run.start + run.steps_at(min(ticks))
            chord = after - before
            off = abs(float(chord[0] * (bend - before)[1] - chord[1] * (bend - before)[0])) / max(
                float(np.hypot(*chord)), 1e-9
            )
            if off > 1.5:  # a bend a sender should have avoided (within a step it is the step grid)
                points.append(bend)
        points.append(after)
        setup = self.board.profile.ebb
        mm = setup.to_machine(np.array(points, dtype=np.float64))
        drawing = self.pen_landed(run.t0)
        for a, b in zip(mm[:-1], mm[1:]):
            self.board.record(a, b, drawing)

    def resting_servo(self) -> float:
        """Where the pen's servo stands at a boot: where it was (no pulses move it), at first the pen up."""
        if hasattr(self, "servos"):
            return self.board.servos.at(self.board.clock)
        return float(self.board.profile.ebb.servo_position(self.board.profile.pen.up))

    def touching(self, position: float) -> bool:
        """Whether the pen's servo at ``position`` holds the pen on the paper: at the profile's
        pen-down height or within a quarter of its up-down travel above it."""
        setup, pen = self.board.profile.ebb, self.board.profile.pen
        down, up = setup.servo_position(pen.down), setup.servo_position(pen.up)
        return (position - down) * (1 if up >= down else -1) <= abs(up - down) / 4

    def pen_landed(self, when: float) -> bool:
        """The pen touches the paper at ``when``: its servo has come to rest at a touching position."""
        servos = self.board.servos
        return self.touching(servos.target) and when >= servos.t1 - 1e-9

    def move_servo(self, up: bool) -> None:
        """SP's move (queued): the pen state flips whatever pin the servo is on."""
        target, rate = (
            (self.board.servo_up, self.board.rate_up) if up else (self.board.servo_down, self.board.rate_down)
        )
        self.board.servos.powered = True
        self.board.servos.move(self.board.servos.sp_rpn, target, rate, self.board.clock)
        self.board.pen_up = up
