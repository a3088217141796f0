"""The G-code interpreter, the planner's timing and the pen models."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from machines import description

from pencilbot.machine.pen import PenModel
from sim.gcode.machine import Machine
from sim.gcode.motion_control import MachineAlarm
from sim.gcode.planner import block_duration, junction_speed
from sim.gcode.settings import DEFAULT_SETTINGS

#: GRBL's stepper idle lock ($1 = 25 ms): the board stands still that long whenever the motion
#: comes to rest with nothing queued.
IDLE_LOCK = DEFAULT_SETTINGS[1] / 1000


def run(machine, *lines):
    for line in lines:
        parsed = machine.parse(line.replace(" ", "").upper())
        assert not isinstance(parsed, int), (line, parsed)
        machine.apply(parsed)
    machine.finish()
    return machine


def test_single_move_time_is_the_trapezoid_then_the_idle_lock():
    m = run(Machine(description(acceleration=800)), "G1 X100 F3000")
    v, a = 50.0, 800.0
    assert m.clock == pytest.approx(2 * v / a + (100 - v * v / a) / v + IDLE_LOCK)


def test_a_pen_change_waits_for_the_idle_lock_and_a_reversal_does_not():
    # GRBL 1.1h's stepper interrupt, out of segments, calls st_go_idle, which waits $1 ms before
    # the cycle ends; a spindle change (spindle_sync) or dwell starts only after that. A
    # reversal stops the pen with the next move queued: the steppers never go idle there.
    assert description().firmware.idle_lock == IDLE_LOCK
    v, a = 50.0, 800.0
    out = 2 * v / a + (10 - v * v / a) / v  # 10 mm from rest to rest at 50 mm/s, 800 mm/s²
    assert run(Machine(description()), "G1 X10 F3000", "M3 S30").clock == pytest.approx(out + IDLE_LOCK)
    there_and_back = run(Machine(description()), "G1 X10 F3000", "G1 X0").clock
    assert there_and_back == pytest.approx(2 * out + IDLE_LOCK)


@pytest.mark.parametrize("setting, lock", [("$1=100", 0.1), ("$1=255", 0.0), ("$1=0", 0.0)])
def test_the_idle_lock_is_the_board_s_own_setting(setting, lock):
    # $1 ms; 255 keeps the motors on and st_go_idle waits nothing. $RST=$ brings back 25 ms.
    from sim.gcode.firmware import Firmware

    fw = Firmware(Machine(description()))
    fw.receive(setting.encode() + b"\nG1 X10 F3000\nM3 S30\n")
    v, a = 50.0, 800.0
    assert fw.machine.clock == pytest.approx(2 * v / a + (10 - v * v / a) / v + lock)
    fw.receive(b"$RST=$\n")
    assert fw.machine.planner.idle_lock == IDLE_LOCK


def test_triangle_profile_when_too_short_to_cruise():
    # 1 mm at 800 mm/s² never reaches 50 mm/s: t = 2·sqrt(L/a)
    assert block_duration(1.0, 800.0, 0.0, 0.0, 50.0) == pytest.approx(2 * math.sqrt(1 / 800))


def test_collinear_segments_do_not_stop_in_between():
    one = run(Machine(description()), "G1 X100 F3000").clock
    split = run(Machine(description()), *[f"G1 X{x} F3000" for x in range(10, 101, 10)]).clock
    assert split == pytest.approx(one)


def test_corners_cost_time_and_reversals_stop():
    straight = run(Machine(description()), "G1 X50 F3000", "G1 X100").clock
    corner = run(Machine(description()), "G1 X50 F3000", "G1 X50 Y50").clock
    reverse = run(Machine(description()), "G1 X50 F3000", "G1 X0").clock
    stopped = run(Machine(description()), "G1 X50 F3000", "G4 P0", "G1 X0").clock
    assert straight < corner < reverse
    # A reversal stops on the way with the next move queued; a dwell lets the steppers go idle.
    assert stopped == pytest.approx(reverse + IDLE_LOCK)


def test_junction_speed_formula():
    assert junction_speed((1, 0, 0), (1, 0, 0), 800, 0.01) == math.inf
    assert junction_speed((1, 0, 0), (-1, 0, 0), 800, 0.01) == 0.0
    # 90°: sin(θ/2) = √0.5 → v² = a·δ·s/(1−s)
    s = math.sqrt(0.5)
    assert junction_speed((1, 0, 0), (0, 1, 0), 800, 0.01) == pytest.approx(
        math.sqrt(800 * 0.01 * s / (1 - s))
    )


def test_rapids_run_at_the_max_rate_and_feeds_are_capped_by_it():
    m = run(Machine(description(max_rate=6000, acceleration=1e9)), "G0 X100")
    assert m.clock == pytest.approx(1.0 + IDLE_LOCK, rel=1e-3)
    m = run(Machine(description(max_rate=6000, acceleration=1e9)), "G1 X100 F60000")
    assert m.clock == pytest.approx(1.0 + IDLE_LOCK, rel=1e-3)


def test_dwell_adds_seconds():
    assert run(Machine(description()), "G4 P1.5").clock == pytest.approx(1.5)


def test_units_distance_modes_and_offsets():
    m = run(Machine(description()), "G20 G0 X1 Y2")
    assert m.position[:2] == pytest.approx((25.4, 50.8))
    m = run(Machine(description()), "G91 G0 X10", "X10", "Y5")
    assert m.position[:2] == pytest.approx((20, 5))
    m = run(Machine(description()), "G0 X10", "G92 X0", "G0 X5")
    assert m.position[0] == pytest.approx(15)
    assert m.work_position()[0] == pytest.approx(5)
    m = run(Machine(description()), "G0 X10 Y10", "G28")
    assert m.position == (0, 0, 0)
    # G28 Y20 goes via Y20 and then sends only the named axis home (GRBL's gc_execute_line).
    m = run(Machine(description()), "G0 X10", "G28 Y20")
    assert [b.tolist() for b in m.travel] == [[[0, 0], [10, 0]], [[10, 0], [10, 20]], [[10, 20], [10, 0]]]


SQUARE = ["G0 X10 Y10", "{down}", "G1 X30 F2000", "G1 Y30", "G1 X10", "G1 Y10", "{up}", "G0 X0 Y0"]


@pytest.mark.parametrize(
    "pen, down, up",
    [
        (PenModel("spindle", up=30, down=90), "M3 S90", "M3 S30"),
        (PenModel("spindle", up=30, down=90), "M3 S80", "M5"),
        (PenModel("z", up=4, down=0), "G0 Z0", "G0 Z4"),
        (PenModel("z", up=-1, down=-3), "G1 Z-2.5 F500", "G1 Z-1.4 F500"),
        (PenModel("servo", up=50, down=20), "M280 P0 S25", "M280 P0 S45"),
    ],
)
def test_pen_models_draw_only_pen_down_moves(pen, down, up):
    config = description(pen=pen)
    m = Machine(config, servo=pen.kind == "servo")  # M280 is an extension real GRBL refuses
    if pen.kind == "z":
        run(m, up)
    lines = [ln.format(down=down, up=up) for ln in SQUARE]
    run(m, *lines)
    assert len(m.strokes) == 1
    assert m.strokes[0].tolist() == [[10, 10], [30, 10], [30, 30], [10, 30], [10, 10]]


def test_spindle_pen_is_up_while_m5_even_at_down_s():
    m = run(Machine(description(pen=PenModel("spindle", 30, 90))), "S90", "G1 X10 F1000")
    assert m.strokes == []


def test_separate_pen_downs_are_separate_strokes():
    m = run(Machine(description()), "M3 S90", "G1 X10 F1000", "M3 S30", "M3 S90", "G1 X20")
    assert [s.tolist() for s in m.strokes] == [[[0, 0], [10, 0]], [[10, 0], [20, 0]]]


def test_soft_limits_follow_the_bed_and_axis_direction():
    m = Machine(description(width=100, height=50, homing=True, soft_limits=True))
    run(m, "G0 X100 Y50")
    with pytest.raises(MachineAlarm) as alarm:
        m.apply(m.parse("G0X100.01"))
    assert alarm.value.code == 2
    inverted = Machine(
        description(width=100, height=50, invert_x=True, invert_y=True, homing=True, soft_limits=True)
    )
    run(inverted, "G0 X-100 Y-50")
    with pytest.raises(MachineAlarm):
        inverted.apply(inverted.parse("G0X1"))


def test_soft_limits_are_off_in_grbl_s_factory_settings():
    m = Machine(description())
    assert (m.settings[20], m.settings[22]) == (0, 0)
    run(m, "G0 X500 Y-20")
    assert m.position[:2] == (500, -20)


def test_soft_limit_alarm_drops_queued_moves():
    m = Machine(description(homing=True, soft_limits=True))
    for line in ("M3S90", "G1X10F1000", "G1X20"):
        m.apply(m.parse(line))
    with pytest.raises(MachineAlarm):
        m.apply(m.parse("G1X-1"))
    m.finish()
    assert m.strokes == [] and not m.planner.busy


@pytest.mark.parametrize(
    "origin, invert_x, invert_y, machine_xy, bed_xy",
    [
        ("bottom-left", False, False, (10, 20), (10, 20)),
        ("top-left", False, False, (10, 20), (10, 80)),  # Y grows towards the front
        ("bottom-right", False, False, (10, 20), (90, 20)),
        ("top-right", True, True, (-10, -20), (90, 80)),
    ],
)
def test_machine_to_bed_mapping(origin, invert_x, invert_y, machine_xy, bed_xy):
    config = description(width=100, height=100, origin=origin, invert_x=invert_x, invert_y=invert_y)
    assert config.bed.to_view(np.array([machine_xy])).tolist() == [list(bed_xy)]


def test_the_machine_takes_bed_pen_and_motion_from_its_description():
    from pencilbot.machine.profile import load_profile

    m = Machine(load_profile("grbl-z-a3"))
    assert (m.settings[130], m.settings[131], m.settings[23]) == (310.0, 430.0, 0)  # X, Y grow out of the bed
    assert (m.pen.kind, m.pen.up, m.pen.down) == ("z", 4.0, 0.0)
    assert m.settings[110] == 5000.0 and m.settings[120] == 500.0 and m.settings[11] == 0.01


def test_check_mode_moves_nothing():
    m = Machine(description())
    m.check_mode = True
    run(m, "M3 S90", "G1 X10 F100", "G4 P5")
    assert m.strokes == [] and m.clock == 0.0


def test_realtime_advance_moves_part_way():
    m = Machine(description(), instant=False)
    m.apply(m.parse("G1X100F3000"))
    m.advance(1.0)
    x = m.machine_position()[0]
    assert 0 < x < 100
    m.advance(10.0)
    assert m.machine_position()[0] == pytest.approx(100) and not m.planner.busy


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(0, 200), st.floats(0, 200), st.sampled_from([300, 1500, 6000])),
        min_size=1,
        max_size=40,
    )
)
def test_planner_is_never_faster_than_allowed(moves):
    m = Machine(description(width=200, height=200))
    done = []
    m.motion.complete = done.extend  # observe the executed blocks
    for x, y, f in moves:
        m.apply(m.parse(f"G1X{x:.3f}Y{y:.3f}F{f}"))
    m.finish()
    prev = None
    total = 0.0
    for b in done:
        assert b.entry <= b.nominal + 1e-9 and b.exit <= b.nominal + 1e-9
        assert b.entry <= b.max_entry + 1e-9
        # reachable within the block at the block's acceleration
        assert abs(b.exit**2 - b.entry**2) <= 2 * b.accel * b.length + 1e-6
        if prev is not None:
            assert prev.exit == pytest.approx(b.entry)
        assert b.duration >= b.length / b.nominal - 1e-9
        total += b.duration
        prev = b
    assert not done or (done[0].entry == 0 and done[-1].exit == 0)
    assert m.clock == pytest.approx(total + (IDLE_LOCK if done else 0.0))  # one stop, at the end
