"""The modal tracker reads each G code for what GRBL does with it: the coordinate-system codes
(G10, G28, G30, G53, G92) are non-modal, so they change neither the motion mode nor the
distance mode of the lines after them; an empty block tracks to nothing."""

import pytest

from pencilbot.driver.gcode.modal import ModalState, clean_line, track
from pencilbot.machine.profile import load_profile

PEN = load_profile("grbl-servo-a4").pen_model


@pytest.mark.parametrize("code", ["G10 L20 P0 X0 Y0", "G28", "G30", "G53 X1 Y1", "G92 X0 Y0"])
def test_a_coordinate_system_code_leaves_the_motion_and_distance_modes_as_they_were(code):
    states = track([clean_line(line) for line in ["G1 X10 Y10 F1000", code, "X20 Y25"]], PEN)
    after = states[2]
    # (Read as an arc, the modal "X20 Y25" would be G2; read as G91, a relative step.)
    assert (after.motion, after.arc, after.relative) == (1, 0, False)
    assert (states[1].motion, states[1].arc, states[1].relative) == (1, 0, False)


def test_an_empty_block_tracks_to_no_state():
    states = track([], PEN, start=ModalState(x=3.0, y=4.0))
    assert len(states) == 0


def test_the_words_of_a_system_command_after_other_lines_count_for_nothing():
    # "$N0=G1X50" stores a startup line in the board; it runs nothing now.
    states = track(["G1X1Y1F100", "$N0=G1X50", "G4P0.1"], PEN)
    assert (states[1].x, states[2].x, states[2].motion) == (1.0, 1.0, 1)


@pytest.mark.parametrize("block", [b"", b"G1X1Y2"])
def test_a_block_without_a_whole_line_has_no_words(block):
    from pencilbot.driver.gcode.words import read_words as _words

    words = _words(block)
    assert words.lines == 0 and len(words.line) == len(words.letter) == len(words.value) == 0
