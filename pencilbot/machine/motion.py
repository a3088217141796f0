"""The motion model: how fast a GRBL-style planner moves the pen, written once.

Both the plot-time estimate (:mod:`pencilbot.planning.stats`, vectorised over a whole plan) and the
virtual plotter's look-ahead planner (:mod:`sim.gcode.planner`, one block at a time) use these rules,
each in the form it needs (arrays, or plain floats on the simulator's per-line path); the tests
hold the two forms to the same numbers.

* Every move has a trapezoidal speed profile at constant acceleration: accelerate, cruise at
  the nominal speed, decelerate; a triangle when the move is too short to reach it.
* At a corner between two moves the speed is limited by GRBL's junction-deviation rule
  ``v² = a · δ · sin(θ/2) / (1 − sin(θ/2))``, θ the angle between the moves as GRBL measures it
  (within 1e-6 of a full reversal: stop; of straight on: no limit).
* A move's rate and acceleration are limited axis by axis (GRBL's
  ``limit_value_by_axis_maximum``): along unit vector ``u`` the rate is ``min_i(limit_i / |u_i|)``,
  so a diagonal rapid runs faster than either axis's limit alone.

Units: mm, mm/s, mm/s², s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: GRBL's cut-offs on ``cos θ`` (θ between the moves; 1 = full reversal, −1 = straight on).
REVERSAL_COS = 0.999999
STRAIGHT_COS = -0.999999


@dataclass(frozen=True)
class Motion:
    """A plotter's motion limits, as a profile's ``[motion]`` table gives them.

    Attributes
    ----------
    draw_feed, travel_feed : float
        mm/min with the pen down (G1 F) and up (G0; GRBL runs G0 at its ``$110``/``$111`` rates).
    acceleration : float
        mm/s² on every axis (GRBL ``$120``–``$122``).
    junction_deviation : float
        mm (GRBL ``$11``).
    """

    draw_feed: float
    travel_feed: float
    acceleration: float
    junction_deviation: float

    @property
    def draw_speed(self) -> float:
        """Pen-down speed, mm/s."""
        return self.draw_feed / 60.0

    @property
    def travel_speed(self) -> float:
        """Pen-up speed, mm/s."""
        return self.travel_feed / 60.0

    @property
    def axis_rate(self) -> float:
        """Each axis's top rate (GRBL ``$110``–``$112``), mm/min: what G0 runs at on one axis."""
        return max(self.travel_feed, self.draw_feed)


# --- the scalar forms: one move or one corner at a time (the simulator's planner) --------------


def junction_speed(prev_unit, unit, accel: float, deviation: float) -> float:
    """Corner speed (mm/s) between two unit directions (3-tuples), GRBL's junction deviation."""
    cos_theta = -(prev_unit[0] * unit[0] + prev_unit[1] * unit[1] + prev_unit[2] * unit[2])
    if cos_theta > REVERSAL_COS:
        return 0.0
    if cos_theta < STRAIGHT_COS:
        return math.inf
    sin_half = math.sqrt(0.5 * (1.0 - cos_theta))
    return math.sqrt(accel * deviation * sin_half / (1.0 - sin_half))


def peak_speed(length: float, accel: float, entry: float, exit_: float, nominal: float) -> float:
    """Highest speed of a move: nominal if there is room to cruise, else the triangle's apex."""
    apex = math.sqrt(max((2.0 * accel * length + entry * entry + exit_ * exit_) / 2.0, 0.0))
    return min(nominal, max(apex, entry, exit_))


def block_duration(length: float, accel: float, entry: float, exit_: float, nominal: float) -> float:
    """Seconds to cover ``length`` mm starting at ``entry`` and ending at ``exit_`` mm/s."""
    peak = peak_speed(length, accel, entry, exit_, nominal)
    d_acc = (peak * peak - entry * entry) / (2.0 * accel)
    d_dec = (peak * peak - exit_ * exit_) / (2.0 * accel)
    cruise = max(length - d_acc - d_dec, 0.0)
    return (peak - entry) / accel + (peak - exit_) / accel + cruise / peak if peak > 0 else 0.0


def axis_limited(unit, rates, accels) -> tuple[float, float]:
    """Rate and acceleration along ``unit`` given per-axis limits (same units as the limits)."""
    rate = accel = math.inf
    for u, axis_rate, axis_accel in zip(unit, rates, accels):
        if u:
            u = abs(u)
            rate = min(rate, axis_rate / u)
            accel = min(accel, axis_accel / u)
    return rate, accel


