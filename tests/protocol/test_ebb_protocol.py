"""The EBB grammar: commands as the board parses them, replies in both syntaxes, LM timing."""

import math

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from firmware_protocol import ProtocolError, ebb

INT32 = st.integers(-(1 << 31), (1 << 31) - 1)


@given(st.integers(1, (1 << 32) - 1), INT32, INT32)
def test_sm_round_trip(duration, a, b):
    data = ebb.encode("SM", duration, a, b)
    assert data.endswith(b"\r") and b" " not in data
    assert ebb.parse_command(data[:-1].decode().lower()) == ebb.Command("SM", (duration, a, b))


@given(st.lists(INT32, min_size=6, max_size=6), st.integers(0, 3))
def test_lm_round_trip(words, clear):
    text = ebb.encode("LM", *words, clear)[:-1].decode()
    assert ebb.parse_command(text).args == (*words, clear)


@pytest.mark.parametrize(
    "text, code",
    [
        ("SM,100", 4),  # a required parameter missing (the reference's own example)
        ("SM,1,1,1,0,0", 7),  # one too many
        ("SM,100A,1", 6),  # not a number
        ("SM,0,5", 6),  # zero duration is refused
        ("EM,6", 6),  # out of range
        ("HM,1000,5", 4),  # Position1 without Position2
        ("BB", 8),
    ],
)
def test_refusals_carry_the_boards_codes(text, code):
    with pytest.raises(ebb.CommandError) as err:
        ebb.parse_command(text)
    assert err.value.code == code and str(err.value).startswith(f"!{code} Err: ")


def test_unknown_command_text_is_the_firmwares():
    with pytest.raises(ebb.CommandError) as err:
        ebb.parse_command("BB")
    assert str(err.value) == "!8 Err: Unknown command 'BB:4242'"
    assert ebb.format_error(err.value, future=True) == b"BB,!8 Err: Unknown command 'BB:4242'\n"


def test_encode_refuses_what_the_board_would():
    with pytest.raises(ProtocolError):
        ebb.encode("SM", 10, 1 << 31)  # beyond a signed 32-bit step count
    with pytest.raises(ProtocolError):
        ebb.encode("LM", *([1] * 40))


@pytest.mark.parametrize(
    "name, data, legacy, future",
    [
        ("SM", None, b"OK\r\n", b"SM\n"),
        ("QS", "1421,-429", b"1421,-429\n\rOK\r\n", b"QS,1421,-429\n"),  # the reference's examples
        ("QG", "3E", b"3E\r\n", b"QG,3E\n"),
        ("ES", "1", b"1\n\rOK\r\n", b"ES,1\n"),
        ("QP", "1", b"1\n\rOK\r\n", b"QP,1\n"),
        ("QU", "32", b"QU,32\r\nOK\r\n", b"QU,32\n"),
        ("V", ebb.VERSION_TEXT, f"{ebb.VERSION_TEXT}\r\n".encode(), f"V,{ebb.VERSION_TEXT}\n".encode()),
    ],
)
def test_reply_shapes_in_both_syntaxes(name, data, legacy, future):
    assert ebb.format_reply(name, data, future=False) == legacy
    assert ebb.format_reply(name, data, future=True) == future
    for is_future, raw in ((False, legacy), (True, future)):
        lines = [ln.strip("\r") for ln in raw.decode().split("\n") if ln.strip("\r")]
        assert len(lines) == ebb.reply_lines(name, future=is_future)
        assert ebb.read_reply(name, lines, future=is_future).data == data


def test_syntax_switch_replies_are_the_odd_ones_the_reference_documents():
    assert ebb.syntax_switch_reply(True, future=False) == b"\n"
    assert ebb.syntax_switch_reply(False, future=True) == b"CUOK\r\n"


def test_version_text_is_the_firmwares():
    assert ebb.VERSION_TEXT == "EBBv13_and_above EB Firmware Version 3.0.3"


def _brute_ticks(steps, rate, accel):
    """The firmware's loop: Rate starts at Rate - Accel/2, then each tick adds Accel to Rate
    and Rate to the accumulator; a step each time it passes 2^31."""
    r, acc, done, t = rate - accel / 2, 0.0, 0, 0
    while done < steps:
        t += 1
        r += accel
        acc += r
        while acc >= ebb.ACCUMULATOR and done < steps:
            acc -= ebb.ACCUMULATOR
            done += 1
        if t > 10**6:
            return -1
    return t


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 300), st.floats(50, 20000), st.floats(-0.9, 3.0))
@example(241, 20000.0, -0.5)  # slows to a stop exactly on the last step in floats, short of it in ticks
def test_lm_ticks_match_the_firmwares_loop(steps, hz, change):
    rate = ebb.lm_rate(hz)
    ticks_guess = steps / hz / ebb.TICK
    accel = int(rate * change / max(ticks_guess, 1))
    want = _brute_ticks(steps, rate, accel)
    got = ebb.lm_ticks(steps, rate, accel)
    if want < 0:
        assert got < 0 or got > 10**6
    else:
        assert abs(got - want) <= 1  # the float loop and the exact sum may differ on the boundary tick
        assert ebb.lm_steps_at(got, steps, rate, accel) == steps


def test_rate_constant_is_the_references():
    assert math.isclose(ebb.RATE_PER_HZ, 85899.35, rel_tol=1e-7)
    assert ebb.lm_rate(45) == 3865471  # the reference's LM example 1


def test_servo_travel_uses_24_ms_updates():
    assert math.isclose(ebb.servo_travel_seconds(10000, 15000, 100), 1.2)  # the reference's FAQ


def test_noise_is_not_taken_for_an_answer():
    assert ebb.plausible("SM", "OK", future=False) and not ebb.plausible("SM", "\xfe\x13#~garb", future=False)
    assert ebb.plausible("QS", "12,-3", future=False) and not ebb.plausible("QS", "garbage", future=False)
    assert ebb.plausible("QS", "QS,12,-3", future=True) and not ebb.plausible("QS", "12,-3", future=True)
    assert ebb.plausible("SM", "!4 Err: Missing parameter(s)", future=False)
