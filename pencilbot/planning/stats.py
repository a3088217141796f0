"""What a plan costs at the plotter: pen-down and pen-up lengths, lifts, and the plot time.

The time is that of the program the G-code writer makes for a plotter profile, move by move,
with the one motion model of :mod:`pencilbot.machine.motion` (the virtual plotter's planner runs
the same rules): the pen starts at the machine's home (``X0 Y0``, wherever the profile's bed puts
it on the page) and is lifted; then for each path a pen-up travel, a drop, the drawn moves and a
lift; finally the travel back home. Pen commands stop the motion (GRBL synchronises the planner
for a spindle or servo change; a Z pen's move is planned from rest to rest), so every path and
every travel starts and ends at rest, and the pen model says what a lift and a drop cost
(dwells, and the Z travel of a Z pen). Within a path, corners follow the junction-deviation rule
and every segment its trapezoid, planned in closed form over all segments at once.

demo, stat and the G-code header all report this one estimate.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from pencilbot.machine.bed import Placement
from pencilbot.machine.motion import axis_scale, move_times, path_speeds
from pencilbot.machine.profile import Profile
from pencilbot.paths import Paths
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
        The plotter: bed (where home is on the page), motion limits, pen.

    Returns
    -------
    PlanStats
    """
    home = Placement.on_bed(plan.page, profile.bed).home()
    lift, drop = profile.pen_model.change_seconds(profile.motion)
    position = home
    layers: dict[str, Stats] = {}
    for index, layer in enumerate(plan.layers):
        stats = _layer_stats(layer.paths, position, profile, lift, drop)
        if index == 0:
            stats += Stats(seconds=lift)  # the pen is lifted before the first move
        if len(layer.paths):
            position = layer.paths.lasts[-1]
        if index == len(plan.layers) - 1:
            back = _travel(np.array([position]), np.array([home]), profile)
            stats += Stats(pen_up_mm=float(back[0].sum()), seconds=float(back[1].sum()))
        layers[layer.name] = layers.get(layer.name, Stats()) + stats
    total = sum(layers.values(), Stats()) if layers else Stats(seconds=lift)
    return PlanStats(layers, total)


def _layer_stats(paths: Paths, position: np.ndarray, profile: Profile, lift: float, drop: float) -> Stats:
    if not len(paths):
        return Stats()
    hops, travel_seconds = _travel(np.vstack([position, paths.lasts[:-1]]), paths.firsts, profile)
    drawn_mm, segments, draw_seconds = _draw(paths, profile)
    return Stats(
        pen_down_mm=float(drawn_mm),
        pen_up_mm=float(hops.sum()),
        lifts=len(paths),
        paths=len(paths),
        segments=segments,
        seconds=float(travel_seconds.sum() + draw_seconds + len(paths) * (lift + drop)),
    )


def _travel(tails: np.ndarray, heads: np.ndarray, profile: Profile) -> tuple[np.ndarray, np.ndarray]:
    """Length (mm) and seconds of the pen-up moves ``tails[i] → heads[i]``, each from rest to rest."""
    step = heads - tails
    length = np.hypot(*step.T)
    motion, firmware = profile.motion, profile.firmware
    moving = length > 0
    scale = np.ones(len(length))
    scale[moving] = axis_scale(step[moving] / length[moving, None])
    # GRBL runs G0 at every axis's top rate (so a diagonal is faster); Marlin at the F it is given.
    rate = motion.travel_speed if firmware.rapids_take_feed else motion.axis_rate / 60.0 * scale
    return length, move_times(length, 0.0, 0.0, rate, motion.acceleration * scale)


def _draw(paths: Paths, profile: Profile) -> tuple[float, int, float]:
    """Pen-down length (mm), segment count and seconds of all paths, vectorised over segments."""
    owner = paths.owners()
    step = np.diff(paths.points, axis=0)
    length = np.hypot(*step.T)
    # Real segments: consecutive points of one path that are not the same point.
    real = (owner[1:] == owner[:-1]) & (length > 0)
    step, length, owner = step[real], length[real], owner[1:][real]
    if len(length) == 0:
        return 0.0, 0, 0.0
    unit = step / length[:, None]
    motion = profile.motion
    accel = motion.acceleration * axis_scale(unit)  # GRBL limits acceleration axis by axis
    # A vertex that starts or ends a path is a stop; between segments of one path, a corner.
    v = path_speeds(length, unit, owner[1:] == owner[:-1], motion.draw_speed, accel, motion.junction_deviation)
    seconds = move_times(length, v[:-1], v[1:], motion.draw_speed, accel).sum()
    return float(length.sum()), len(length), float(seconds)


def duration_text(seconds: float) -> str:
    """``H:MM:SS`` for a duration in seconds (how plot times are shown everywhere)."""
    hours, rest = divmod(round(seconds), 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}"
