"""The fast path's motion (:mod:`sim.bulk`): the look-ahead planner's timing of many moves at once.

In instant mode :class:`sim.gcode.planner.Planner` holds ``capacity`` blocks; a block starts (and its
exit speed is fixed) when the planner needs its slot, so block *j*'s exit is the entry speed the
planner had given block *j + 1* once blocks *j* .. *j + capacity − 1* were queued (or fewer at a
synchronisation, which runs the queue out, the last block to rest). That entry is what the
planner's passes leave (their early stop changes nothing: it stops where the speeds are those a
full pass gives):

* backward from the newest block, which must be able to stop: ``B = min(max_entry,
  sqrt(B_next² + 2·a·length))``;
* forward from the executing block's entry: ``exit_j = min(B_{j+1}, sqrt(entry_j² + 2·a_j·length_j))``,
  ``entry_{j+1} = exit_j``.

The backward passes of every window are a few array steps (one per planner slot); the forward
one is a running recurrence, solved by sweeps over the moves whose speed the move before still
lowers (exact: every step is the planner's own float operation, in its order, and each only
lowers a speed, so the sweeps end on the planner's values). Durations are
:func:`~pencilbot.machine.motion.block_duration`'s, written out over arrays with its operations
in its order, so the clock adds the same numbers as the full interpreter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pencilbot.machine.motion import REVERSAL_COS, STRAIGHT_COS

#: Sweeps of the forward recurrence before the rest runs move by move (a run accelerating over
#: many short moves, each slower than the planner allows).
SWEEPS = 64


@dataclass(frozen=True)
class Moves:
    """Queued moves in program order (mm, mm/s, mm/s²): ``start`` marks the first of a run (moves
    between two synchronisations, which the planner starts from rest)."""

    length: np.ndarray
    accel: np.ndarray
    nominal: np.ndarray
    max_entry: np.ndarray  # junction and nominal limits (0 for a run's first move)
    start: np.ndarray

    def __len__(self) -> int:
        return len(self.length)

    def take(self, part: slice) -> Moves:
        return Moves(*(getattr(self, name)[part] for name in self.__dataclass_fields__))

    @staticmethod
    def join(a: Moves, b: Moves) -> Moves:
        return Moves(*(np.concatenate([getattr(a, n), getattr(b, n)]) for n in a.__dataclass_fields__))

    @staticmethod
    def empty() -> Moves:
        return Moves(*(np.zeros(0, bool if n == "start" else float) for n in Moves.__dataclass_fields__))


def axis_limited(unit: np.ndarray, rates, accels) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pencilbot.machine.motion.axis_limited` of each ``unit`` row."""
    rate, accel = np.full(len(unit), math.inf), np.full(len(unit), math.inf)
    with np.errstate(divide="ignore"):
        for k in range(3):
            u = np.abs(unit[:, k])
            moving = u != 0
            rate = np.where(moving, np.minimum(rate, rates[k] / u), rate)
            accel = np.where(moving, np.minimum(accel, accels[k] / u), accel)
    return rate, accel


