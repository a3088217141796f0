"""The virtual EBB against the EBB reference: FIFO blocking, replies, steps, servo, ES, power."""

import math

import pytest

from pencilbot.machine.profile import load_profile
from sim.ebb.board import EbbBoard
from sim.faults import Faults


@pytest.fixture
def board():
    return _board()


def _board(**options):
    moves = []
    board = EbbBoard(
        load_profile("axidraw-v3"), lambda a, b, drawing: moves.append((a, b, drawing)), **options
    )
    board.moves = moves
    return board


def ask(board, text):
    board.receive(text.encode() + b"\r")
    return board.take_output()


def test_a_motion_command_is_answered_only_when_the_fifo_has_room():
    board = _board(instant=False)
    assert ask(board, "SM,100,10,10") == b"OK\r\n"  # runs
    assert ask(board, "SM,100,10,10") == b"OK\r\n"  # waits in the one-deep FIFO
    assert ask(board, "SM,100,10,10") == b""  # parsed only once there is room
    assert ask(board, "QS") == b""  # and everything behind it waits too
    board.poll(0.099)
    assert board.take_output() == b""
    board.poll(0.002)
    assert board.take_output() == b"OK\r\n10,10\n\rOK\r\n"


def test_cu_4_deepens_the_fifo():
    board = _board(instant=False)
    assert ask(board, "QU,2") == b"QU,32\r\nOK\r\n"
    ask(board, "CU,4,3")
    assert ask(board, "QU,3") == b"QU,3\r\nOK\r\n"
    for _ in range(4):
        assert ask(board, "SM,50,5,0") == b"OK\r\n"
    assert ask(board, "SM,50,5,0") == b""


def test_replies_in_legacy_and_future_syntax(board):
    assert ask(board, "V") == b"EBBv13_and_above EB Firmware Version 3.0.3\r\n"
    assert ask(board, "QG") == b"10\r\n"  # pen up, idle
    assert ask(board, "CU,10,1") == b"\n"  # the odd switch reply
    assert ask(board, "V") == b"V,EBBv13_and_above EB Firmware Version 3.0.3\n"
    assert ask(board, "QS") == b"QS,0,0\n"
    assert ask(board, "SM,10,1,1") == b"SM\n"
    assert ask(board, "SM,100") == b"SM,!4 Err: Missing parameter(s)\n"
    assert ask(board, "CU,10,0") == b"CUOK\r\n"
    assert ask(board, "SM,100") == b"!4 Err: Missing parameter(s)\r\n"


def test_lm_lasts_what_the_reference_says(board):
    ask(board, "LM,42950000,50,13400,0,0,0")  # the reference: 500 -> 800 steps/s, 50 steps, 77 ms
    board.finish()
    assert math.isclose(board.clock, 0.077, abs_tol=0.0015)
    assert ask(board, "QS") == b"50,0\n\rOK\r\n"


def test_xm_mixes_the_axes(board):
    ask(board, "XM,1000,550,-1234")  # the reference's example
    board.finish()
    assert ask(board, "QS") == b"-684,1784\n\rOK\r\n"


def test_a_move_started_before_the_pen_landed_is_not_drawn(board):
    ask(board, "SC,5,15000")
    ask(board, "SC,12,1000")  # 3000 units at 1000 per 24 ms: 72 ms of travel
    ask(board, "SP,0,10")  # but only 10 ms of wait
    ask(board, "SM,100,800,800")
    ask(board, "SP,0,100")  # long enough
    ask(board, "SM,100,800,800")
    board.finish()
    assert [drawing for _, _, drawing in board.moves] == [False, True]


def test_es_stops_mid_move_and_flushes():
    board = _board(instant=False)
    ask(board, "SM,1000,1000,0")
    ask(board, "SM,1000,1000,0")
    board.poll(0.25)
    assert ask(board, "ES") == b"1\n\rOK\r\n"
    steps = int(ask(board, "QS").split(b",")[0])
    assert 240 <= steps <= 260
    assert ask(board, "QG") == b"10\r\n"  # nothing running, nothing queued


def test_power_lost_bit_is_set_once_when_the_supply_dips():
    board = _board(faults=Faults.parse("abort@3"))
    ask(board, "CU,60,250")
    ask(board, "QG")
    ask(board, "SM,10,1,1")  # the third command: the supply dips
    board.finish()
    assert int(ask(board, "QG"), 16) & 64
    assert not int(ask(board, "QG"), 16) & 64  # read once, cleared


def test_a_power_cycle_zeroes_the_counters_where_the_carriage_stands(board):
    ask(board, "EM,1,1")
    ask(board, "SM,100,800,0")
    board.finish()
    board.carriage = board.true_steps().astype(float)
    board.power_cycle()
    assert ask(board, "QS") == b"0,0\n\rOK\r\n"
    assert ask(board, "QE") == b"0,0\n\rOK\r\n"  # motors off: the carriage is free
    assert list(board.true_steps()) == [800, 0]


def test_lf_ends_a_command_too_and_probes_of_other_firmware_get_the_boards_errors(board):
    board.receive(b"$I\n")
    assert board.take_output() == b"!8 Err: Unknown command '$I:2449'\r\n"
    board.receive(b"V\r\n")  # CR LF: one command, not an empty second one
    assert board.take_output() == b"EBBv13_and_above EB Firmware Version 3.0.3\r\n"
    board.receive(b"VX\x08\r")  # a backspace takes the X back
    assert board.take_output().startswith(b"EBBv13")


def test_firmware_before_3_has_no_qu_and_keeps_a_one_deep_fifo():
    old, new = _board(instant=False, version="2.8.1"), _board(instant=False)
    assert ask(old, "V") == b"EBBv13_and_above EB Firmware Version 2.8.1\r\n"
    assert ask(old, "QU,2") == b"!8 Err: Unknown command 'QU:5155'\r\n"
    assert ask(new, "QU,2") == b"QU,32\r\nOK\r\n"
    for board in (old, new):
        assert ask(board, "CU,4,8") == b"OK\r\n"  # 2.8.1 takes it and does nothing
        replies = [ask(board, "SM,100,10,10") for _ in range(4)]
        # running, then the FIFO: one place on 2.x (the third waits), eight on 3.x
        assert replies == ([b"OK\r\n", b"OK\r\n", b"", b""] if board is old else [b"OK\r\n"] * 4)


def test_sm_without_steps_is_a_delay_capped_at_100_s():
    board = _board(instant=False)
    assert ask(board, "SM,250,0,0") == b"OK\r\n"
    assert ask(board, "SM,1,1,0") == b"OK\r\n"  # waits in the FIFO behind the delay
    board.poll(0.2499)
    assert ask(board, "QS") == b"0,0\n\rOK\r\n"
    board.poll(0.0012)
    assert ask(board, "QS") == b"1,0\n\rOK\r\n"
    capped = _board()
    ask(capped, "SM,150000,0,0")
    capped.finish()
    assert capped.clock == pytest.approx(100.0, abs=1e-3)
