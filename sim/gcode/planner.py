"""GRBL-style look-ahead motion planner and the virtual clock it drives.

The maths (junction speed, trapezoids) is the one motion model of :mod:`pencilbot.machine.motion`,
which the plot-time estimate uses too; this module keeps the queue, the passes and the clock.

Moves queue as :class:`Block` (straight lines at a nominal speed). Each block's entry speed is
bounded by the junction-deviation corner speed with the block before it (GRBL's formula) and by
what the acceleration allows over the following blocks (backward pass) and from the preceding
ones (forward pass); the machine stops at the end of the queue, and there stands still for the
firmware's idle lock (GRBL's ``$1``, waited out in its stepper interrupt) before anything else
can start or a synchronisation end. A block's speed profile is
fixed when it starts executing; its duration is the trapezoid (or triangle) time for that
profile. A feed hold (:meth:`Planner.hold`) slows the machine from the speed it has at its
acceleration along the path it was taking, as GRBL's stepper does, over as many blocks as that
takes; what is left of the block it stops on waits, to start from rest when released. Units:
mm, mm/s, mm/s², s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pencilbot.machine.motion import block_duration, junction_speed, peak_speed

#: Blocks the planner holds: GRBL's 16-slot ring keeps one slot empty.
PLANNER_CAPACITY = 15


@dataclass(slots=True)
class Block:
    """One straight move in machine coordinates (mm)."""

    start: tuple[float, ...]
    end: tuple[float, ...]
    length: float  # mm
    unit: tuple[float, ...]
    nominal: float  # mm/s
    accel: float  # mm/s² along the move
    pen_down: bool
    max_entry: float = 0.0  # mm/s, junction and nominal limits
    entry: float = 0.0  # mm/s, as planned
    exit: float = 0.0  # mm/s, fixed when the block starts
    duration: float = 0.0  # s, fixed when the block starts
    braking: bool = False  # a stretch run slowing to a feed hold (its speed profile is fixed)
    rest: bool = False  # what a feed hold left of a block: the same planner slot as the stretch before

    def _profile(self) -> tuple[float, float, float, float]:
        """(peak speed, seconds accelerating, cruising, decelerating) of the fixed profile."""
        a, vi, vo = self.accel, self.entry, self.exit
        peak = peak_speed(self.length, a, vi, vo, self.nominal)
        t_acc, t_dec = (peak - vi) / a, (peak - vo) / a
        return peak, t_acc, max(self.duration - t_acc - t_dec, 0.0), t_dec

    def speed_at(self, t: float) -> float:
        """Speed (mm/s) ``t`` seconds into the block, following its fixed profile."""
        peak, t_acc, t_cruise, t_dec = self._profile()
        if t <= t_acc:
            return self.entry + self.accel * t
        if t <= t_acc + t_cruise:
            return peak
        return max(peak - self.accel * min(t - t_acc - t_cruise, t_dec), self.exit)

    def distance_at(self, t: float) -> float:
        """Distance (mm) travelled ``t`` seconds into the block, following its fixed profile."""
        a, vi = self.accel, self.entry
        peak, t_acc, t_cruise, t_dec = self._profile()
        if t <= t_acc:
            return vi * t + 0.5 * a * t * t
        d_acc = vi * t_acc + 0.5 * a * t_acc * t_acc
        if t <= t_acc + t_cruise:
            return d_acc + peak * (t - t_acc)
        td = min(t - t_acc - t_cruise, t_dec)
        return min(d_acc + peak * t_cruise + peak * td - 0.5 * a * td * td, self.length)

    def point_at(self, t: float) -> tuple[float, ...]:
        """Machine position ``t`` seconds into the block."""
        d = self.distance_at(t)
        return tuple(s + u * d for s, u in zip(self.start, self.unit))


class Planner:
    """The queue of planned blocks plus the one executing, and the clock they advance."""

    def __init__(self, capacity: int = PLANNER_CAPACITY, idle_lock: float = 0.0):
        self.capacity = capacity
        self.idle_lock = idle_lock  # s at rest after the queue runs out
        self.settling = 0.0  # s of that still to pass
        self.queue: list[Block] = []  # at most ``capacity``, so list pops are cheap
        self.executing: Block | None = None
        self.elapsed = 0.0  # s into the executing block
        self.clock = 0.0  # s of simulated motion and dwell since power-on
        self._last: Block | None = None  # most recently queued, for the next junction
        self._speed_into_queue = 0.0  # mm/s the machine will have when it reaches queue[0]
        self.held = False  # a feed hold: nothing starts but the stretches that slow to it

    def __len__(self) -> int:
        return len(self.queue) + (self.executing is not None) - self._sharing()

    def _sharing(self) -> int:
        """1 while a hold's last slowing stretch and what it left of its block are both still
        to run: they are one block (one planner slot) cut in two, else 0."""
        before = self.executing
        for b in self.queue:
            if b.rest:
                return int(before is not None and before.braking)
            if not b.braking:
                return 0
            before = b
        return 0

    @property
    def free_blocks(self) -> int:
        return self.capacity - len(self)

    @property
    def busy(self) -> bool:
        return len(self) > 0

    def add(self, block: Block, junction_deviation: float) -> None:
        """Queue ``block`` and re-plan entry speeds (caller ensures a free slot).

        ``junction_deviation`` is GRBL's ``$11`` in mm, for the corner with the previous block.
        """
        moving = self.busy
        if moving and self._last is not None:
            corner = junction_speed(self._last.unit, block.unit, block.accel, junction_deviation)
            block.max_entry = min(corner, block.nominal, self._last.nominal)
        else:
            block.max_entry = 0.0
        self.queue.append(block)
        self._last = block
        self._replan()

    @property
    def braking(self) -> bool:
        """A feed hold is slowing the machine (GRBL's ``Hold:1``)."""
        return self.held and self.executing is not None and self.executing.braking

    def hold(self) -> Block | None:
        """Feed hold: from the speed it has, the machine slows at each block's acceleration
        along the queued path until it stands; nothing else starts until :meth:`release`.
        Returns the part of the executing block already run (for the recorder), if any."""
        self.held = True
        if self.executing is None:
            if not self.queue or self._speed_into_queue == 0.0:
                return None
            self.start_next()  # at a junction, already moving into the next block
        b, t = self.executing, self.elapsed
        assert b is not None  # (started above)
        ran = _cut(b, t) if t > 0 else None
        speed, here, left = b.speed_at(t), b.point_at(t), b.length - b.distance_at(t)
        stretches = []
        while True:
            stopping = speed * speed / (2.0 * b.accel)
            if stopping < left:  # stands inside this block: the rest of it waits, from rest
                stop = tuple(h + u * stopping for h, u in zip(here, b.unit))
                if stopping > 0:
                    stretches.append(_braking(b, here, stop, stopping, speed, 0.0))
                stretches.append(
                    Block(stop, b.end, left - stopping, b.unit, b.nominal, b.accel, b.pen_down, rest=True)
                )
                break
            out = math.sqrt(max(speed * speed - 2.0 * b.accel * left, 0.0))
            stretches.append(_braking(b, here, b.end, left, speed, out))
            speed = out
            if speed == 0.0 or not self.queue:
                break
            b = self.queue.pop(0)
            here, left = b.start, b.length
        if stretches[-1].braking and self.queue:
            self.queue[0].entry = self.queue[0].max_entry = 0.0  # stood at its start: it starts from rest
        self.queue[:0] = stretches
        self.executing = None
        if stretches[0].braking:
            self.start_next()
        return ran

    def release(self) -> None:
        """Cycle start once a hold has stopped the machine: what is queued runs on from rest."""
        self.held = False
        self._speed_into_queue = 0.0
        if self.queue:
            self._replan(full=True)

    def _replan(self, full: bool = False) -> None:
        q = self.queue
        # Backward pass: the newest block must be able to stop by its end.
        next_entry, first = 0.0, len(q) - 1
        for i in range(len(q) - 1, 0, -1):
            b = q[i]
            limit = min(b.max_entry, math.sqrt(next_entry * next_entry + 2.0 * b.accel * b.length))
            if limit == b.entry and i < len(q) - 1 and not full:
                break  # earlier blocks were planned against this same speed
            b.entry = limit
            next_entry, first = limit, i
        # Forward pass from the first changed block: nothing may enter faster than the
        # acceleration from the block before allows.
        q[0].entry = self._speed_into_queue
        for i in range(1 if full else max(first, 1), len(q)):
            prev, b = q[i - 1], q[i]
            reachable = math.sqrt(prev.entry * prev.entry + 2.0 * prev.accel * prev.length)
            if b.entry > reachable:
                b.entry = reachable

    def start_next(self) -> Block:
        """Take the oldest queued block for execution and fix its speed profile."""
        b = self.queue.pop(0)
        b.exit = self.queue[0].entry if self.queue else 0.0
        b.duration = block_duration(b.length, b.accel, b.entry, b.exit, b.nominal)
        self._speed_into_queue = b.exit
        self.executing, self.elapsed = b, 0.0
        return b

    def advance(self, dt: float) -> list[Block]:
        """Run the clock ``dt`` seconds; return the blocks that finished, in order."""
        done = []
        while dt > 0 and (self.executing or self.queue or self.settling):
            if self.executing is None and self.settling:
                step = min(dt, self.settling)
                self.settling -= step
                self.clock += step
                dt -= step
                continue
            if self.held and not (self.executing or self.queue[0]).braking:
                break  # standing in a feed hold
            if self.executing is None:
                self.start_next()
            b = self.executing
            assert b is not None
            step = min(dt, b.duration - self.elapsed)
            self.elapsed += step
            self.clock += step
            dt -= step
            if self.elapsed >= b.duration:
                done.append(b)
                self.executing = None
                self._at_rest()
        return done

    def finish_one(self) -> Block:
        """Execute the oldest block to its end at once (instant mode: make room)."""
        if self.executing is None:
            self._settle()
            self.start_next()
        b = self.executing
        assert b is not None
        self.clock += b.duration - self.elapsed
        self.executing = None
        self._at_rest()
        return b

    def finish_all(self) -> list[Block]:
        """Execute everything queued at once; the machine ends at rest."""
        done = []
        while self.executing or self.queue:
            done.append(self.finish_one())
        self._settle()
        return done

    def _at_rest(self) -> None:
        """A block has ended: with nothing queued the machine is at rest, and the idle lock starts."""
        if not self.queue:
            self.settling = self.idle_lock

    def _settle(self) -> None:
        """Instant mode: the idle lock passes at once."""
        self.clock += self.settling
        self.settling = 0.0

    def discard(self) -> Block | None:
        """Stop dead (reset / alarm): drop the queue; return the executing block cut where it
        stands, or ``None`` if nothing was moving."""
        cut = _cut(self.executing, self.elapsed) if self.executing is not None and self.elapsed > 0 else None
        self.queue.clear()
        self.executing = None
        self.elapsed = 0.0
        self.settling = 0.0
        self.held = False
        self._last = None
        self._speed_into_queue = 0.0
        return cut


def _cut(block: Block, t: float) -> Block:
    """The part of ``block`` run in its first ``t`` seconds."""
    return Block(
        block.start,
        block.point_at(t),
        block.distance_at(t),
        block.unit,
        block.nominal,
        block.accel,
        block.pen_down,
    )


def _braking(block: Block, start, end, length: float, entry: float, exit_: float) -> Block:
    """A stretch of ``block`` run slowing from ``entry`` to ``exit_`` (mm/s) to a feed hold."""
    return Block(
        start,
        end,
        length,
        block.unit,
        entry,
        block.accel,
        block.pen_down,
        max_entry=entry,
        entry=entry,
        exit=exit_,
        braking=True,
    )
