"""The virtual 7475A runs a move as its pairs arrive (an instruction longer than the buffer is
drawn, not waited for), answers ESC.L, knows the 7475A's instructions (and only them), and
draws its circles, arcs and edged rectangles."""

from __future__ import annotations

import numpy as np

from pencilbot.machine.profile import load_profile
from sim.hpgl.board import HpglBoard

PROFILE = load_profile("hp7475a")


def answers(board) -> list[str]:
    return [a for a in board.take_output().decode("ascii").split("\r") if a]


def test_one_instruction_longer_than_the_buffer_is_drawn_as_it_arrives():
    board = HpglBoard(PROFILE)
    points = [(1000 + 20 * k, 1000 + (k % 2) * 300) for k in range(300)]
    job = b"IN;SP1;PU1000,1000;PD" + b",".join(b"%d,%d" % p for p in points[1:]) + b";PU;"
    assert len(job) > 2 * PROFILE.receive_buffer
    sent = 0
    for _ in range(1000):  # a sender that writes what ESC.B says is free, as hpgl-buddy does
        board.receive(b"\x1b.B")
        free = int(answers(board)[0])
        board.receive(job[sent : sent + free])
        sent += min(free, len(job) - sent)
        board.poll(0.5)
        if sent == len(job):
            break
    board.finish()
    assert sent == len(job) and board.overflows == 0
    (stroke,) = board.strokes
    assert np.allclose(stroke / PROFILE.paper.unit_mm, points)


def test_esc_l_answers_the_buffer_size_whatever_it_holds():
    board = HpglBoard(PROFILE)
    board.receive(b"IN;SP1;PU0,0;\x1b.L\x1b.B")
    assert answers(board) == [str(PROFILE.receive_buffer), str(PROFILE.receive_buffer - 13)]


def test_the_7475a_instructions_are_known_and_others_are_error_1():
    board = HpglBoard(PROFILE)
    board.receive(b"IN;LT2;PT0.3;CS0;LBHELLO\x03OE;ZZ1;OE;OF;OO;")
    board.finish()
    assert answers(board) == ["0", "1", "40,40", "0,1,0,0,1,0,0,0"]
    assert board.unemulated == {"LB": 1}  # known, taken, but its drawing is not emulated


def test_circles_arcs_and_rectangles_are_chords_of_the_shape():
    board = HpglBoard(PROFILE)
    board.receive(b"IN;SP1;PA2000,2000;CI400;EA2400,2300;PU3000,2000;PD;AA3000,2400,-90;PU;")
    board.finish()
    circle, rectangle, arc = (s / PROFILE.paper.unit_mm for s in board.strokes)
    assert len(circle) == 73  # 360 / 5° chords, closed
    assert np.allclose(np.hypot(*(circle - [2000, 2000]).T), 400, atol=0.75)
    assert rectangle.tolist() == [[2000, 2000], [2400, 2000], [2400, 2300], [2000, 2300], [2000, 2000]]
    assert np.allclose(np.hypot(*(arc - [3000, 2400]).T), 400, atol=0.75) and np.allclose(
        arc[-1], [2600, 2400], atol=1
    )
    assert not board.down  # CI and EA put the pen back as it was (up)
