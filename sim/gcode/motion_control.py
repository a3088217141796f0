"""GRBL's motion control (``motion_control.c``) on the virtual machine: a move checked against
the soft limits and queued when the planner has room, a dwell, a buffer synchronise, the homing
cycle, and a stop that drops planned motion (where the carriage may coast on).

Each of these is a generator that yields :data:`WAIT` wherever GRBL's main loop would block, or
in instant mode jumps the clock ahead at once.
"""

from __future__ import annotations

import math

from pencilbot.machine.motion import axis_limited
from sim.gcode.planner import Block

SOFT_LIMIT_ALARM = 2
WAIT, PAUSE = "wait", "pause"  # what an execution yields: blocked on the machine, or M0


class MachineAlarm(Exception):
    """Motion stopped with GRBL alarm ``code`` (e.g. 2: soft limit)."""

    def __init__(self, code: int):
        super().__init__(f"ALARM:{code}")
        self.code = code


class MotionControl:
    """The motion part of :class:`sim.gcode.machine.Machine`, kept apart: mixed into it, these
    methods use its ``planner``, ``settings``, ``profile``, ``state`` (the parser's position),
    clock mode (``instant``) and recorder (:class:`sim.recorder.StrokeRecorder`).
    """

    def home(self):
        """``$H``: seek the switches at ``$25``, locate at ``$24``, pull off ``$27`` (a generator).

        The carriage ends at the origin corner (X and Y; a pen plotter homes no Z) and GRBL's
        count agrees with it again. Non-inverted axes read 0 there (a positive work space needs
        HOMING_FORCE_SET_ORIGIN), inverted ones −``$27`` (GRBL's negative space).
        """
        pulloff, seek, feed = self.settings[27], self.settings[25], self.settings[24]
        start = self.carriage_position()
        bed = self.profile.bed
        home = (-pulloff if bed.invert_x else 0.0, -pulloff if bed.invert_y else 0.0, start[2])
        distance = math.dist(start[:2], home[:2])
        seconds = (distance + pulloff) / (seek / 60.0) + 2 * pulloff / (feed / 60.0)
        yield from self._dwell(seconds)
        self._record(start, home, self.pen_down)
        self._close_stroke()
        self.slip = (0.0, 0.0, self.slip[2])
        self.position = (home[0], home[1], start[2] - self.slip[2])

    def _soft_limit_exceeded(self, target) -> bool:
        if not self.settings[20]:
            return False
        eps = 1e-6
        for value, travel, inverted in (
            (target[0], self.settings[130], self.profile.bed.invert_x),
            (target[1], self.settings[131], self.profile.bed.invert_y),
        ):
            lo, hi = (-travel, 0.0) if inverted else (0.0, travel)
            if not lo - eps <= value <= hi + eps:
                return True
        return False

    def _queue_line(self, target, *, rapid: bool, feed: float | None = None, checked: bool = False):
        """GRBL's mc_line: soft limits, check mode, wait for a planner slot, plan the move."""
        if not checked and self._soft_limit_exceeded(target):
            self.stop()
            raise MachineAlarm(SOFT_LIMIT_ALARM)
        if self.check_mode:
            self.position = target
            return
        while self.planner.free_blocks == 0:
            if self.instant:
                self._complete([self.planner.finish_one()])
            else:
                yield WAIT
        self._line(target, rapid=rapid, feed=feed)

    def _line(self, target: tuple[float, float, float], *, rapid: bool, feed: float | None = None) -> None:
        start = self.position
        delta = (target[0] - start[0], target[1] - start[1], target[2] - start[2])
        length = math.hypot(*delta)
        pen_before = self.pen_down
        self.position = target
        if length < 1e-9:
            return
        unit = (delta[0] / length, delta[1] / length, delta[2] / length)
        settings = self.settings
        rate, accel = axis_limited(
            unit, (settings[110], settings[111], settings[112]), (settings[120], settings[121], settings[122])
        )
        rate /= 60.0
        nominal = rate if rapid else min((self.state.feed if feed is None else feed) / 60.0, rate)
        pen = pen_before and (self.pen.kind != "z" or self.pen_down)
        self.planner.add(Block(start, target, length, unit, nominal, accel, pen), settings[11])

    @property
    def dwelling(self) -> bool:
        """Real-time mode: a G4 (or a homing cycle) is still counting down."""
        return self.planner.clock < self.dwell_until

    def _dwell(self, seconds: float):
        if self.check_mode:
            return
        yield from self._synchronize()
        if self.instant:
            self.planner.clock += seconds
            return
        self.dwell_until = self.planner.clock + seconds
        while self.dwelling:
            yield WAIT

    def _synchronize(self):
        """GRBL's protocol_buffer_synchronize: wait until every queued move has run and the
        steppers' idle lock has passed."""
        if self.instant:
            self._complete(self.planner.finish_all())
        while self.planner.busy or self.planner.settling:
            yield WAIT

    def advance(self, seconds: float) -> None:
        """Real-time mode: let ``seconds`` of machine time pass."""
        self._complete(self.planner.advance(seconds))
        if not self.planner.busy and self.planner.clock < self.dwell_until:
            self.planner.clock = min(self.dwell_until, self.planner.clock + seconds)

    def hold(self) -> None:
        """A feed hold: in real time the machine slows to a stand along its path (GRBL's
        ``Hold:1``, then ``Hold:0``); in instant mode nothing is moving."""
        if not self.instant:
            ran = self.planner.hold()
            if ran is not None:
                self._complete([ran])

    def release(self) -> None:
        """Cycle start after a hold: the rest of the queue runs on from rest."""
        self.planner.release()

    def stop(self, *, lose: bool = False) -> bool:
        """Halt at once (reset, alarm): drop planned moves. True if the machine was moving.

        ``lose``: the motors stop dead but the carriage coasts on for its stopping distance
        (v²/2a along the move), so GRBL's count no longer says where it is.
        """
        p = self.planner
        moving = p.busy
        first = p.executing or (p.queue[0] if p.queue else None)
        # In instant mode the machine stands at the start of the first queued move, at the speed
        # the planner entered it with (never more than it can stop from by the move's end).
        speed = self.current_speed() if p.executing is not None else (first.entry if first else 0.0)
        here = self.machine_position()  # moves not yet started are dropped, not reached
        cut = p.discard()
        if cut is not None:
            self._complete([cut])
        self.position = here
        self.dwell_until = p.clock
        if lose and first is not None and speed > 0:
            coast = speed * speed / (2.0 * first.accel)
            start = self.carriage_position()
            self.slip = tuple(s + u * coast for s, u in zip(self.slip, first.unit))
            self._record(start, self.carriage_position(), first.pen_down)
            left = math.dist(here, first.end)  # of the move, before it runs past its end
            if first.pen_down and coast > left:
                end = self.carriage_position()
                self.overruns.append(
                    (tuple(e - u * (coast - left) for e, u in zip(end, first.unit))[:2], end[:2])
                )
        self._close_stroke()
        return moving

    def finish(self) -> None:
        """Complete all queued motion (instant mode)."""
        if self.instant and not self.check_mode:
            self._complete(self.planner.finish_all())
