"""The virtual EBB answers and refuses as firmware 3.0.3 and 2.8.1 do (UBW.c, ebb.c, RCServo2.c
of evil-mad/EggBot): the queries real clients send before a plot, the refusals of bad motion,
the servo's pins and channels, timed moves, 2.8.1's own formats, and motors without power."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.machine.profile import load_profile
from sim.ebb.board import EbbBoard


def _board(profile="axidraw-v3", **options):
    moves = []
    board = EbbBoard(load_profile(profile), lambda a, b, drawing: moves.append((a, b, drawing)), **options)
    board.moves = moves
    return board


def ask(board, text):
    board.receive(text.encode() + b"\r")
    return board.take_output()


@pytest.mark.parametrize(
    "version, qc, ql, qn, qr",
    [
        ("3.0.3", b"394,297\r\nOK\r\n", b"7\r\nOK\r\n", b"13\r\nOK\r\n", b"0\n\rOK\r\n"),  # ebb_print_int
        (
            "2.8.1",
            b"0394,0297\r\nOK\r\n",
            b"007\r\nOK\r\n",
            b"0000000013\r\nOK\r\n",
            b"0\r\nOK\r\n",
        ),  # printf %04i...
    ],
)
def test_queries_in_each_firmwares_format(version, qc, ql, qn, qr):
    board = _board(version=version)
    assert ask(board, "QC") == qc  # 9.1 V at the jack: (9.1 - 0.3) / 9.2 of 3.3 V in 1023 counts
    assert ask(board, "SL,7") == b"OK\r\n" and ask(board, "QL") == ql
    assert ask(board, "SN,12") == ask(board, "NI") == b"OK\r\n" and ask(board, "QN") == qn
    assert ask(board, "QR") == qr


def test_future_syntax_and_the_always_named_replies():
    board = _board()
    assert ask(board, "PI,B,3") == b"PI,0\r\n"  # no OK after PI
    assert ask(board, "QU,7") == b"QU,!6 Err: Invalid parameter value\r\n"  # an unknown QU number
    assert ask(board, "ST,left one") == b"OK\r\n" and ask(board, "QT") == b"left one\r\nOK\r\n"
    ask(board, "CU,10,1")
    assert ask(board, "QC") == b"QC,394,297\n"
    assert ask(board, "QU,9") == b"QU,,!6 Err: Invalid parameter value\n"
    assert ask(board, "SM,10,300") == b"SM,!0 Err: <axis1> step rate too high\n\n"


@pytest.mark.parametrize(
    "command",
    [
        "LM,0,0,0,0,0,0",
        "LM,100,0,5,100,0,5",
        "LM,0,100,0,0,200,0",
        "LM,-100,-5,0,0,0,0",
        "T3,0,1,1,1,1,1,1",
        "QU,3,1",
        "PO,B,8,1",
        "PO,F,1,1",
    ],
)
def test_what_the_firmware_refuses_is_refused_and_not_run(command):
    board = _board()
    assert ask(board, command).endswith(b"Err: Invalid parameter value\r\n") or b"!7" in ask(board, command)
    board.finish()
    assert board.counters.tolist() == [0, 0] and board.log.count(command) == 0


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 5000), st.integers(-200_000, 200_000))
def test_sm_over_25_khz_is_refused_at_or_under_is_run(ms, steps):
    board = _board()
    reply = ask(board, f"SM,{ms},{steps},0")
    rate = int(abs(steps) * (85_899_345.92 / ms))
    if steps and rate > 1 << 31:
        assert reply == b"!0 Err: <axis1> step rate too high\n\r\r\n"
    elif steps and rate == 0:
        assert reply == b"!0 Err: <axis1> step rate too slow\n\r\r\n"
    else:
        assert reply == b"OK\r\n"
        board.finish()
        assert board.counters.tolist() == [steps, 0]


def test_firmware_2_8_1_stops_with_five_fields_and_has_no_qu_or_t3():
    board = _board(version="2.8.1", instant=False)
    ask(board, "SM,100,200,0")
    ask(board, "SM,100,0,300")  # waits in the one-deep FIFO
    board.poll(0.05)
    assert ask(board, "ES") == b"1,0,300,100,0\n\rOK\r\n"  # interrupted, FIFO 0/300, 100 of 200 left
    assert ask(board, "QU,2") == b"!8 Err: Unknown command 'QU:5155'\r\n"
    assert ask(board, "T3,10,1,1,1,1,1,1").startswith(b"!8 Err: Unknown command 'T3")
    assert ask(board, "SM,10,300") == b"!0 Err: <axis1> step rate > 25K steps/second.\n\r"


def test_t3_runs_its_intervals_and_td_twice_as_long():
    board = _board()
    rate = 85_899_346  # 1000 steps/s
    assert ask(board, f"T3,2500,{rate},0,0,{-rate},0,0") == b"OK\r\n"  # 0.1 s
    board.finish()
    assert board.counters.tolist() == [100, -100] and board.clock == pytest.approx(0.1, abs=1e-4)
    assert ask(board, f"TD,2500,{rate},{rate},0,0,0,0,0,0") == b"OK\r\n"
    board.finish()
    assert board.counters.tolist() == [300, -100]


def test_the_pen_moves_only_on_its_pin_and_channel():
    """A NextDraw 8511's narrow-band servo is on RB2: SP without a pin drives RB1, and with eight
    channels running its rate steps come every 24 ms, with one every 3 ms."""
    board = _board("nextdraw-8511")
    ask(board, "SC,5,8280")
    ask(board, "SP,0,50")  # RB1: the pen stays up
    ask(board, "SM,100,800,800")
    board.finish()
    assert (
        not any(drawing for *_, drawing in board.moves) and not board.pen_up
    )  # the firmware thinks it is down
    ask(board, "SC,4,9720")
    ask(board, "SC,12,154")
    ask(board, "SP,1,10,2")
    ask(board, "SP,0,30,2")
    board.finish()
    assert board.servos.t1 - board.servos.t0 == pytest.approx(10 * 0.024)  # 1440 units at 154 per 24 ms
    ask(board, "SC,8,1")
    ask(board, "SP,1,30,2")
    ask(board, "SP,0,30,2")
    board.finish()
    assert board.servos.t1 - board.servos.t0 == pytest.approx(10 * 0.003)  # the same at 3 ms
    ask(board, "SM,100,800,800")
    board.finish()
    assert board.moves[-1][2]  # drawn


def test_saxi_s2_moves_the_pen_on_rp4():
    board = _board()
    ask(board, "S2,15248,4,0,100")  # saxi's pen down: S2,height,4,rate,delay
    ask(board, "SM,100,800,800")
    ask(board, "S2,20641,4,0,100")
    ask(board, "SM,100,800,800")
    board.finish()
    assert [drawing for *_, drawing in board.moves] == [True, False]


def test_without_power_the_motors_do_not_turn_but_the_counters_count():
    board = _board(supply=0.0)
    assert ask(board, "QC") == b"394,0\r\nOK\r\n"
    ask(board, "SM,100,800,800")
    board.finish()
    assert (
        ask(board, "QS") == b"800,800\n\rOK\r\n" and board.moves == [] and board.carriage.tolist() == [0, 0]
    )
    assert board.true_steps().tolist() == [0, 0]


def test_pi_reads_the_drivers_enable_and_microstep_pins():
    board = _board()
    assert [ask(board, f"PI,{p}") for p in ("E,0", "C,1")] == [b"PI,1\r\n", b"PI,1\r\n"]  # off at boot
    ask(board, "EM,2,2")
    board.finish()
    pins = [ask(board, f"PI,{p}") for p in ("E,0", "C,1", "E,2", "E,1", "A,6")]
    assert pins == [b"PI,0\r\n", b"PI,0\r\n", b"PI,1\r\n", b"PI,1\r\n", b"PI,0\r\n"]  # on; 8x: MS1 MS2
