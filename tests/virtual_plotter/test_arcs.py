"""G2/G3 arcs: GRBL's chord count from $12, the geometry of IJK and R arcs in all three planes."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from machines import description
from test_machine import IDLE_LOCK, run

from sim.gcode.arcs import arc_chords
from sim.gcode.machine import Machine


def drawn(*lines, **config):
    """Pen-down polylines (machine mm) of ``lines`` after a pen-down M3 S90."""
    return run(Machine(description(**config)), "M3 S90", *lines).strokes


def test_chord_count_follows_grbl_s_formula_and_tolerance():
    # Full circle of r = 10 at $12 = 0.002: floor(π·10 / √(0.002·(20 − 0.002))) = 157 chords.
    points, count = arc_chords((10, 0, 0), (10, 0, 0), (-10, 0, 0), 10.0, (0, 1, 2), False, 0.002)
    assert count == 157 and len(points) == 157
    points, count = arc_chords((10, 0, 0), (10, 0, 0), (-10, 0, 0), 10.0, (0, 1, 2), False, 0.02)
    assert count == math.floor(math.pi * 10 / math.sqrt(0.02 * (20 - 0.02))) == 49


@settings(max_examples=80, deadline=None)
@given(
    st.floats(0.5, 200),
    st.floats(-math.pi, math.pi),
    st.floats(-math.pi, math.pi),
    st.booleans(),
    st.sampled_from([0.001, 0.002, 0.01, 0.1]),
)
def test_chords_end_on_the_circle_and_stay_near_it(radius, a_start, a_end, clockwise, tolerance):
    start = (radius * math.cos(a_start), radius * math.sin(a_start), 0.0)
    target = (radius * math.cos(a_end), radius * math.sin(a_end), 3.0)
    offset = (-start[0], -start[1], 0.0)
    points, count = arc_chords(start, target, offset, radius, (0, 1, 2), clockwise, tolerance)
    assert np.allclose(points[-1], target)
    ends = np.vstack([start, points])
    r = np.hypot(ends[:, 0], ends[:, 1])
    assert np.allclose(r, radius, atol=1e-6)  # every chord end is on the circle
    if count > 1:
        chord = np.hypot(*np.diff(ends[:, :2], axis=0).T)
        sagitta = radius - np.sqrt(np.maximum(radius**2 - (chord / 2) ** 2, 0))
        # floor() makes chords a hair longer than the tolerance's: at most one chord's worth
        assert sagitta.max() <= tolerance * ((count + 1) / count) ** 2 + 1e-9
        # the helix climbs in equal steps along the linear axis
        assert np.allclose(np.diff(ends[:, 2])[:-1], 3.0 / count)
        # turning one way only
        cross = ends[:-1, 0] * ends[1:, 1] - ends[:-1, 1] * ends[1:, 0]
        assert (cross < 0).all() if clockwise else (cross > 0).all()


def test_g2_goes_clockwise_and_g3_counterclockwise_through_the_right_half():
    cw = drawn("G2 X20 Y0 I10 J0 F1000")[0]
    ccw = drawn("G3 X20 Y0 I10 J0 F1000")[0]
    assert cw[:, 1].max() == pytest.approx(10, abs=0.01) and cw[:, 1].min() >= -1e-9  # over the top
    assert ccw[:, 1].min() == pytest.approx(-10, abs=0.01) and ccw[:, 1].max() <= 1e-9  # under


@pytest.mark.parametrize("r, sweep", [(10, 60), (-10, 300)])
def test_radius_arcs_take_the_short_way_and_negative_r_the_long_way(r, sweep):
    (stroke,) = drawn(f"G2 X10 Y0 R{r} F1000")
    # The centre is 10 from both ends: (5, ∓8.66); the sweep seen from it is 60° or 300°.
    center = np.array([5.0, -8.660254 if r > 0 else 8.660254])
    angles = np.unwrap(np.arctan2(*(stroke - center)[:, ::-1].T))
    assert np.allclose(np.hypot(*(stroke - center).T), 10, atol=1e-6)
    assert abs(np.degrees(angles[-1] - angles[0])) == pytest.approx(sweep, abs=1e-6)


@pytest.mark.parametrize(
    "plane, line, axes, center, linear",
    [
        ("G17", "G2 X20 Z5 I10", (0, 1), (10, 0, 0), 2),  # XY, helix along Z
        ("G18", "G2 X20 Y5 I10", (2, 0), (10, 0, 0), 1),  # ZX, helix along Y
        ("G19", "G2 Y20 X5 J10", (1, 2), (0, 10, 0), 0),
    ],  # YZ, helix along X
)
def test_each_plane_arcs_in_its_axes_and_climbs_along_the_third(plane, line, axes, center, linear):
    m = Machine(description())
    done = []
    m.motion.complete = done.extend  # observe the executed blocks in 3-D
    run(m, plane, line + " F1000")
    ends = np.array([b.end for b in done])
    a0, a1 = axes
    r = np.hypot(ends[:, a0] - center[a0], ends[:, a1] - center[a1])
    assert np.allclose(r, 10, atol=1e-6)
    assert ends[-1, linear] == pytest.approx(5) and np.all(np.diff(ends[:, linear]) > 0)


def test_arc_time_is_its_length_at_the_feed():
    m = run(Machine(description(acceleration=1e6)), "G2 X0 Y0 I50 F3000")  # full circle, r = 50
    assert m.clock == pytest.approx(
        2 * math.pi * 50 / 50.0 + IDLE_LOCK, rel=2e-3
    )  # chords are a hair shorter


def test_inverse_time_lines_take_one_over_f_minutes():
    m = run(Machine(description(acceleration=1e6)), "G93 G1 X100 F2")  # 100 mm in half a minute
    assert m.clock == pytest.approx(30.0, rel=1e-3)


def test_inverse_time_arcs_run_at_f_times_the_chord_count_as_grbl_s_mc_arc_does():
    # GRBL 1.1h multiplies F by the segment count and then plans each chord at that many mm/min:
    # a half circle of r = 10 (78 chords at $12 = 0.002) at F1 runs at 78 mm/min, not π·10 mm/min.
    m = run(Machine(description(acceleration=1e6)), "G93 G2 X20 I10 F1")
    _, count = arc_chords((0, 0, 0), (20, 0, 0), (10, 0, 0), 10.0, (0, 1, 2), True, 0.002)
    assert count == 78
    assert m.clock == pytest.approx(math.pi * 10 / (count / 60.0), rel=2e-3)


def test_an_arc_is_one_stroke_with_the_pen_down_and_travel_with_it_up():
    m = run(Machine(description()), "G2 X20 I10 F1000", "M3 S90", "G2 X0 I-10", "M5")
    assert len(m.strokes) == 1 and len(m.strokes[0]) > 50
    assert len(m.travel) > 50  # the first arc, chord by chord, pen up


def test_arc_chords_queue_as_the_planner_frees_room_in_real_time():
    from sim.gcode.firmware import Firmware

    fw = Firmware(Machine(description(), instant=False))
    fw.take_output()
    fw.receive(b"G2 X0 Y0 I20 F6000\n")  # a full circle: 250 chords, the planner holds 15
    assert fw.take_output() == b""  # GRBL answers once the last chord is planned
    seconds = 0.0
    while not fw.take_output():
        fw.poll(0.05)
        seconds += 0.05
        assert seconds < 30
    assert seconds > 0.5  # most of the circle had run before the last chord fitted
