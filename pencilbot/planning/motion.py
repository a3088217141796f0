"""How long a plan takes to plot, and how much the pen travels up and down.

The motion model is GRBL's, so the estimate matches what a GRBL plotter does:

* every move has a trapezoidal speed profile (accelerate, cruise, decelerate) at a constant
  acceleration;
* at a corner between two drawn segments the speed is limited by the junction-deviation rule:
  ``v² = a · δ · sin(θ/2) / (1 − sin(θ/2))`` with θ the angle between the segments as GRBL
  measures it (180° = straight on, unlimited; 0° = full reversal, stop);
* the pen stops before it lifts and after it drops (a pen command is a planner sync), so every
  drawn path and every pen-up travel starts and ends at rest; lift and drop add fixed delays.

The speed plan is the usual backward/forward pass (``v_i² ≤ v_j² + 2a·s`` between vertices),
written in closed form as running minima over the whole plan, so it is vectorised over segments.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.paths import Paths
from pencilbot.planning.plan import Plan


@dataclass(frozen=True)
class MotionSettings:
    """Machine motion limits.

    Attributes
    ----------
    draw_speed : float
        Pen-down feed rate, mm/s.
    travel_speed : float
        Pen-up (rapid) speed, mm/s.
    acceleration : float
        mm/s², both for drawing and travel.
    junction_deviation : float
        GRBL's ``$11``, mm: how sharply corners may be taken at speed.
    pen_up_delay, pen_down_delay : float
        Seconds the pen needs to lift or drop (dwell after the pen command).
    """

    draw_speed: float = 25.0
    travel_speed: float = 100.0
    acceleration: float = 500.0
    junction_deviation: float = 0.01
    pen_up_delay: float = 0.15
    pen_down_delay: float = 0.15

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            delay = f.name.endswith("delay")
            if not np.isfinite(value) or value < 0 or (value == 0 and not delay):
                need = "zero or more" if delay else "more than zero"
                raise PencilbotError(f"motion setting {f.name} = {value!r} is invalid: it must be {need}")


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
    """Per-layer stats in drawing order (``layers`` maps layer name → :class:`Stats`) and the total."""

    layers: dict[str, Stats]
    total: Stats

    def as_dict(self) -> dict:
        row = lambda s: {f.name: getattr(s, f.name) for f in fields(s)}  # noqa: E731
        return {"layers": {k: row(v) for k, v in self.layers.items()}, "total": row(self.total)}


def estimate(plan: Plan, settings: MotionSettings | None = None, *, start=(0.0, 0.0)) -> PlanStats:
    """Estimate plot time and pen travel of ``plan``, layer by layer.

    Parameters
    ----------
    plan : Plan
    settings : MotionSettings, optional
        Default :class:`MotionSettings` when omitted.
    start : (float, float), optional
        Pen position before the first path, mm (the plotter's home). Each layer's travel starts
        where the previous layer ended; the return to home is not counted.

    Returns
    -------
    PlanStats
    """
    settings = settings or MotionSettings()
    position = np.asarray(start, np.float64)
    layers: dict[str, Stats] = {}
    for layer in plan.layers:
        stats = _layer_stats(layer.paths, position, settings)
        layers[layer.name] = layers.get(layer.name, Stats()) + stats
        if len(layer.paths):
            position = layer.paths.lasts[-1]
    total = sum(layers.values(), Stats())
    return PlanStats(layers, total)


def _layer_stats(paths: Paths, position: np.ndarray, s: MotionSettings) -> Stats:
    if not len(paths):
        return Stats()
    heads = paths.firsts
    tails = np.vstack([position, paths.lasts[:-1]])
    hops = np.hypot(*(heads - tails).T)
    travel_seconds = move_times(hops, 0.0, 0.0, s.travel_speed, s.acceleration).sum()
    drawn_mm, segments, draw_seconds = _draw(paths, s)
    lifts = len(paths)
    return Stats(
        pen_down_mm=float(drawn_mm),
        pen_up_mm=float(hops.sum()),
        lifts=lifts,
        paths=len(paths),
        segments=segments,
        seconds=float(travel_seconds + draw_seconds + lifts * (s.pen_up_delay + s.pen_down_delay)),
    )


def _draw(paths: Paths, s: MotionSettings) -> tuple[float, int, float]:
    """Pen-down length (mm), segment count and seconds of all paths, vectorised over segments."""
    pts = paths.points
    owner = paths.owners()
    step = np.diff(pts, axis=0)
    length = np.hypot(*step.T)
    # Real segments: consecutive points of one path that are not the same point.
    real = (owner[1:] == owner[:-1]) & (length > 0)
    step, length, owner = step[real], length[real], owner[1:][real]
    count = len(length)
    if count == 0:
        return 0.0, 0, 0.0
    unit = step / length[:, None]
    # Vertex k is the start of segment k; vertex count is the end of the last one. A vertex that
    # starts a path (or ends one) is a stop; otherwise the junction rule limits its speed.
    joined = owner[1:] == owner[:-1]
    cos_theta = -np.einsum("ij,ij->i", unit[:-1], unit[1:])  # GRBL's junction_cos_theta
    sin_half = np.sqrt(np.clip((1.0 - cos_theta) / 2.0, 0.0, 1.0))
    with np.errstate(divide="ignore"):
        junction = s.acceleration * s.junction_deviation * sin_half / (1.0 - sin_half)
    # GRBL's cut-offs: within 1e-6 of a full reversal stop, of straight on go full speed.
    junction = np.where(cos_theta > 0.999999, 0.0, np.where(cos_theta < -0.999999, np.inf, junction))
    cap = np.zeros(count + 1)  # v² limit at each vertex
    cap[1:-1] = np.where(joined, np.minimum(junction, s.draw_speed**2), 0.0)
    # Reachable v² at vertex i: min over j of cap_j + 2a·|P_i − P_j| (P = distance along the plan).
    # Splitting into j ≥ i (braking ahead) and j ≤ i (accelerating behind) gives running minima.
    P = 2.0 * s.acceleration * np.concatenate([[0.0], np.cumsum(length)])
    ahead = np.minimum.accumulate((cap + P)[::-1])[::-1] - P
    behind = np.minimum.accumulate(cap - P) + P
    v = np.sqrt(np.maximum(np.minimum(ahead, behind), 0.0))
    seconds = move_times(length, v[:-1], v[1:], s.draw_speed, s.acceleration).sum()
    return float(length.sum()), count, float(seconds)


def duration_text(seconds: float) -> str:
    """``H:MM:SS`` for a duration in seconds (how plot times are shown everywhere)."""
    hours, rest = divmod(round(seconds), 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}"


def move_times(length, v_in, v_out, v_max: float, accel: float) -> np.ndarray:
    """Seconds for moves of ``length`` mm entered at ``v_in`` and left at ``v_out`` mm/s.

    Trapezoid (accelerate to ``v_max``, cruise, decelerate) when the move is long enough, else a
    triangle peaking where the acceleration and braking ramps meet. Speeds must be reachable
    (the planner guarantees ``|v_in² − v_out²| ≤ 2·a·length``).
    """
    length = np.asarray(length, np.float64)
    v_in = np.broadcast_to(np.asarray(v_in, np.float64), length.shape)
    v_out = np.broadcast_to(np.asarray(v_out, np.float64), length.shape)
    ramps = (2 * v_max**2 - v_in**2 - v_out**2) / (2 * accel)  # distance to reach v_max and leave it
    peak = np.sqrt(np.minimum((2 * accel * length + v_in**2 + v_out**2) / 2, v_max**2))
    cruise = np.maximum(length - ramps, 0.0) / v_max
    return (2 * peak - v_in - v_out) / accel + cruise