def max_entries(before: np.ndarray, unit: np.ndarray, accel, deviation: float, nominal, nominal_before):
    """The planner's ``max_entry`` of each move after one before it: its corner speed
    (:func:`~pencilbot.machine.motion.junction_speed`) and both moves' nominal speeds."""
    cos_theta = -(before[:, 0] * unit[:, 0] + before[:, 1] * unit[:, 1] + before[:, 2] * unit[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        sin_half = np.sqrt(0.5 * (1.0 - cos_theta))
        corner = np.sqrt(accel * deviation * sin_half / (1.0 - sin_half))
    corner = np.where(cos_theta > REVERSAL_COS, 0.0, np.where(cos_theta < STRAIGHT_COS, math.inf, corner))
    return np.minimum(np.minimum(corner, nominal), nominal_before)


def durations(length, accel, entry, exit_, nominal) -> np.ndarray:
    """:func:`~pencilbot.machine.motion.block_duration` of each move, operation for operation."""
    apex = np.sqrt(np.maximum((2.0 * accel * length + entry * entry + exit_ * exit_) / 2.0, 0.0))
    peak = np.minimum(nominal, np.maximum(np.maximum(apex, entry), exit_))
    d_acc = (peak * peak - entry * entry) / (2.0 * accel)
    d_dec = (peak * peak - exit_ * exit_) / (2.0 * accel)
    cruise = np.maximum(length - d_acc - d_dec, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        seconds = (peak - entry) / accel + (peak - exit_) / accel + cruise / peak
    return np.where(peak > 0, seconds, 0.0)


def time_moves(moves: Moves, entry: float, *, open_run: bool, capacity: int) -> tuple[np.ndarray, float]:
    """The durations of ``moves`` whose exit speed is known, in order, and the entry speed of the
    first one left over. ``entry``: the first move's, unless it starts a run. ``open_run``: the
    last run goes on past these moves (its last ``capacity - 1`` moves wait for the ones after)."""
    n, ahead = len(moves), capacity - 1
    if not n:
        return np.zeros(0), entry
    last = np.flatnonzero(np.append(moves.start[1:], True))  # each run's last move
    end = last[np.searchsorted(last, np.arange(n))]
    timed = n
    if open_run:  # its last moves wait for what follows (the last run begins at its last start)
        starts = np.flatnonzero(moves.start)
        timed = n - min(ahead, n - (int(starts[-1]) if len(starts) else 0))
    first = 0.0 if moves.start[0] else entry
    if not timed:
        return np.zeros(0), first
    reach = 2.0 * moves.accel * moves.length
    bound = _backward(moves.max_entry, reach, end, ahead)[:timed]
    exits = _forward(bound, reach[:timed], first)
    entries = np.concatenate([[first], exits[:-1]])  # a run's last move exits at 0: the next starts from rest
    part = slice(0, timed)
    seconds = durations(moves.length[part], moves.accel[part], entries, exits, moves.nominal[part])
    return seconds, float(exits[-1])


def _backward(max_entry: np.ndarray, reach: np.ndarray, end: np.ndarray, ahead: int) -> np.ndarray:
    """For each move *j*, the entry the backward pass gives move *j + 1* over the window
    *j* .. min(*j* + ``ahead``, its run's end) (0 for a run's last move: it stops)."""
    j = np.arange(len(reach))
    window = np.minimum(j + ahead, end)
    depth = window - j
    speed = np.minimum(max_entry[window], np.sqrt(reach[window]))  # the newest: 0² + 2·a·l
    for m in range(1, ahead):
        i = np.maximum(window - m, 0)
        speed = np.where(depth > m, np.minimum(max_entry[i], np.sqrt(speed * speed + reach[i])), speed)
    return np.where(depth > 0, speed, 0.0)


def _forward(bound: np.ndarray, reach: np.ndarray, first: float) -> np.ndarray:
    """Each move's exit: ``min(bound, sqrt(entry² + reach))``, its entry the exit before it
    (``first`` for the first; a run's last move exits at 0, so the next starts from rest)."""
    n = len(bound)
    exits = bound.copy()
    todo = np.arange(n)
    for _ in range(SWEEPS):
        before = np.where(todo > 0, exits[np.maximum(todo - 1, 0)], first)
        lowered = np.minimum(bound[todo], np.sqrt(before * before + reach[todo]))
        changed = todo[lowered != exits[todo]]
        exits[todo] = lowered
        todo = changed + 1
        todo = todo[todo < n]
        if not len(todo):
            return exits
    # What the sweeps left: every move before the first still to do is final; the rest in order.
    out, bounds, reaches = exits.tolist(), bound.tolist(), reach.tolist()
    for k in range(int(todo[0]), n):
        entry = out[k - 1] if k else first
        out[k] = min(bounds[k], math.sqrt(entry * entry + reaches[k]))
    return np.array(out)
