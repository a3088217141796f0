"""The virtual HP 7475A is as unforgiving as the real one: a full buffer loses bytes (ESC.E 16),
moves beyond the hard-clip limits are refused (OE 3), a pen that is not picked draws nothing,
ESC.K discards what is buffered, XON/XOFF follow the buffer."""

from __future__ import annotations

import math

from pencilbot.machine.profile import load_profile
from sim.hpgl.board import HpglBoard

PROFILE = load_profile("hp7475a")


def answers(board) -> list[str]:
    return [a for a in board.take_output().decode("ascii").split("\r") if a]


def test_bytes_beyond_the_buffer_are_lost_and_esc_e_says_so():
    board = HpglBoard(PROFILE)
    job = b"IN;SP1;" + b"".join(b"PU%d,%d;PD%d,%d;" % (i, i, i + 40, i) for i in range(150))
    assert len(job) > PROFILE.receive_buffer
    board.receive(job)  # a sender that does not poll ESC.B
    assert board.overflows == len(job) - PROFILE.receive_buffer
    board.receive(b"\x1b.E\x1b.E")
    assert answers(board) == ["16", "0"]  # reported once, then cleared
    board.finish()
    assert len(board.strokes) < 150  # the lost bytes are lost strokes


def test_esc_b_counts_free_bytes_and_esc_k_discards_them():
    board = HpglBoard(PROFILE)
    board.receive(b"IN;SP1;PU0,0;PD400,0;\x1b.B")
    assert answers(board) == [str(PROFILE.receive_buffer - 21)]
    board.receive(b"\x1b.K\x1b.B")
    assert answers(board) == [str(PROFILE.receive_buffer)]
    board.finish()
    assert board.strokes == [] and board.executed == 0


def test_limits_errors_and_the_carousel():
    board = HpglBoard(PROFILE)
    width, height = board.limits[2], board.limits[3]
    assert (width, height) == (11040, 7721)  # the 7475A's A4 hard-clip limits
    board.receive(b"IN;PD100,100;PU0,0;SP2;PD%d,0;OE;PD%d,0;OE;OS;OA;" % (width, width + 1))
    board.finish()
    # OS after OE: pen down, initialised, paper ready; the error bit went with OE reading it
    assert answers(board) == ["0", "3", "25", f"{width},0,1"]
    # No pen picked: the first PD drew nothing; pen 2 drew to the limit and not beyond.
    assert [s.tolist() for s in board.strokes] == [[[0.0, 0.0], [width * PROFILE.paper.unit_mm, 0.0]]]
    assert board.stroke_pens == [2]


def test_xon_xoff_follow_the_buffer():
    board = HpglBoard(PROFILE, xonxoff=True)
    board.receive(b"PU0,0;" * 170)  # 1020 bytes: fewer than 80 free
    assert board.take_output() == b"\x13"
    board.poll(math.inf)
    assert board.take_output() == b"\x11"


def test_time_is_the_motion_model_and_the_pen_delays():
    board = HpglBoard(PROFILE)
    board.receive(b"IN;SP1;VS10;PD0,4000;PU;")  # 4000 units at 100 mm/s, pen down and up
    board.finish()
    a = PROFILE.motion.acceleration
    length = 4000 * PROFILE.paper.unit_mm  # 99.52 mm of the 7475A's 0.02488 mm units
    expected = length / 100 + 100 / a + PROFILE.pen.down_delay + PROFILE.pen.up_delay  # trapezoid: L/v + v/a
    assert math.isclose(board.clock, expected, rel_tol=1e-9)


def test_os_says_initialised_once_after_power_up_in_and_a_reset():
    # HP 7470A manual, OS: bit 8 is set at power-up and by IN, cleared once the status is output.
    from sim.faults import Faults

    board = HpglBoard(PROFILE, faults=Faults.parse("reset@6"))
    board.receive(
        b"OS;OS;IN;OS;PU10,10;OS;"
    )  # the reset comes as the 6th instruction (OS) starts: it is lost
    board.finish()
    assert answers(board) == ["24", "16", "24"]
    board.receive(b"OS;OS;OA;")
    board.finish()
    assert answers(board) == ["24", "16", "0,0,0"]
