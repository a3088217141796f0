"""The virtual GRBL's serial behaviour: byte sequences in → the exact bytes GRBL 1.1 prints."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from machines import description

from firmware_protocol import grbl
from pencilbot.machine.pen import PenModel
from sim.faults import GARBAGE, Faults
from sim.gcode.firmware import Firmware
from sim.gcode.lines import filter_line
from sim.gcode.machine import Machine

BANNER = "\r\nGrbl 1.1h ['$' for help]\r\n"
IDLE0 = "<Idle|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"


def board(*, instant=True, faults="", **config):
    fw = Firmware(Machine(description(**config), instant=instant), Faults.parse(faults))
    assert fw.take_output().decode() == BANNER
    return fw


def exchange(fw, data: bytes) -> str:
    fw.receive(data)
    return fw.take_output().decode("latin-1")


@pytest.mark.parametrize("homing", [False, True])
def test_settings_listing_is_grbl_formatted(homing):
    fw = Firmware(
        Machine(
            description(
                width=220, height=310, max_rate=6000, acceleration=800, homing=homing, soft_limits=homing
            )
        )
    )
    fw.take_output()
    lines = exchange(fw, b"$$\n").split("\r\n")
    assert lines[0] == "$0=10" and lines[-2] == "ok"
    assert "$11=0.010" in lines and f"$20={int(homing)}" in lines and f"$22={int(homing)}" in lines
    assert "$23=3" in lines  # both axes grow into the bed from the origin corner: home towards negative
    assert "$110=6000.000" in lines and "$120=800.000" in lines
    assert "$130=220.000" in lines and "$131=310.000" in lines
    assert all(isinstance(grbl.parse_line(ln), grbl.Setting) for ln in lines[:-2])


def test_status_report_cadence_wco_then_overrides():
    fw = board()
    reports = [grbl.parse_line(exchange(fw, b"?")) for _ in range(12)]
    assert [r.wco is not None for r in reports] == [True] + [False] * 9 + [True, False]
    assert [r.overrides is not None for r in reports] == [False, True] + [False] * 9 + [True]


def test_realtime_bytes_inside_a_line_act_immediately():
    fw = board()
    assert exchange(fw, b"G0 X?1\n") == IDLE0 + "ok\r\n"
    assert fw.log[-1].text == "G0 X1"


def test_ok_waits_for_room_in_the_planner_in_realtime_mode():
    fw = board(instant=False)
    moves = b"".join(b"G1 X%d F6000\n" % (i % 2 * 50) for i in range(1, 20))
    text = exchange(fw, moves)
    assert text.count("ok") == 15  # planner holds 15 blocks; line 16 waits for room
    fw.poll(2.0)
    assert fw.take_output().decode().count("ok") >= 1


def test_receive_ring_overflows_like_grbl_when_the_sender_does_not_count():
    fw = board(instant=False)
    block = b"G1 X50 F600\nG1 X0 F600\n" * 8  # 16 moves fill the planner
    exchange(fw, block)
    flood = b"G1 X10 Y10 F600\n" * 20  # 320 bytes while the board is not reading
    fw.receive(flood)
    # serial.c: a ring of RX_BUFFER_SIZE + 1 slots with one kept free holds 128 bytes
    assert fw.lost_bytes == len(flood) - grbl.RX_BUFFER_SIZE
    assert len(fw._ring) == grbl.RX_BUFFER_SIZE  # noqa: SLF001 -- the bytes waiting


def test_dwell_and_pen_changes_wait_for_motion_in_realtime_mode():
    fw = board(instant=False)
    assert exchange(fw, b"G1 X50 F3000\nM3 S90\n") == "ok\r\n"  # M3 waits for the move
    fw.poll(0.5)
    assert fw.take_output() == b""
    fw.poll(1.0)
    assert fw.take_output() == b"ok\r\n"
    assert exchange(fw, b"G4 P2\n") == ""  # dwell: ok after 2 s of machine time
    fw.poll(1.5)
    assert fw.take_output() == b""
    fw.poll(0.6)
    assert fw.take_output() == b"ok\r\n"


def test_feed_hold_from_idle_holds_what_comes_next_until_resume():
    # protocol.c: a hold suspends the main loop, so the next line is not even read (no ok)
    # until cycle start; it waits in the receive buffer.
    fw = board()
    assert exchange(fw, b"!?") == "<Hold:0|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"
    assert exchange(fw, b"G0 X10\n") == ""
    assert exchange(fw, b"?").startswith("<Hold:0|MPos:0.000,0.000,0.000|")
    assert exchange(fw, b"~") == "ok\r\n"
    assert exchange(fw, b"?").startswith("<Idle|MPos:10.000,0.000,0.000|")


def test_feed_hold_is_ignored_in_alarm_and_check_mode():
    fw = board()
    exchange(fw, b"$C\n")
    assert exchange(fw, b"!?").startswith("<Check|")
    fw = board()
    exchange(fw, b"G0 X1\n\x18")  # reset in motion: ALARM:3, locked
    assert exchange(fw, b"!?").startswith("<Alarm|")


def test_hold_stops_the_machine_clock_until_resume():
    fw = board(instant=False)
    exchange(fw, b"G1 X50 F3000\n!")
    fw.poll(5.0)
    assert fw.machine.machine_position()[0] == 0.0  # it had not started: nothing to slow
    exchange(fw, b"~")
    fw.poll(5.0)
    assert fw.machine.machine_position()[0] == pytest.approx(50.0)


@pytest.mark.parametrize(
    "faults, lines, replies",
    [
        ("error@2", ["G0 X1", "G0 X2", "G0 X3"], ["ok", "error:20", "ok"]),
        ("error@2:22", ["G0 X1", "G0 X2"], ["ok", "error:22"]),
        ("alarm@2", ["G0 X1", "G0 X2", "G0 X3"], ["ok", "ALARM:1\r\n[MSG:Reset to continue]"]),
        ("silent@2", ["G0 X1", "G0 X2", "?"], ["ok"]),
        ("reset@2", ["G0 X1", "G0 X2"], ["ok", BANNER.strip("\r\n")]),
        ("garbage@1", ["G0 X1"], [GARBAGE.decode("latin-1").strip() + "\r\nok"]),
    ],
)
def test_fault_injection(faults, lines, replies):
    fw = board(faults=faults)
    out = fw.take_output()
    out = exchange(fw, "".join(f"{ln}\n" if ln != "?" else ln for ln in lines).encode("latin-1"))
    assert out.strip("\r\n").replace("\r\n\r\n", "\r\n") == "\r\n".join(replies)


def test_drop_fault_marks_the_link():
    fw = board(faults="drop@3")
    exchange(fw, b"G0 X1\nG0 X2\nG0 X3\n")
    assert fw.link_dropped
    assert [e.reply for e in fw.log] == ["ok", "ok", "-"]


def test_log_indexes_every_complete_line():
    fw = board()
    exchange(fw, b"G0 X1\nBAD\nG0 X2\n")
    assert [(e.index, e.text, e.reply) for e in fw.log] == [
        (1, "G0 X1", "ok"),
        (2, "BAD", "error:2"),
        (3, "G0 X2", "ok"),
    ]
    assert fw.accepted_lines() == ["G0 X1", "G0 X2"]


@pytest.mark.parametrize(
    "raw, line",
    [
        (b"g1 x1 (c) y2", "G1X1Y2"),
        (b"G1;X1", "G1"),
        (b"(open", ""),
        (b"/G1\tX1", "G1X1"),
        (b"X" * 79, "X" * 79),
        (b"X" * 80, None),
    ],
)
def test_filter_line(raw, line):
    assert filter_line(raw) == line


gcode_like = st.lists(
    st.one_of(
        st.sampled_from(
            [
                "G0",
                "G1",
                "G4",
                "G20",
                "G21",
                "G28",
                "G90",
                "G91",
                "G92",
                "M3",
                "M5",
                "M280",
                "F1000",
                "S90",
                "S30",
                "P0.1",
                "X",
                "Y",
                "Z",
                "(c)",
                ";",
                " ",
                "$",
                "$X",
                "$C",
                "G2",
                "N5",
                "T1",
                ".",
            ]
        ),
        st.builds(
            lambda a, v: f"{a}{v}",
            st.sampled_from("XYZFSPNGM"),
            st.floats(-400, 400, allow_nan=False).map(lambda v: f"{v:.3f}"),
        ),
    ),
    max_size=8,
).map(" ".join)


@settings(max_examples=150, deadline=None)
@given(st.lists(gcode_like, max_size=25))
def test_each_gcode_like_line_gets_exactly_one_reply(lines):
    fw = board()
    assert exchange(fw, b"$20=0\n") == "ok\r\n"  # no soft limits: no alarm may stand in for a reply
    for line in lines:
        # "~" after each line: an M0 pause (a feed hold) would otherwise rightly hold back the
        # reply to the next line that needs the planner to drain.
        out = exchange(fw, line.encode() + b"\n~")
        replies = [ln for ln in out.split("\r\n") if ln in ("ok",) or ln.startswith("error:")]
        assert len(replies) == 1, (line, out)


@settings(max_examples=150, deadline=None)
@given(st.binary(max_size=300), st.booleans())
def test_arbitrary_bytes_never_crash_and_every_line_is_answered_or_alarmed(data, instant):
    fw = board(instant=instant)
    fw.receive(data)
    fw.poll(1000.0)
    out = fw.take_output().decode("ascii")
    replies = [ln for ln in out.split("\r\n") if ln == "ok" or ln.startswith("error:")]
    # every logged line was answered exactly once, unless an alarm or a reset swallowed it
    answered = [e for e in fw.log if e.reply == "ok" or e.reply.startswith("error:")]
    assert len(replies) == len(answered)
    assert all(
        isinstance(
            grbl.parse_line(ln),
            (grbl.Ok, grbl.Error, grbl.Alarm, grbl.Status, grbl.Feedback, grbl.Welcome, grbl.Setting),
        )
        for ln in out.split("\r\n")
        if ln
    )


def test_m280_is_refused_as_real_grbl_does_unless_the_servo_extension_is_on():
    fw = board(pen=PenModel("servo", up=50, down=20))
    assert exchange(fw, b"M280 P0 S20\n") == "error:23\r\n"


def test_pen_model_servo_m280():
    fw = Firmware(Machine(description(pen=PenModel("servo", up=50, down=20)), servo=True))
    fw.take_output()
    exchange(fw, b"G0 X10 Y10\nM280 P0 S20\nG1 X20 F1000\nM280 P0 S50\nG0 X0 Y0\n")
    fw.finish()
    strokes = fw.machine.strokes
    assert len(strokes) == 1 and strokes[0].tolist() == [[10, 10], [20, 10]]


def test_m0_pauses_and_answers_after_cycle_start():
    # gcode.c: M0 finishes the queued motion, then enters a feed hold inside the line; its ok
    # (and everything after it) comes after ~.
    fw = board()
    assert exchange(fw, b"G0 X10\nM0\nG0 X20\n?") == (
        "ok\r\n<Hold:0|MPos:10.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"
    )
    assert exchange(fw, b"~?") == "ok\r\nok\r\n<Idle|MPos:20.000,0.000,0.000|FS:0,0|Ov:100,100,100>\r\n"


def test_reboot_revives_a_hung_board():
    fw = board(faults="silent@1")
    assert exchange(fw, b"G0 X1\n?") == ""
    fw.power_cycle()
    assert exchange(fw, b"G0 X1\n") == BANNER + "ok\r\n"


@pytest.mark.parametrize("fault", ["drop@1", "reset@1", "silent@1"])
def test_bytes_in_flight_behind_a_fault_are_lost(fault):
    fw = board(faults=fault)
    fw.receive(b"G0X1\nG0X2\n")
    assert fw.accepted_lines() == []
    assert len(fw.log) == 1


def test_stop_reports_where_the_tool_stopped_not_where_queued_moves_end():
    fw = board()
    exchange(fw, b"G1X10F1000\nG1X20\n\x18")
    assert fw.machine.machine_position() == (0.0, 0.0, 0.0)
    exchange(fw, b"$X\n?")
    assert grbl.parse_line(exchange(fw, b"?").strip()).mpos == (0.0, 0.0, 0.0)


def test_status_polls_mid_stroke_do_not_split_the_stroke():
    fw = board()
    for line in [b"M3S90", b"G1X10F1000", b"G1Y10", b"G1X0", b"G1Y0", b"M3S30"]:
        exchange(fw, line + b"\n?")  # instant mode: each ? runs the queued motion
    assert [s.tolist() for s in fw.machine.strokes] == [[[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]]]


def test_jog_runs_as_jog_and_cancel_stops_it_where_it_is():
    fw = board(instant=False)
    assert exchange(fw, b"$J=G91 X50 F600\n") == "ok\r\n"
    assert exchange(fw, b"G1 X1 F100\n") == "error:9\r\n"
    fw.poll(1.0)
    assert grbl.parse_line(exchange(fw, b"?").strip()).state == "Jog"
    exchange(fw, grbl.JOG_CANCEL)
    x = fw.machine.machine_position()[0]
    assert 0 < x < 50
    fw.poll(10.0)
    assert grbl.parse_line(exchange(fw, b"?").strip()).state == "Idle"
    assert fw.machine.machine_position()[0] == x
    assert exchange(fw, b"G1 X0 F600\n$J=X5 F100\n") == "ok\r\nerror:8\r\n"  # not while running G-code


# --- reset, power and homing: where the pen really is ------------------------------------------


def cruising(fw, line=b"M3 S90\nG1 X100 F3000\n", seconds=1.0):
    """A real-time board drawing a 100 mm line at 50 mm/s, ``seconds`` in (past its ramp)."""
    exchange(fw, line)
    fw.poll(0.5)  # the pen change waits for motion; nothing moves before it
    fw.poll(seconds)
    return fw


@pytest.mark.parametrize("loses", [False, True])
def test_reset_in_motion_alarms_and_a_real_board_loses_the_position(loses):
    fw = Firmware(Machine(description(), instant=False), abort_loses=loses)
    fw.take_output()
    cruising(fw)
    reported = fw.machine.machine_position()
    assert exchange(fw, b"\x18").startswith("ALARM:3\r\n")
    assert fw.machine.machine_position() == reported  # GRBL keeps its step count...
    coast = 50.0**2 / (2 * 800.0)  # ...but the carriage ran on for v²/2a at 50 mm/s, 800 mm/s²
    assert fw.machine.carriage_position()[0] - reported[0] == pytest.approx(coast if loses else 0.0)
    exchange(fw, b"$X\nM3 S90\nG1 X150 F3000\n")
    fw.poll(10.0)
    end = fw.machine.strokes[-1][-1]
    assert end[0] == pytest.approx(150 + (coast if loses else 0.0))  # drawn off by the slip


def test_reset_after_a_completed_hold_keeps_the_position_without_alarm():
    fw = Firmware(Machine(description(), instant=False), abort_loses=True)
    fw.take_output()
    cruising(fw)
    exchange(fw, b"!")
    fw.poll(0.5)  # it slows to a stand (Hold:0)
    held = fw.machine.machine_position()
    assert exchange(fw, b"\x18") == BANNER  # no ALARM:3: motion had stopped
    assert fw.machine.carriage_position() == held


def test_a_feed_hold_slows_the_machine_along_its_move_and_the_rest_starts_from_rest():
    # stepper.c: a hold decelerates the running block at its acceleration (Hold:1) to a stand
    # (Hold:0); the block keeps what is left of it, replanned from rest on cycle start.
    fw = Firmware(Machine(description(), instant=False))
    fw.take_output()
    cruising(fw)
    x0 = fw.machine.machine_position()[0]
    report = exchange(fw, b"?!?")
    assert report.startswith("<Run|") and "<Hold:1|" in report and "|FS:3000," in report
    assert exchange(fw, b"~") == ""  # cycle start while still slowing: dropped, as GRBL does
    fw.poll(0.01)
    assert exchange(fw, b"?").startswith("<Hold:1|")
    fw.poll(0.5)
    stood = fw.machine.machine_position()[0]
    assert exchange(fw, b"?").startswith("<Hold:0|")
    assert stood - x0 == pytest.approx(50.0**2 / (2 * 800.0))  # v²/2a: 50 mm/s, 800 mm/s²
    fw.poll(5.0)
    assert fw.machine.machine_position()[0] == stood  # held: the dropped ~ resumed nothing
    exchange(fw, b"~")
    t0 = fw.machine.clock
    fw.poll(0.05)
    assert fw.machine.current_speed() == pytest.approx(800.0 * 0.05)  # from rest, at 800 mm/s²
    fw.poll(5.0)
    assert fw.machine.machine_position()[0] == pytest.approx(100.0)
    left = 100.0 - stood
    ramp = 50.0 / 800.0  # to 50 mm/s and back down at the end, then GRBL's idle lock ($1)
    idle = fw.machine.profile.firmware.idle_lock
    assert fw.machine.clock - t0 == pytest.approx(2 * ramp + (left - 50.0 * ramp) / 50.0 + idle, rel=1e-6)
    strokes = fw.machine.strokes
    assert len(strokes) == 1 and strokes[0][0][0] == 0.0 and strokes[0][-1][0] == pytest.approx(100.0)


def test_a_feed_hold_slows_through_the_corners_of_the_blocks_ahead():
    # Short moves at speed: the stopping distance is longer than what is left of the running
    # block, so the machine slows on through the next ones, where it stands.
    fw = Firmware(Machine(description(), instant=False))
    fw.take_output()
    exchange(fw, b"M3 S90\n" + b"".join(b"G1 X%.1f F3000\n" % (i * 0.4) for i in range(1, 25)))
    fw.poll(0.1)
    speed, x0 = fw.machine.current_speed(), fw.machine.machine_position()[0]
    assert speed == pytest.approx(50.0)  # cruising through the collinear joints
    blocks = len(fw.machine.planner)
    exchange(fw, b"!")
    assert len(fw.machine.planner) == blocks  # slowing cuts blocks, it adds none
    fw.poll(1.0)
    stood = fw.machine.machine_position()[0]
    assert stood - x0 == pytest.approx(speed**2 / (2 * 800.0), rel=1e-6)
    assert int(stood / 0.4) > int(x0 / 0.4) + 2  # it stands some blocks ahead of the one it ran
    rest = fw.machine.planner.queue[0]  # what is left of the block it stands in, from rest
    assert (
        rest.start[0] == stood
        and rest.end[0] == pytest.approx(0.4 * (int(stood / 0.4) + 1))
        and rest.entry == 0
    )
    planned_to = fw.machine.planner.queue[-1].end[0]
    assert len(fw.machine.planner) == round(planned_to / 0.4) - int(stood / 0.4)  # a slot a block, as before


def test_a_reset_while_the_hold_is_still_slowing_is_a_reset_in_motion():
    fw = Firmware(Machine(description(), instant=False), abort_loses=True)
    fw.take_output()
    cruising(fw)
    exchange(fw, b"!")
    fw.poll(0.01)
    assert exchange(fw, b"\x18").startswith("ALARM:3\r\n")


@pytest.mark.parametrize("zero", [False, True])
def test_power_cycle_restarts_the_count_at_zero_where_the_carriage_stands(zero):
    fw = Firmware(Machine(description()), power_zero=zero)
    fw.take_output()
    exchange(fw, b"G0 X50 Y40\n?")
    fw.power_cycle()
    mpos = grbl.parse_line(exchange(fw, b"?").split("\r\n")[-2]).mpos
    assert mpos == ((0.0, 0.0, 0.0) if zero else (50.0, 40.0, 0.0))
    exchange(fw, b"G90 M3 S90\nG1 X10 F1000\nM5\n")
    fw.finish()
    start, end = fw.machine.strokes[-1][[0, -1]]
    # The board thinks it draws from 0 to 10; on the paper the line starts where the pen was.
    assert start.tolist() == [50.0, 40.0]
    assert end.tolist() == ([60.0, 40.0] if zero else [10.0, 40.0])


def test_a_power_cycle_forgets_an_alarm_only_on_a_real_board():
    for zero, state in [(True, "Idle"), (False, "Alarm")]:
        fw = Firmware(Machine(description()), power_zero=zero)
        exchange(fw, b"G0 X10\n\x18")  # ALARM:3
        fw.power_cycle()
        fw.take_output()
        assert grbl.parse_line(exchange(fw, b"?").strip()).state == state


@pytest.mark.parametrize(
    "origin, invert, mpos, corner",
    [
        ("bottom-left", False, (0.0, 0.0), (0.0, 0.0)),  # homes to negative: HOMING_FORCE_SET_ORIGIN space
        ("top-right", True, (-1.0, -1.0), (100.0, 50.0)),
    ],  # homes to positive: GRBL's negative space, -$27
)
def test_homing_finds_the_origin_corner_and_trusts_the_position_again(origin, invert, mpos, corner):
    config = description(
        width=100, height=50, origin=origin, invert_x=invert, invert_y=invert, homing=True, soft_limits=True
    )
    fw = Firmware(Machine(config), power_zero=True)
    assert fw.take_output().decode() == BANNER + "[MSG:'$H'|'$X' to unlock]\r\n"  # HOMING_INIT_LOCK
    assert exchange(fw, b"G0 X1\n") == "error:9\r\n"
    assert exchange(fw, b"$X\n$20=0\nG0 X-30 Y-20\n") == "[MSG:Caution: Unlocked]\r\nok\r\nok\r\nok\r\n"
    fw.power_cycle()  # lost: the count restarts where the carriage is
    exchange(fw, b"$H\n")
    status = grbl.parse_line(exchange(fw, b"?").strip())
    assert status.state == "Idle" and status.mpos[:2] == mpos
    bed = config.bed.to_view(np.array([fw.machine.carriage_position()]))[0]
    pulloff = 1.0 if invert else 0.0
    assert np.allclose(np.abs(bed - corner), pulloff)  # $27 off the corner's switches, or on the corner


def test_homing_with_the_pen_down_drags_a_line_to_the_corner():
    fw = Firmware(Machine(description(homing=True)), power_zero=True)
    exchange(fw, b"$X\nG0 X30 Y20\nM3 S90\n$H\n")
    assert [s.tolist() for s in fw.machine.strokes] == [[[30.0, 20.0], [0.0, 0.0]]]


def test_startup_lines_run_after_every_reset_and_after_homing():
    fw = Firmware(Machine(description(homing=True)))
    fw.take_output()
    assert exchange(fw, b"$X\n$N0=G91\n$N1=G20\n") == "[MSG:Caution: Unlocked]\r\nok\r\nok\r\nok\r\n"
    assert exchange(fw, b"$H\n") == ">G91:ok\r\n>G20:ok\r\nok\r\n"
    assert exchange(fw, b"\x18") == BANNER + ">G91:ok\r\n>G20:ok\r\n"
    assert "G20 G91" in exchange(fw, b"$G\n")


def test_hold_fault_is_the_machine_s_hold_button():
    fw = board(faults="hold@2")
    assert exchange(fw, b"G0 X1\nG0 X2\nG0 X3\n") == "ok\r\n"
    assert grbl.parse_line(exchange(fw, b"?").strip()).state == "Hold"
    assert exchange(fw, b"~") == "ok\r\nok\r\n"
    assert fw.accepted_lines() == ["G0 X1", "G0 X2", "G0 X3"]


def test_a_critical_alarm_answers_nothing_until_reset():
    fw = board(faults="alarm@1")
    assert exchange(fw, b"G0 X1\n?$X\n!~") == "ALARM:1\r\n[MSG:Reset to continue]\r\n"
    assert exchange(fw, b"\x18") == BANNER + "[MSG:'$H'|'$X' to unlock]\r\n"
    assert exchange(fw, b"$X\n") == "[MSG:Caution: Unlocked]\r\nok\r\n"  # the $X sent before was lost


def test_dollar_dollar_is_answered_while_jogging_but_not_while_running():
    fw = board(instant=False)
    exchange(fw, b"$J=X100 F600\n")
    fw.poll(0.5)
    assert exchange(fw, b"$$\n").endswith("$132=200.000\r\nok\r\n")
    exchange(fw, grbl.JOG_CANCEL + b"G1 X0 F600\n")
    fw.poll(0.5)
    assert exchange(fw, b"$$\n") == "error:8\r\n"


@given(
    st.lists(
        st.tuples(
            st.integers(1, 2**31),
            st.text(st.characters(max_codepoint=255), max_size=12),
            st.sampled_from(["ok", "error:20", "-", "error:1"]),
        ),
        max_size=30,
    )
)
def test_the_line_log_gives_back_every_line_as_it_was_logged(entries):
    from sim.gcode.line_log import LineLog, LoggedLine

    log = LineLog()
    for entry in entries:
        log.append(*entry)
    want = [LoggedLine(*entry) for entry in entries]
    assert len(log) == len(want) and list(log) == want
    if want:
        assert log[-1] == want[-1] and log[0] == want[0]
    assert log.texts_answered("ok") == [e.text for e in want if e.reply == "ok" and e.text]
    with pytest.raises(IndexError):
        log[len(want)]
