"""The virtual GRBL's serial behaviour: byte sequences in → the exact bytes GRBL 1.1 prints."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_protocol import grbl
from machines import description

from pencilbot.machine.pen import PenModel
from sim.firmware import GARBAGE, Faults, Firmware, filter_line
from sim.machine import Machine

BANNER = "\r\nGrbl 1.1h ['$' for help]\r\n"
IDLE0 = "<Idle|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"


def board(*, instant=True, faults="", **config):
    fw = Firmware(Machine(description(**config), instant=instant), Faults.parse(faults))
    assert fw.take_output().decode() == BANNER
    return fw


def exchange(fw, data: bytes) -> str:
    fw.receive(data)
    return fw.take_output().decode("latin-1")


# (bytes sent to a fresh board, exact reply)
CONFORMANCE = [
    (b"G21\n", "ok\r\n"),
    (b"\n", "ok\r\n"),
    (b"(just a comment)\n", "ok\r\n"),
    (b"G1 X1 F100 ; trailing\n", "ok\r\n"),
    (b"g1 x1 f100\n", "ok\r\n"),
    (b"G1 X1 F100\r\n", "ok\r\nok\r\n"),  # GRBL ends a line at \r and at \n
    (b"G0 X1\nG0 Y1\n", "ok\r\nok\r\n"),
    (b"?", IDLE0),
    (b"G0 X1.2.3\n", "error:1\r\n"),
    (b"#1\n", "error:1\r\n"),
    (b"G0 X\n", "error:2\r\n"),
    (b"G0 X-\n", "error:2\r\n"),
    (b"$Q\n", "error:3\r\n"),
    (b"$1=abc\n", "error:2\r\n"),
    (b"$999=1\n", "error:3\r\n"),
    (b"$1=-5\n", "error:4\r\n"),
    (b"G4 P-1\n", "error:4\r\n"),
    (b"G1 X1 F-10\n", "error:4\r\n"),
    (b"$0=2\n", "error:6\r\n"),
    (b"G1 X" + b"1" * 80 + b"\n", "error:11\r\n"),
    (b"G1 X" + b"1" * 76 + b"\n", "error:22\r\n"),  # 79 significant characters still fit
    (b"G1 X" + b"1 " * 76 + b"\n", "error:22\r\n"),  # spaces do not count
    (b"G1 X" + b"1 " * 77 + b"\n", "error:11\r\n"),
    (b"G2 X1 Y1 I1\n", "error:20\r\n"),
    (b"G5\n", "error:20\r\n"),
    (b"M6\n", "error:20\r\n"),
    (b"G0 E5\n", "error:20\r\n"),
    (b"G0 G1 X1\n", "error:21\r\n"),
    (b"G20 G21\n", "error:21\r\n"),
    (b"M3 M5\n", "error:21\r\n"),
    (b"G1 X5\n", "error:22\r\n"),
    (b"G1 X5 F0\n", "error:22\r\n"),
    (b"G1.5 X1\n", "error:23\r\n"),
    (b"M3.5\n", "error:23\r\n"),
    (b"G0 G28 X1\n", "error:24\r\n"),
    (b"G0 X1 X2\n", "error:25\r\n"),
    (b"G1 F1 F2\n", "error:25\r\n"),
    (b"G92\n", "error:26\r\n"),
    (b"N99999999 G0 X1\n", "error:27\r\n"),
    (b"G4\n", "error:28\r\n"),
    (b"G80 X1\n", "error:31\r\n"),
    (b"G0 X1 P1\n", "error:36\r\n"),
    (b"G0 X1 R1\n", "error:36\r\n"),
    (b"T300\n", "error:38\r\n"),
    (b"G0 X500\n", "ALARM:2\r\n[MSG:Reset to continue]\r\n"),
    (b"G91 G0 X-1\n", "ALARM:2\r\n[MSG:Reset to continue]\r\n"),
    (b"$G\n", "[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]\r\nok\r\n"),
    (b"G91 G20 G1 F10 M3 S90\n$G\n", "ok\r\n[GC:G1 G54 G17 G20 G91 G94 M3 M9 T0 F254 S90]\r\nok\r\n"),
    (b"$I\n", "[VER:1.1h.20190825:]\r\n[OPT:V,15,128]\r\nok\r\n"),
    (b"$N\n", "$N0=\r\n$N1=\r\nok\r\n"),
    (b"$\n", "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]\r\nok\r\n"),
    (b"$X\n", "ok\r\n"),
    (b"$H\n", "ok\r\n"),
    (b"$C\n", "[MSG:Enabled]\r\nok\r\n"),
    (b"$C\nG0 X10\n$C\n", "[MSG:Enabled]\r\nok\r\nok\r\n[MSG:Disabled]\r\nok\r\n" + BANNER),
    (b"$C\n?", "[MSG:Enabled]\r\nok\r\n<Check|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"),
    (b"$10=3\n?", "ok\r\n<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000>\r\n"),
    (b"$10=0\nG92 X5\n?", "ok\r\nok\r\n<Idle|WPos:5.000,0.000,0.000|FS:0,0|WCO:-5.000,0.000,0.000>\r\n"),
    (b"$11=0.02\n", "ok\r\n"),
    (b"$22=0\n$20=1\n", "ok\r\nerror:10\r\n"),
    (b"$22=0\n$H\n", "ok\r\nerror:5\r\n"),
    (b"M2\n", "[MSG:Pgm End]\r\nok\r\n"),
    (b"G20 G91 M3 S90\nM30\n$G\n", "ok\r\n[MSG:Pgm End]\r\nok\r\n[GC:G1 G54 G17 G20 G90 G94 M5 M9 T0 F0 S90]\r\nok\r\n"),
    (b"\x18", BANNER),
    (b"G0 X10\n\x18", "ok\r\nALARM:3\r\n" + BANNER + "[MSG:'$H'|'$X' to unlock]\r\n"),
    (b"G0 X10\n\x18G0 X1\n$X\nG0 X1\n",
     "ok\r\nALARM:3\r\n" + BANNER + "[MSG:'$H'|'$X' to unlock]\r\nerror:9\r\n[MSG:Caution: Unlocked]\r\nok\r\nok\r\n"),
    (b"G0 X500\nG0 X1\n$X\n\x18$X\nG0 X1\n",
     "ALARM:2\r\n[MSG:Reset to continue]\r\n" + BANNER + "[MSG:'$H'|'$X' to unlock]\r\n"
     "[MSG:Caution: Unlocked]\r\nok\r\nok\r\n"),
    (b"G0 X10\n!?~?",
     "ok\r\n<Hold:0|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"
     "<Idle|MPos:10.000,0.000,0.000|FS:0,0|Ov:100,100,100>\r\n"),
    (b"!", ""),  # feed hold while idle does nothing
    (b"$J=G91 X10 F1000\n$J=X5 F500\n?",  # the G91 was the first jog's only
     "ok\r\nok\r\n<Idle|MPos:5.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"),
    (b"$J=G91 G20 X1 F10\n$G\n", "ok\r\n[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]\r\nok\r\n"),
    (b"$J=X10\n", "error:22\r\n"),
    (b"$J=G1 X10 F100\n", "error:16\r\n"),
    (b"$J=X10 F100 M3\n", "error:16\r\n"),
    (b"$J=X500 F100\n", "error:15\r\n"),
    (b"$JX10\n", "error:3\r\n"),
    (b"\xff\x85G0 X1\n", "ok\r\n"),  # extended-ASCII bytes never reach the line
]


@pytest.mark.parametrize("sent, reply", CONFORMANCE, ids=[repr(s)[:40] for s, _ in CONFORMANCE])
def test_conformance(sent, reply):
    assert exchange(board(), sent) == reply


def test_settings_listing_is_grbl_formatted():
    text = exchange(board(width=220, height=310, max_rate=6000, acceleration=800), b"$$\n")
    lines = text.split("\r\n")
    assert lines[0] == "$0=10" and lines[-2] == "ok"
    assert "$11=0.010" in lines and "$20=1" in lines and "$22=1" in lines
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
    assert fw.lost_bytes == len(flood) - (grbl.RX_BUFFER_SIZE - 1) - 0
    assert fw._ring  # noqa: SLF001 -- the ring holds 127 bytes waiting


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
    fw = board()
    assert exchange(fw, b"!?") == "<Hold:0|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"
    assert exchange(fw, b"G0 X10\n") == "ok\r\n"
    assert exchange(fw, b"?").startswith("<Hold:0|MPos:0.000,0.000,0.000|")
    exchange(fw, b"~")
    assert exchange(fw, b"?").startswith("<Idle|MPos:10.000,0.000,0.000|")


def test_feed_hold_is_ignored_in_alarm_and_check_mode():
    fw = board()
    exchange(fw, b"$C\n")
    assert exchange(fw, b"!?").startswith("<Check|")
    fw = board(faults="alarm@1")
    exchange(fw, b"G0 X1\n")
    assert exchange(fw, b"!?").startswith("<Alarm|")


def test_hold_stops_the_machine_clock_until_resume():
    fw = board(instant=False)
    exchange(fw, b"G1 X50 F3000\n!")
    fw.poll(5.0)
    assert fw.machine.machine_position()[0] == 0.0
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
        (1, "G0 X1", "ok"), (2, "BAD", "error:2"), (3, "G0 X2", "ok")]
    assert fw.accepted_lines() == ["G0 X1", "G0 X2"]


@pytest.mark.parametrize(
    "raw, line",
    [(b"g1 x1 (c) y2", "G1X1Y2"), (b"G1;X1", "G1"), (b"(open", ""), (b"/G1\tX1", "G1X1"),
     (b"X" * 79, "X" * 79), (b"X" * 80, None)],
)
def test_filter_line(raw, line):
    assert filter_line(raw) == line


gcode_like = st.lists(
    st.one_of(
        st.sampled_from(["G0", "G1", "G4", "G20", "G21", "G28", "G90", "G91", "G92", "M3", "M5", "M280",
                         "F1000", "S90", "S30", "P0.1", "X", "Y", "Z", "(c)", ";", " ", "$", "$X", "$C", "G2",
                         "N5", "T1", "."]),
        st.builds(lambda a, v: f"{a}{v}", st.sampled_from("XYZFSPNGM"),
                  st.floats(-400, 400, allow_nan=False).map(lambda v: f"{v:.3f}")),
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
    assert all(isinstance(grbl.parse_line(ln), (grbl.Ok, grbl.Error, grbl.Alarm, grbl.Status,
                                                 grbl.Feedback, grbl.Welcome, grbl.Setting))
               for ln in out.split("\r\n") if ln)


def test_pen_model_servo_m280():
    fw = board(pen=PenModel("servo", up=50, down=20))
    exchange(fw, b"G0 X10 Y10\nM280 P0 S20\nG1 X20 F1000\nM280 P0 S50\nG0 X0 Y0\n")
    fw.finish()
    strokes = fw.machine.strokes
    assert len(strokes) == 1 and strokes[0].tolist() == [[10, 10], [20, 10]]


def test_m0_pauses_after_its_ok_until_cycle_start():
    fw = board()
    assert exchange(fw, b"G0 X10\nM0\nG0 X20\n?") == (
        "ok\r\nok\r\nok\r\n<Hold:0|MPos:10.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n")
    assert exchange(fw, b"~?") == "<Idle|MPos:20.000,0.000,0.000|FS:0,0|Ov:100,100,100>\r\n"


def test_reboot_revives_a_hung_board():
    fw = board(faults="silent@1")
    assert exchange(fw, b"G0 X1\n?") == ""
    fw.reset(reboot=True)
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
