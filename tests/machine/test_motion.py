"""The one motion model: the array forms (the estimate's) equal the scalar forms (the simulator's
planner), and the closed-form speed plan equals a sequential look-ahead planner."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.machine.motion import (
    axis_limited,
    axis_scale,
    block_duration,
    junction_speed,
    junction_speeds_squared,
    move_times,
    path_speeds,
)

unit_vectors = st.floats(0, 2 * math.pi).map(lambda a: (math.cos(a), math.sin(a), 0.0))


@settings(max_examples=200, deadline=None)
@given(unit_vectors, unit_vectors, st.floats(10, 5000), st.floats(0.001, 0.5))
def test_junction_speed_forms_agree(u, w, accel, deviation):
    scalar = junction_speed(u, w, accel, deviation)
    cos_theta = -np.dot(u, w)
    vector = math.sqrt(junction_speeds_squared(np.array([cos_theta]), accel, deviation)[0])
    # Near a straight junction 1 − sin(θ/2) cancels: the two forms round differently there.
    assert vector == pytest.approx(scalar, rel=1e-9) or (math.isinf(scalar) and math.isinf(vector))


@settings(max_examples=200, deadline=None)
@given(st.floats(0, 200), st.floats(1, 200), st.floats(10, 5000), st.floats(0, 1), st.floats(0, 1))
def test_trapezoid_forms_agree(length, nominal, accel, f_in, f_out):
    # entry and exit speeds the planner could choose: reachable within the move
    v_in = f_in * min(nominal, math.sqrt(2 * accel * length))
    v_out = f_out * min(nominal, math.sqrt(v_in**2 + 2 * accel * length))
    v_in = min(v_in, math.sqrt(v_out**2 + 2 * accel * length))
    scalar = block_duration(length, accel, v_in, v_out, nominal)
    assert move_times(np.array([length]), v_in, v_out, nominal, accel)[0] == pytest.approx(
        scalar, rel=1e-9, abs=1e-12
    )


@settings(max_examples=100, deadline=None)
@given(unit_vectors, st.floats(100, 10000), st.floats(10, 5000))
def test_axis_limits_forms_agree(u, rate, accel):
    along_rate, along_accel = axis_limited(u, (rate, rate, rate), (accel, accel, accel))
    scale = axis_scale(np.array([u]))[0]
    assert along_rate == pytest.approx(rate * scale) and along_accel == pytest.approx(accel * scale)
    assert rate <= along_rate <= rate * math.sqrt(2) + 1e-9  # a diagonal runs faster than one axis


def test_trapezoid_and_triangle_profiles():
    # v_max 10 mm/s, a 100 mm/s²: ramps take 0.1 s and 0.5 mm each
    assert move_times(np.array([10.0]), 0, 0, 10, 100)[0] == pytest.approx(0.2 + 9.0 / 10)
    # 0.5 mm is too short to reach v_max: peak sqrt(a·L) = sqrt(50)
    assert move_times(np.array([0.5]), 0, 0, 10, 100)[0] == pytest.approx(2 * math.sqrt(50) / 100)
    # entering already at full speed: no ramp up
    assert move_times(np.array([10.0]), 10, 0, 10, 100)[0] == pytest.approx(0.1 + 9.5 / 10)


def sequential_plan(lengths, units, joined, speed, accel, deviation):
    """A planner written the long way, as the simulator's: a corner is capped by the scalar junction
    rule and both moves' nominal speeds, then a backward and a forward pass, then every move's
    trapezoid with the scalar duration."""
    cap = [0.0]
    for k in range(1, len(lengths)):
        corner = junction_speed(tuple(units[k - 1]) + (0.0,), tuple(units[k]) + (0.0,), accel[k], deviation)
        cap.append(min(corner, speed[k - 1], speed[k]) ** 2 if joined[k - 1] else 0.0)
    cap.append(0.0)
    for k in range(len(lengths) - 1, -1, -1):  # backward: able to brake
        cap[k] = min(cap[k], cap[k + 1] + 2 * accel[k] * lengths[k])
    for k in range(len(lengths)):  # forward: able to accelerate
        cap[k + 1] = min(cap[k + 1], cap[k] + 2 * accel[k] * lengths[k])
    v = [math.sqrt(c) for c in cap]
    return v, sum(block_duration(lengths[k], accel[k], v[k], v[k + 1], speed[k]) for k in range(len(lengths)))


@settings(max_examples=80, deadline=None)
@given(
    st.lists(st.tuples(st.floats(0, 50), st.floats(0, 50)), min_size=2, max_size=14),
    st.lists(st.booleans(), min_size=13, max_size=13),
    st.lists(st.floats(5, 80), min_size=13, max_size=13),
    st.floats(50, 3000),
    st.floats(0.001, 0.2),
)
def test_closed_form_speeds_equal_a_sequential_planner(points, joins, speeds, accel, deviation):
    step = np.diff(np.array(points), axis=0)
    lengths = np.hypot(*step.T)
    keep = lengths > 1e-6
    step, lengths = step[keep], lengths[keep]
    if len(lengths) == 0:
        return
    units = step / lengths[:, None]
    accels = accel * axis_scale(units)
    joined = np.array(joins[: len(lengths) - 1], dtype=bool)
    speed = np.array(speeds[: len(lengths)])
    v = path_speeds(lengths, units, joined, speed, accels, deviation)
    want_v, want_seconds = sequential_plan(lengths, units, joined, speed, accels, deviation)
    np.testing.assert_allclose(v, want_v, rtol=1e-9, atol=1e-9)
    got_seconds = move_times(lengths, v[:-1], v[1:], speed, accels).sum()
    assert got_seconds == pytest.approx(want_seconds, rel=1e-9, abs=1e-12)
