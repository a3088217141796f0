"""HP-GL export: a colour plan takes the carousel's pens in load order without a pause, moves
are whole plotter units on the sheet, and what cannot be plotted is refused before a file exists."""

from __future__ import annotations

import numpy as np
import pytest

from firmware_protocol import hpgl as grammar
from pencilbot.errors import OutOfBedError, PencilbotError
from pencilbot.export.hpgl import hpgl_program, write_hpgl
from pencilbot.machine.profile import load_profile
from pencilbot.paths import Paths
from pencilbot.planning.plan import Layer, Page, Plan
from sim.hpgl.board import HpglBoard

PROFILE = load_profile("hp7475a")
A4 = Page(297, 210, margin=0.0, name="A4")


def _layer(name, pen, x, color="#000000"):
    return Layer(
        name,
        Paths.of(
            [
                np.array([[x, 40.0], [x + 30.0, 60.0], [x + 31.0, 120.0]]),
                np.array([[x, 150.0], [x + 5.0, 160.0]]),
            ]
        ),
        pen=pen,
        color=color,
    )


def _play(program: bytes, error: int = 0) -> HpglBoard:
    board = HpglBoard(PROFILE)
    for at in range(0, len(program), 512):
        board.receive(program[at : at + 512])
        board.finish()
    assert board.overflows == 0 and board.error == error
    return board


def test_a_colour_plan_selects_carousel_pens_in_load_order_without_pausing():
    plan = Plan(
        A4,
        [
            _layer("y", "yellow", 30, "#ffff00"),
            _layer("c", "cyan", 90, "#00ffff"),
            _layer("c2", "cyan", 120, "#00ffff"),
            _layer("k", "black", 200),
        ],
    )
    program = hpgl_program(plan, PROFILE)
    found, _ = grammar.split_instructions(program)
    selects = [int(i.params[0]) for i in found if i.mnemonic == "SP"]
    assert selects == [1, 2, 3, 0]  # one pen run each (cyan's two layers together), then put away
    assert found[0].mnemonic == "IN" and found[-1] == grammar.Instruction("SP", (0.0,))
    assert all(p == int(p) for i in found for p in i.params)  # whole plotter units
    board = _play(program)
    assert board.stroke_pens == [1, 1, 2, 2, 2, 2, 3, 3]
    # Where the sheet lies: page (30, 40) mm is 10, 4 mm right of and above the plotter's origin.
    assert board.strokes[0][0].tolist() == pytest.approx(
        [20.0, 36.0], abs=PROFILE.paper.unit_mm / 2
    )  # to a unit


def test_pens_beyond_the_carousel_keep_their_numbers_and_the_plotter_refuses_them_unaided():
    many = Plan(A4, [_layer(f"l{i}", f"pen{i}", 20 + 30 * i) for i in range(8)])
    found, _ = grammar.split_instructions(hpgl_program(many, PROFILE))
    assert [int(i.params[0]) for i in found if i.mnemonic == "SP"] == [1, 2, 3, 4, 5, 6, 7, 8, 0]
    # Sent as it is, with no one to change pens: there is no slot 7 or 8 (OE 3), and the plotter
    # draws their strokes with the pen it holds (what pencilbot's draw pauses to prevent).
    board = _play(hpgl_program(many, PROFILE), error=3)
    assert board.stroke_pens == [k for k in range(1, 7) for _ in range(2)] + [6] * 4


def test_what_cannot_be_plotted_is_refused_before_a_file_exists(tmp_path):
    target = tmp_path / "d.hpgl"
    off = Plan(A4, [Layer("off", Paths.of([np.array([[2.0, 40.0], [50.0, 60.0]])]))])  # left of the limits
    with pytest.raises(OutOfBedError, match="does not fit the limits"):
        write_hpgl(off, PROFILE, target)
    with pytest.raises(PencilbotError, match="not an HP-GL plotter"):
        write_hpgl(Plan(A4, [_layer("k", "", 50)]), load_profile("grbl-servo-a4"), target)
    assert not target.exists()


def test_stat_and_draw_say_when_the_profile_is_not_an_hpgl_plotters(tmp_path, capsys):
    from pencilbot.cli import main

    target = tmp_path / "d.hpgl"
    write_hpgl(Plan(A4, [_layer("k", "", 50)]), PROFILE, target)
    assert main(["stat", str(target), "--profile", "grbl-servo-a4"]) != 0
    assert "not an HP-GL plotter's" in capsys.readouterr().err
    assert main(["draw", str(target), "--profile", "grbl-servo-a4", "--port", "sim://"]) != 0
    assert "--profile hp7475a" in capsys.readouterr().err
    assert main(["stat", str(target), "--profile", "hp7475a", "--json"]) == 0
    assert '"paths": 2' in capsys.readouterr().out
