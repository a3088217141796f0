"""GRBL 1.1 message grammar: exact lines a board prints ↔ typed messages."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_protocol import ProtocolError, grbl
from firmware_protocol.grbl import (
    Alarm,
    Error,
    Feedback,
    Ok,
    Setting,
    Status,
    Unknown,
    Welcome,
    encode_line,
    format_message,
    parse_line,
    significant_length,
)

# (line as the board prints it, message)
GRAMMAR = [
    ("ok", Ok()),
    ("error:2", Error(2)),
    ("error:20", Error(20)),
    ("ALARM:2", Alarm(2)),
    ("Grbl 1.1h ['$' for help]", Welcome("1.1h")),
    ("[MSG:Caution: Unlocked]", Feedback("MSG", "Caution: Unlocked")),
    ("[MSG:'$H'|'$X' to unlock]", Feedback("MSG", "'$H'|'$X' to unlock")),
    ("[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]", Feedback("GC", "G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0")),
    ("[VER:1.1h.20190825:]", Feedback("VER", "1.1h.20190825:")),
    ("[OPT:V,15,128]", Feedback("OPT", "V,15,128")),
    ("[G54:0.000,0.000,0.000]", Feedback("G54", "0.000,0.000,0.000")),
    ("$0=10", Setting(0, 10.0)),
    ("$11=0.010", Setting(11, 0.01)),
    ("$130=210.000", Setting(130, 210.0)),
    ("<Idle|MPos:0.000,0.000,0.000|FS:0,0>", Status("Idle", mpos=(0.0, 0.0, 0.0), feed=0.0, spindle=0.0)),
    (
        "<Run|MPos:10.500,-2.000,0.000|Bf:15,128|FS:3000,1000|WCO:1.000,2.000,0.000>",
        Status(
            "Run", mpos=(10.5, -2.0, 0.0), buffer=(15, 128), feed=3000.0, spindle=1000.0, wco=(1.0, 2.0, 0.0)
        ),
    ),
    (
        "<Hold:0|WPos:1.000,2.000,3.000|Ln:12|F:500|Pn:XZ|Ov:100,100,100|A:S>",
        Status(
            "Hold",
            0,
            wpos=(1.0, 2.0, 3.0),
            line_number=12,
            feed=500.0,
            pins="XZ",
            overrides=(100, 100, 100),
            accessories="S",
        ),
    ),
    ("<Alarm|MPos:0.000,0.000,0.000|FS:0,0>", Status("Alarm", mpos=(0.0, 0.0, 0.0), feed=0.0, spindle=0.0)),
]


@pytest.mark.parametrize("line, message", GRAMMAR)
def test_parse_exact_lines(line, message):
    assert parse_line(line) == message
    assert parse_line(line + "\r\n") == message
    assert parse_line((line + "\r\n").encode()) == message


@pytest.mark.parametrize("line, message", GRAMMAR)
def test_format_prints_what_grbl_prints(line, message):
    assert format_message(message) == line


@pytest.mark.parametrize(
    "line",
    [
        "",
        "okay",
        "error:",
        "error:x",
        "ALARM:",
        "<>",
        "<Idle|MPos>",
        "<Idle|Bf:1>",
        "[no colon]",
        "Grbl 1.1h",
        "$x=1",
        "\xfe\x13garbage",
        "<Idle|MPos:1,a,3>",
    ],
)
def test_not_grbl_is_unknown(line):
    assert isinstance(parse_line(line), Unknown)


def test_unknown_status_fields_are_skipped():
    assert parse_line("<Idle|MPos:1.000,2.000,3.000|Foo:bar>") == Status("Idle", mpos=(1.0, 2.0, 3.0))


def test_error_and_alarm_tables_carry_grbl_texts():
    assert Error(2).text == "Bad number format"
    assert Error(11).text == "Line overflow"
    assert Error(20).text == "Unsupported command"
    assert Error(25).explanation == "Repeated g-code word found in block."
    assert Alarm(2).text == "Soft limit"
    assert Alarm(3).text == "Abort during cycle"
    assert set(grbl.ERRORS) == set(range(1, 18)) | set(range(20, 39))
    assert set(grbl.ALARMS) == set(range(1, 10))
    assert Error(99).text == "Unknown error"


def test_constants():
    assert grbl.RX_BUFFER_SIZE == 128
    assert grbl.LINE_BUFFER_SIZE == 80
    assert {0x3F, 0x21, 0x7E, 0x18} == grbl.REALTIME_BYTES
    assert grbl.BANNER == "Grbl 1.1h ['$' for help]"


@pytest.mark.parametrize(
    "line, length",
    [
        ("G1 X10 Y20", 8),
        ("g1x10", 5),
        ("G1 (pen down) X1", 4),
        ("G1 X1 ; comment", 4),
        ("(only)", 0),
        ("/G1", 2),
        ("G1\tX1", 4),
    ],
)
def test_significant_length_drops_what_grbl_drops(line, length):
    assert significant_length(line) == length


def test_encode_line_frames_with_single_newline():
    assert encode_line("  G1 X1 Y2  ") == b"G1 X1 Y2\n"
    assert encode_line("X" + "1" * 78) == b"X" + b"1" * 78 + b"\n"
    # spaces do not count towards GRBL's line buffer
    assert encode_line("G1 " + " ".join("X1" for _ in range(38))).endswith(b"\n")


@pytest.mark.parametrize("line", ["X" + "1" * 79, "G1 X1\nG1 X2", "G1 X1 (stop!)", "G1 X1 ~", "G1 X°"])
def test_encode_line_rejects_what_grbl_would_mangle(line):
    with pytest.raises(ProtocolError):
        encode_line(line)


@settings(max_examples=300)
@given(st.one_of(st.text(max_size=120), st.binary(max_size=120)))
def test_parse_never_raises(data):
    message = parse_line(data)
    assert isinstance(message, (Ok, Error, Alarm, Status, Feedback, Welcome, Setting, Unknown))


coords = st.tuples(*[st.integers(-99999, 99999).map(lambda v: v / 1000)] * 3)


@settings(max_examples=200)
@given(
    state=st.sampled_from(grbl.STATES),
    mpos=coords,
    wco=st.none() | coords,
    buffer=st.none() | st.tuples(st.integers(0, 15), st.integers(0, 128)),
    line_number=st.none() | st.integers(0, 9_999_999),
    feed=st.integers(0, 20000).map(float),
    spindle=st.none() | st.integers(0, 30000).map(float),
    overrides=st.none() | st.tuples(st.integers(10, 200), st.integers(25, 100), st.integers(10, 200)),
)
def test_status_round_trip(state, mpos, wco, buffer, line_number, feed, spindle, overrides):
    status = Status(
        state,
        mpos=mpos,
        wco=wco,
        buffer=buffer,
        line_number=line_number,
        feed=feed,
        spindle=spindle,
        overrides=overrides,
    )
    assert parse_line(format_message(status)) == status