# --- the array forms: whole plans at once (the estimate) ---------------------------------------


def junction_speeds_squared(cos_theta: np.ndarray, accel: float, deviation: float) -> np.ndarray:
    """:func:`junction_speed` squared for an array of ``cos θ`` (inf: no limit)."""
    sin_half = np.sqrt(np.clip((1.0 - cos_theta) / 2.0, 0.0, 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):  # 0 · ∞ where straight on (deviation 0)
        v2 = accel * deviation * sin_half / (1.0 - sin_half)
    return np.where(cos_theta > REVERSAL_COS, 0.0, np.where(cos_theta < STRAIGHT_COS, np.inf, v2))


def move_times(length, v_in, v_out, v_max, accel) -> np.ndarray:
    """:func:`block_duration` for arrays of moves (``v_max`` and ``accel`` may be arrays too).

    Speeds must be reachable (a planner guarantees ``|v_in² − v_out²| ≤ 2·a·length``).
    """
    length = np.asarray(length, np.float64)
    v_in = np.broadcast_to(np.asarray(v_in, np.float64), length.shape)
    v_out = np.broadcast_to(np.asarray(v_out, np.float64), length.shape)
    ramps = (2 * v_max**2 - v_in**2 - v_out**2) / (2 * accel)  # distance to reach v_max and leave it
    peak = np.sqrt(np.minimum((2 * accel * length + v_in**2 + v_out**2) / 2, v_max**2))
    cruise = np.maximum(length - ramps, 0.0) / v_max
    return (2 * peak - v_in - v_out) / accel + cruise


def axis_scale(units: np.ndarray) -> np.ndarray:
    """:func:`axis_limited` for equal limits on every axis: the factor ``1 / max_i |u_i|``
    that a move's rate and acceleration get along each unit vector of ``units`` (N, d)."""
    return 1.0 / np.maximum(np.abs(units).max(axis=1), 1e-12)


def path_speeds(
    lengths: np.ndarray, units: np.ndarray, joined: np.ndarray, speed, accel, deviation: float
) -> np.ndarray:
    """Speed (mm/s) at every vertex of a run of moves, planned with unlimited look-ahead.

    Parameters
    ----------
    lengths : (M,) array
        Move lengths, mm (all > 0).
    units : (M, d) array
        Their unit directions.
    joined : (M − 1,) bool array
        Whether move ``k + 1`` follows move ``k`` without a stop (same path); a stop otherwise.
    speed : float or (M,) array
        Nominal speed of each move, mm/s (a corner is taken at most at the slower one's).
    accel : float or (M,) array
        Acceleration of each move, mm/s² (a corner is planned with the next move's).
    deviation : float
        Junction deviation, mm.

    Returns
    -------
    (M + 1,) array
        Speed entering each move and, last, leaving the final one (0: every run ends at rest).

    Notes
    -----
    The backward/forward pass of a look-ahead planner (``v_{k+1}² ≤ v_k² + 2·a_k·L_k`` along the
    run and back) in closed form: the reachable ``v²`` at vertex ``i`` is
    ``min_j cap_j + |P_i − P_j|`` with ``P`` the running sum of ``2·a_k·L_k``, which splits into
    two running minima.
    """
    count = len(lengths)
    accel = np.broadcast_to(np.asarray(accel, np.float64), lengths.shape)
    speed = np.broadcast_to(np.asarray(speed, np.float64), lengths.shape)
    cos_theta = -np.einsum("ij,ij->i", units[:-1], units[1:])  # GRBL's junction_cos_theta
    corner = junction_speeds_squared(cos_theta, accel[1:], deviation)
    cap = np.zeros(count + 1)  # v² limit at each vertex
    cap[1:-1] = np.where(joined, np.minimum(corner, np.minimum(speed[:-1], speed[1:]) ** 2), 0.0)
    along = np.concatenate([[0.0], np.cumsum(2.0 * accel * lengths)])
    ahead = np.minimum.accumulate((cap + along)[::-1])[::-1] - along
    behind = np.minimum.accumulate(cap - along) + along
    return np.sqrt(np.maximum(np.minimum(ahead, behind), 0.0))
