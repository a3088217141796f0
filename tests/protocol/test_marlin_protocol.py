"""Marlin replies and N…*checksum framing."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_protocol import ProtocolError
from firmware_protocol.marlin import (
    Busy,
    Echo,
    Error,
    Ok,
    Resend,
    Start,
    Unknown,
    checksum,
    frame_line,
    parse_line,
    reset_line_numbers,
    unframe_line,
)


@pytest.mark.parametrize(
    "line, message",
    [
        ("ok", Ok()),
        ("ok N12 P15 B3", Ok(12, 15, 3)),
        ("ok T:20.0 /0.0", Ok()),
        ("Resend: 7", Resend(7)),
        ("rs N7", Resend(7)),
        ("echo:busy: processing", Busy("processing")),
        ("busy: paused for user", Busy("paused for user")),
        ('echo:Unknown command: "M999"', Echo('Unknown command: "M999"')),
        (
            "Error:Line Number is not Last Line Number+1, Last Line: 5",
            Error("Line Number is not Last Line Number+1, Last Line: 5"),
        ),
        ("Error:checksum mismatch, Last Line: 5", Error("checksum mismatch, Last Line: 5")),
        ("start", Start()),
        ("okay", Unknown("okay")),
        ("T:20.0 /0.0 B:20.0 /0.0", Unknown("T:20.0 /0.0 B:20.0 /0.0")),
    ],
)
def test_parse(line, message):
    assert parse_line(line + "\n") == message


def test_checksum_is_xor_of_bytes():
    # hand-computed: 'N' ^ '1' ^ ' ' ^ 'G' ^ '2' ^ '8' = 0x4e^0x31^0x20^0x47^0x32^0x38
    assert checksum("N1 G28") == 0x4E ^ 0x31 ^ 0x20 ^ 0x47 ^ 0x32 ^ 0x38
    assert frame_line(1, "G28") == f"N1 G28*{checksum('N1 G28')}\n".encode()


def test_reset_line_numbers():
    assert reset_line_numbers(0) == frame_line(0, "M110 N0")


@pytest.mark.parametrize("command", ["G1 X1*2", "G1\nX1", "G1 X°", "G1 X" + "1" * 100])
def test_frame_rejects(command):
    with pytest.raises(ProtocolError):
        frame_line(3, command)


@settings(max_examples=200)
@given(
    st.integers(0, 10**7),
    st.text(st.characters(min_codepoint=33, max_codepoint=126, blacklist_characters="*"), max_size=60),
)
def test_frame_round_trip_and_corruption_detected(number, command):
    framed = frame_line(number, command).decode()
    assert unframe_line(framed) == (number, command)
    corrupt = framed.replace(f"N{number}", f"N{number + 1}", 1)
    assert unframe_line(corrupt) is None


@settings(max_examples=200)
@given(st.one_of(st.text(max_size=80), st.binary(max_size=80)))
def test_parse_never_raises(data):
    parse_line(data)
