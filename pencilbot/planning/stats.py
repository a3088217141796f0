"""What a plan costs at the plotter: pen-down and pen-up lengths, lifts, and the plot time.

The time is that of the program the G-code writer makes for a plotter profile, move by move,
with the one motion model of :mod:`pencilbot.machine.motion` (the virtual plotter's planner runs
the same rules): the pen starts at the machine's home (``X0 Y0``, wherever the profile's bed puts
it on the page) and is lifted; then for each path a pen-up travel, a drop, the drawn moves and a
lift; finally the travel back home. Pen commands stop the motion (GRBL synchronises the planner
for a spindle or servo change; a Z pen's move is planned from rest to rest), so every path and
every travel starts and ends at rest, and the pen model says what a lift and a drop cost
(dwells, and the Z travel of a Z pen). Within a path, corners follow the junction-deviation rule
and every segment its trapezoid, planned in closed form over all segments at once. Every time
the motion comes to rest the board stands still for its idle lock (GRBL's ``$1``: 25 ms on
every travel and every path, the biggest part of a plot's time after the moves and dwells).

demo, stat and the G-code header all report this one estimate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from pencilbot.machine.bed import Placement
from pencilbot.machine.motion import axis_scale, move_times, path_speeds
from pencilbot.machine.profile import Profile
from pencilbot.planning.plan import Plan


@dataclass(frozen=True)
class Stats:
    """What one layer (or the whole plan) costs at the plotter."""

    pen_down_mm: float = 0.0
    pen_up_mm: float = 0.0
    lifts: int = 0
    paths: int = 0
    segments: int = 0
    seconds: float = 0.0

    def __add__(self, other: Stats) -> Stats:
        return Stats(*(getattr(self, f.name) + getattr(other, f.name) for f in fields(self)))


@dataclass(frozen=True)
class PlanStats:
    """Per-layer stats in drawing order (``layers`` maps layer name → :class:`Stats`) and the total.

    The first layer carries the pen's first lift and the last the travel back home, so the
    total is the sum of the layers.
    """

    layers: dict[str, Stats]
    total: Stats

    def as_dict(self) -> dict:
        row = lambda s: {f.name: getattr(s, f.name) for f in fields(s)}  # noqa: E731
        return {"layers": {k: row(v) for k, v in self.layers.items()}, "total": row(self.total)}


def estimate(plan: Plan, profile: Profile) -> PlanStats:
    """Plot time and pen travel of ``plan`` on the plotter of ``profile``, layer by layer.

    Parameters
    ----------
    plan : Plan
    profile : Profile
        The plotter: bed (where home is on the page), motion limits, pen, firmware.

    Returns
    -------
    PlanStats
    """
    moves = _Program(plan, profile)
    motion = profile.motion
    seconds = np.zeros(0)
    if len(moves.length):
        v = path_speeds(
            moves.length, moves.unit, moves.joined, moves.nominal, moves.accel, motion.junction_deviation
        )
        seconds = move_times(moves.length, v[:-1], v[1:], moves.nominal, moves.accel)
    pen, n_layers = profile.pen_model, max(len(plan.layers), 1)
    per_layer = lambda values: np.bincount(moves.layer, weights=values, minlength=n_layers)  # noqa: E731
    drawn, travelled = moves.kind == _DRAW, moves.kind == _TRAVEL
    paths = np.array([len(layer.paths) for layer in plan.layers] or [0])
    stops = np.append(~moves.joined, True) if len(moves.length) else np.zeros(0, bool)  # runs' last moves
    time = per_layer(seconds + stops * profile.firmware.idle_lock) + paths * (pen.up_delay + pen.down_delay)
    time[0] += pen.up_delay  # the first lift
    columns = (
        per_layer(moves.length * drawn),
        per_layer(moves.length * travelled),
        paths,
        paths,
        np.bincount(moves.layer[drawn], minlength=n_layers),
        time,
    )
    layers: dict[str, Stats] = {}
    for index, layer in enumerate(plan.layers):
        values: list[Any] = [
            float(c[index]) if f.type == "float" else int(c[index]) for c, f in zip(columns, fields(Stats))
        ]
        row = Stats(*values)
        layers[layer.name] = layers.get(layer.name, Stats()) + row
    total = sum(layers.values(), Stats()) if layers else Stats(seconds=float(time[0]))
    return PlanStats(layers, total)


_TRAVEL, _PEN, _DRAW = 0, 1, 2


class _Program:
    """Every move the G-code program of a plan makes, in order, as arrays (machine-neutral:
    page mm, Z in the pen's heights).

    Per path: a pen-up travel, the drop, the drawn segments, the lift; then the travel home.
    A Z pen's drops and lifts are moves of the axes and join the motion at corners; a spindle or
    servo pen change, and any dwell, stops it (``joined`` is False across it).
    """

    def __init__(self, plan: Plan, profile: Profile) -> None:
        pen, motion, firmware = profile.pen_model, profile.motion, profile.firmware
        paths = plan.paths()
        count = len(paths)
        layer_of_path = np.repeat(np.arange(len(plan.layers)), [len(layer.paths) for layer in plan.layers])
        home = Placement.on_bed(plan.page, profile.bed).home()
        z_pen = pen.moves_with_the_axes
        up, down = (pen.up, pen.down) if z_pen else (0.0, 0.0)
        stride = float(paths.lengths.max() + 4) if count else 4.0  # sort keys: path·stride + slot

        owner = paths.owners()
        step = np.diff(paths.points, axis=0)
        within = (owner[1:] == owner[:-1]) & (np.hypot(*step.T) > 0)
        draw_path = owner[1:][within]
        local = (np.arange(1, len(paths.points)) - paths.offsets[owner[1:]])[within]
        tails = np.vstack([home, paths.lasts]) if count else home[None]
        heads = np.vstack([paths.firsts, home]) if count else home[None]
        hop = np.column_stack([heads - tails, np.zeros(count + 1)])
        pieces = [  # (vectors, sort keys, kind, path)
            (hop, np.arange(count + 1) * stride, _TRAVEL, np.append(np.arange(count), max(count - 1, 0))),
            (
                np.column_stack([step[within], np.zeros(len(draw_path))]),
                draw_path * stride + 1.5 + local,
                _DRAW,
                draw_path,
            ),
        ]
        syncs = []
        if z_pen:
            each = np.arange(count)
            pieces += [
                (np.tile([0.0, 0.0, down - up], (count, 1)), each * stride + 1, _PEN, each),
                (np.tile([0.0, 0.0, up - down], (count, 1)), each * stride + stride - 1, _PEN, each),
                (np.array([[0.0, 0.0, up]]), np.array([-1.0]), _PEN, np.zeros(1, np.int64)),  # the first lift
            ]
            # A dwell after a pen move (G4) stops the motion; the moves themselves do not.
            if pen.down_delay:
                syncs.append(np.arange(count) * stride + 1.25)
            if pen.up_delay:
                syncs += [np.arange(count) * stride + stride - 0.5, np.array([-0.5])]
        else:  # a spindle or servo change waits for the motion to end, before and after
            syncs += [np.arange(count) * stride + 1, np.arange(count) * stride + stride - 1]
        vectors = np.concatenate([v for v, _, _, _ in pieces])
        keys = np.concatenate([k for _, k, _, _ in pieces])
        kind = np.concatenate([np.full(len(k), t) for _, k, t, _ in pieces])
        path = np.concatenate([p for _, _, _, p in pieces]).astype(np.int64)
        length = np.sqrt((vectors**2).sum(axis=1))
        order = np.argsort(keys, kind="stable")
        order = order[length[order] > 0]  # a move to where the pen already is, is none
        self.length, self.kind = length[order], kind[order]
        self.unit = vectors[order] / self.length[:, None] if len(order) else np.zeros((0, 3))
        run = np.searchsorted(np.sort(np.concatenate(syncs)) if syncs else np.zeros(0), keys[order])
        self.joined = run[1:] == run[:-1]
        self.layer = layer_of_path[path[order]] if count else np.zeros(len(order), np.int64)
        scale = axis_scale(self.unit) if len(order) else np.zeros(0)  # GRBL limits each axis
        self.accel = motion.acceleration * scale
        rapid = motion.travel_speed if firmware.rapids_take_feed else motion.axis_rate / 60.0 * scale
        pen_speed = np.where(
            self.unit[:, 2] > 0, pen.z_speed(motion, lifting=True), pen.z_speed(motion, lifting=False)
        )
        self.nominal = np.select(
            [self.kind == _TRAVEL, self.kind == _DRAW], [rapid, motion.draw_speed], pen_speed
        )


def duration_text(seconds: float) -> str:
    """``H:MM:SS`` for a duration in seconds (how plot times are shown everywhere); ``?:??:??``
    for one that is not finite (a plan with coordinates that are not)."""
    if not math.isfinite(seconds):
        return "?:??:??"
    hours, rest = divmod(round(seconds), 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}"
