"""GRBL-style look-ahead motion planner and the virtual clock it drives.

The maths (junction speed, trapezoids) is the one motion model of :mod:`pencilbot.machine.motion`,
which the plot-time estimate uses too; this module keeps the queue, the passes and the clock.

Moves queue as :class:`Block` (straight lines at a nominal speed). Each block's entry speed is
bounded by the junction-deviation corner speed with the block before it (GRBL's formula) and by
what the acceleration allows over the following blocks (backward pass) and from the preceding
ones (forward pass); the machine stops at the end of the queue. A block's speed profile is
fixed when it starts executing; its duration is the trapezoid (or triangle) time for that
profile. Units: mm, mm/s, mm/s², s.
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

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    length: float  # mm
    unit: tuple[float, float, float]
    nominal: float  # mm/s
    accel: float  # mm/s² along the move
    pen_down: bool
    max_entry: float = 0.0  # mm/s, junction and nominal limits
    entry: float = 0.0  # mm/s, as planned
    exit: float = 0.0  # mm/s, fixed when the block starts
    duration: float = 0.0  # s, fixed when the block starts

    def distance_at(self, t: float) -> float:
        """Distance (mm) travelled ``t`` seconds into the block, following its fixed profile."""
        a, vi, vo = self.accel, self.entry, self.exit
        peak = peak_speed(self.length, a, vi, vo, self.nominal)
        t_acc = (peak - vi) / a
        t_dec = (peak - vo) / a
        t_cruise = max(self.duration - t_acc - t_dec, 0.0)
        if t <= t_acc:
            return vi * t + 0.5 * a * t * t
        d_acc = vi * t_acc + 0.5 * a * t_acc * t_acc
        if t <= t_acc + t_cruise:
            return d_acc + peak * (t - t_acc)
        td = min(t - t_acc - t_cruise, t_dec)
        return min(d_acc + peak * t_cruise + peak * td - 0.5 * a * td * td, self.length)

    def point_at(self, t: float) -> tuple[float, float, float]:
        """Machine position ``t`` seconds into the block."""
        d = self.distance_at(t)
        return tuple(s + u * d for s, u in zip(self.start, self.unit))


class Planner:
    """The queue of planned blocks plus the one executing, and the clock they advance."""

    def __init__(self, capacity: int = PLANNER_CAPACITY):
        self.capacity = capacity
        self.queue: list[Block] = []  # at most ``capacity``, so list pops are cheap
        self.executing: Block | None = None
        self.elapsed = 0.0  # s into the executing block
        self.clock = 0.0  # s of simulated motion and dwell since power-on
        self._last: Block | None = None  # most recently queued, for the next junction
        self._speed_into_queue = 0.0  # mm/s the machine will have when it reaches queue[0]

    def __len__(self) -> int:
        return len(self.queue) + (self.executing is not None)

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

    def _replan(self) -> None:
        q = self.queue
        # Backward pass: the newest block must be able to stop by its end.
        next_entry, first = 0.0, len(q) - 1
        for i in range(len(q) - 1, 0, -1):
            b = q[i]
            limit = min(b.max_entry, math.sqrt(next_entry * next_entry + 2.0 * b.accel * b.length))
            if limit == b.entry and i < len(q) - 1:
                break  # earlier blocks were planned against this same speed
            b.entry = limit
            next_entry, first = limit, i
        # Forward pass from the first changed block: nothing may enter faster than the
        # acceleration from the block before allows.
        q[0].entry = self._speed_into_queue
        for i in range(max(first, 1), len(q)):
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
        while dt > 0 and (self.executing or self.queue):
            if self.executing is None:
                self.start_next()
            b = self.executing
            step = min(dt, b.duration - self.elapsed)
            self.elapsed += step
            self.clock += step
            dt -= step
            if self.elapsed >= b.duration:
                done.append(b)
                self.executing = None
        return done

    def finish_one(self) -> Block:
        """Execute the oldest block to its end at once (instant mode: make room)."""
        if self.executing is None:
            self.start_next()
        b = self.executing
        self.clock += b.duration - self.elapsed
        self.executing = None
        return b

    def finish_all(self) -> list[Block]:
        """Execute everything queued at once; the machine ends at rest."""
        done = []
        while self.executing or self.queue:
            done.append(self.finish_one())
        return done

    def discard(self) -> Block | None:
        """Stop dead (reset / alarm): drop the queue; return the executing block cut where it
        stands, or ``None`` if nothing was moving."""
        cut = None
        if self.executing is not None and self.elapsed > 0:
            b = self.executing
            end = b.point_at(self.elapsed)
            cut = Block(b.start, end, b.distance_at(self.elapsed), b.unit, b.nominal, b.accel, b.pen_down)
        self.queue.clear()
        self.executing = None
        self.elapsed = 0.0
        self._last = None
        self._speed_into_queue = 0.0
        return cut
