"""GRBL's motion control (``motion_control.c``) for the virtual machine: the planner and the clock
it runs on, a move checked against the soft limits and planned when the planner has room, a dwell,
a buffer synchronise, a feed hold, and the planned motion dropped at a stop.

The waits are generators that yield :data:`WAIT` wherever GRBL's main loop would block, or in
instant mode jump the clock ahead at once. The machine (:class:`sim.gcode.machine.Machine`) holds
one :class:`MotionControl`, passes it the settings and the check mode where they count, and is told
each block the planner finished (``complete``: its recorder).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping

from pencilbot.machine.bed import Bed
from pencilbot.machine.motion import axis_limited
from sim.gcode.planner import Block, Planner

SOFT_LIMIT_ALARM = 2
WAIT, PAUSE = "wait", "pause"  # what an execution yields: blocked on the machine, or M0


class MachineAlarm(Exception):
    """Motion stopped with GRBL alarm ``code`` (e.g. 2: soft limit)."""

    def __init__(self, code: int):
        super().__init__(f"ALARM:{code}")
        self.code = code


class MotionControl:
    """The planner of a machine and its clock: instant (``instant``: a wait jumps the clock) or
    advanced by the caller, with ``complete(blocks)`` told of every block that has run."""

    def __init__(self, planner: Planner, bed: Bed, *, instant: bool, complete: Callable[[list[Block]], None]):
        self.planner, self.bed, self.instant, self.complete = planner, bed, instant, complete
        self.dwell_until = 0.0  # real-time mode: when the G4 (or homing cycle) counting down ends

    def soft_limit_exceeded(self, target, settings: Mapping[int, float]) -> bool:
        """A target outside the travel (``$130``, ``$131``) when soft limits (``$20``) are on."""
        if not settings[20]:
            return False
        eps = 1e-6
        for value, travel, inverted in (
            (target[0], settings[130], self.bed.invert_x),
            (target[1], settings[131], self.bed.invert_y),
        ):
            lo, hi = (-travel, 0.0) if inverted else (0.0, travel)
            if not lo - eps <= value <= hi + eps:
                return True
        return False

    def room(self) -> Iterator[str]:
        """Until the planner has a free block (GRBL's mc_line waiting for a slot)."""
        while self.planner.free_blocks == 0:
            if self.instant:
                self.complete([self.planner.finish_one()])
            else:
                yield WAIT

    def plan(self, start, target, length: float, *, nominal: float | None, pen_down: bool, settings) -> None:
        """Plan the move from ``start`` to ``target`` (``length`` mm) at the axes' limits, at most
        ``nominal`` mm/s (None: a rapid)."""
        unit = tuple((t - s) / length for s, t in zip(start, target))
        rate, accel = axis_limited(
            unit, (settings[110], settings[111], settings[112]), (settings[120], settings[121], settings[122])
        )
        rate /= 60.0
        speed = rate if nominal is None else min(nominal, rate)
        self.planner.add(Block(start, target, length, unit, speed, accel, pen_down), settings[11])

    @property
    def dwelling(self) -> bool:
        """Real-time mode: a G4 (or a homing cycle) is still counting down."""
        return self.planner.clock < self.dwell_until

    def dwell(self, seconds: float) -> Iterator[str]:
        """``G4``: every queued move run, then ``seconds`` pass."""
        yield from self.synchronize()
        if self.instant:
            self.planner.clock += seconds
            return
        self.dwell_until = self.planner.clock + seconds
        while self.dwelling:
            yield WAIT

    def synchronize(self) -> Iterator[str]:
        """GRBL's protocol_buffer_synchronize: wait until every queued move has run and the
        steppers' idle lock has passed."""
        if self.instant:
            self.complete(self.planner.finish_all())
        while self.planner.busy or self.planner.settling:
            yield WAIT

    def advance(self, seconds: float) -> None:
        """Real-time mode: let ``seconds`` of machine time pass."""
        self.complete(self.planner.advance(seconds))
        if not self.planner.busy and self.planner.clock < self.dwell_until:
            self.planner.clock = min(self.dwell_until, self.planner.clock + seconds)

    def hold(self) -> None:
        """A feed hold: in real time the machine slows to a stand along its path (GRBL's
        ``Hold:1``, then ``Hold:0``); in instant mode nothing is moving."""
        if not self.instant:
            ran = self.planner.hold()
            if ran is not None:
                self.complete([ran])

    def release(self) -> None:
        """Cycle start after a hold: the rest of the queue runs on from rest."""
        self.planner.release()

    def discard(self) -> None:
        """A stop: planned moves dropped (the part of the one running that ran, recorded), no dwell."""
        cut = self.planner.discard()
        if cut is not None:
            self.complete([cut])
        self.dwell_until = self.planner.clock

    def finish(self) -> None:
        """Complete all queued motion (instant mode)."""
        if self.instant:
            self.complete(self.planner.finish_all())
