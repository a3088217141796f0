"""Motion estimate: trapezoids, GRBL junction speeds, pen delays, per-layer sums."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.errors import PencilbotError
from pencilbot.planning.motion import MotionSettings, Stats, estimate, move_times
from pencilbot.planning.plan import Layer, Page, Plan

NO_PEN = dict(pen_up_delay=0.0, pen_down_delay=0.0)


def plan_of(*layers):
    return Plan(Page(300, 300), [Layer(name, paths) for name, paths in layers])


def reference_time(path, s: MotionSettings) -> float:
    """Sequential GRBL-style planner (backward then forward pass), one path from rest to rest."""
    pts = [p for i, p in enumerate(np.asarray(path, float)) if i == 0 or np.any(p != path[i - 1])]
    pts = np.array(pts)
    seg = np.diff(pts, axis=0)
    length = np.hypot(*seg.T)
    if len(length) == 0:
        return 0.0
    unit = seg / length[:, None]
    cap = [0.0]
    for u, w in zip(unit[:-1], unit[1:]):
        cos_theta = -float(u @ w)
        sin_half = math.sqrt(max(0.0, (1 - cos_theta) / 2))
        if cos_theta > 0.999999:  # GRBL: reversal
            v2 = 0.0
        elif cos_theta < -0.999999:  # GRBL: straight on
            v2 = s.draw_speed**2
        else:
            v2 = s.acceleration * s.junction_deviation * sin_half / (1 - sin_half)
        cap.append(min(v2, s.draw_speed**2))
    cap.append(0.0)
    for i in range(len(length) - 1, -1, -1):  # backward: able to brake
        cap[i] = min(cap[i], cap[i + 1] + 2 * s.acceleration * length[i])
    for i in range(len(length)):  # forward: able to accelerate
        cap[i + 1] = min(cap[i + 1], cap[i] + 2 * s.acceleration * length[i])
    total = 0.0
    a, vmax = s.acceleration, s.draw_speed
    for L, w0, w1 in zip(length, cap[:-1], cap[1:]):
        v0, v1 = math.sqrt(w0), math.sqrt(w1)
        up, down = (vmax**2 - w0) / (2 * a), (vmax**2 - w1) / (2 * a)
        if up + down <= L:
            total += (vmax - v0) / a + (vmax - v1) / a + (L - up - down) / vmax
        else:
            vp = math.sqrt((2 * a * L + w0 + w1) / 2)
            total += (vp - v0) / a + (vp - v1) / a
    return total


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.floats(0, 50), st.floats(0, 50)), min_size=2, max_size=12),
    st.floats(5, 80),
    st.floats(50, 3000),
    st.floats(0.001, 0.2),
)
def test_vectorised_planner_matches_sequential_reference(points, speed, accel, jd):
    s = MotionSettings(draw_speed=speed, acceleration=accel, junction_deviation=jd, **NO_PEN)
    path = np.array(points)
    stats = estimate(plan_of(("a", [path])), s, start=tuple(path[0]))  # no travel
    assert stats.total.seconds == pytest.approx(reference_time(path, s), rel=1e-9, abs=1e-12)


def test_trapezoid_and_triangle_profiles():
    # v_max 10 mm/s, a 100 mm/s²: ramps take 0.1 s and 0.5 mm each
    assert move_times(np.array([10.0]), 0, 0, 10, 100)[0] == pytest.approx(0.2 + 9.0 / 10)
    # 0.5 mm is too short to reach v_max: peak sqrt(a·L) = sqrt(50)
    assert move_times(np.array([0.5]), 0, 0, 10, 100)[0] == pytest.approx(2 * math.sqrt(50) / 100)
    # entering already at full speed: no ramp up
    assert move_times(np.array([10.0]), 10, 0, 10, 100)[0] == pytest.approx(0.1 + 9.5 / 10)


def test_collinear_points_do_not_slow_the_pen():
    s = MotionSettings(**NO_PEN)
    one = estimate(plan_of(("a", [np.array([[0.0, 0.0], [100.0, 0.0]])])), s).total
    many = estimate(plan_of(("a", [np.column_stack([np.linspace(0, 100, 51), np.zeros(51)])])), s).total
    assert many.seconds == pytest.approx(one.seconds)
    assert (one.segments, many.segments) == (1, 50)


def test_reversal_stops_and_right_angle_follows_junction_deviation():
    s = MotionSettings(draw_speed=50, acceleration=200, junction_deviation=0.05, **NO_PEN)
    single = move_times(np.array([20.0]), 0, 0, 50, 200)[0]
    back = estimate(plan_of(("a", [np.array([[0.0, 0], [20, 0], [0, 0]])])), s).total.seconds
    assert back == pytest.approx(2 * single)
    corner = estimate(plan_of(("a", [np.array([[0.0, 0], [20, 0], [20, 20]])])), s).total.seconds
    v = math.sqrt(200 * 0.05 * math.sqrt(0.5) / (1 - math.sqrt(0.5)))  # GRBL at 90°
    expect = 2 * move_times(np.array([20.0]), 0, v, 50, 200)[0]
    assert corner == pytest.approx(expect) and corner < back
    looser = MotionSettings(draw_speed=50, acceleration=200, junction_deviation=0.5, **NO_PEN)
    assert estimate(plan_of(("a", [np.array([[0.0, 0], [20, 0], [20, 20]])])), looser).total.seconds < corner


def test_travel_lifts_delays_and_layers_add_up():
    s = MotionSettings(travel_speed=100, acceleration=1000, pen_up_delay=0.2, pen_down_delay=0.3)
    a = [np.array([[10.0, 0.0], [20.0, 0.0]]), np.array([[20.0, 10.0], [10.0, 10.0]])]
    b = [np.array([[10.0, 40.0], [10.0, 50.0]]), np.array([[7.0, 7.0]])]
    stats = estimate(plan_of(("hatch", a), ("edges", b)), s, start=(0.0, 0.0))
    h, e = stats.layers["hatch"], stats.layers["edges"]
    assert (h.pen_up_mm, h.pen_down_mm, h.lifts, h.paths, h.segments) == (20.0, 20.0, 2, 2, 2)
    assert e.pen_up_mm == pytest.approx(30.0 + math.hypot(3, 43))  # from hatch's last point
    assert (e.lifts, e.paths, e.segments) == (2, 2, 1)
    travel = move_times(np.array([10.0, 10.0]), 0, 0, 100, 1000).sum()
    draw = move_times(np.array([10.0, 10.0]), 0, 0, s.draw_speed, 1000).sum()
    assert h.seconds == pytest.approx(travel + draw + 2 * 0.5)
    assert stats.total == h + e
    assert stats.as_dict()["total"]["lifts"] == 4


def test_empty_plan_costs_nothing():
    stats = estimate(plan_of(("edges", [])))
    assert stats.total == Stats() and stats.layers["edges"] == Stats()


@pytest.mark.parametrize("field", ["draw_speed", "acceleration", "junction_deviation"])
def test_bad_settings_are_user_errors(field):
    with pytest.raises(PencilbotError, match=field):
        MotionSettings(**{field: 0})
    with pytest.raises(PencilbotError, match="pen_up_delay"):
        MotionSettings(pen_up_delay=-1)
