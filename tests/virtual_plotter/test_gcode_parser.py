"""GRBL's parser on any input: an answer from GRBL's table, and a failing line changes nothing."""

import copy

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from machines import description

from firmware_protocol import grbl
from sim.gcode.machine import Machine
from sim.gcode.motion_control import MachineAlarm
from sim.gcode.parser import Block, ParserState, _grbl_float, parse_block

WORDS = st.one_of(
    st.sampled_from(
        [
            "G0",
            "G1",
            "G2",
            "G3",
            "G4",
            "G10",
            "G17",
            "G18",
            "G19",
            "G20",
            "G21",
            "G28",
            "G28.1",
            "G30",
            "G38.2",
            "G38.4",
            "G40",
            "G43.1",
            "G49",
            "G53",
            "G54",
            "G59",
            "G59.1",
            "G61",
            "G80",
            "G90",
            "G91",
            "G91.1",
            "G92",
            "G92.1",
            "G93",
            "G94",
            "M0",
            "M1",
            "M2",
            "M3",
            "M5",
            "M7",
            "M8",
            "M30",
            "M280",
            "L2",
            "L20",
            "P1",
            "P7",
            "R5",
            "R-5",
            "%",
            "#",
            ".",
        ]
    ),
    st.builds(
        lambda a, v: f"{a}{v}",
        st.sampled_from("XYZFSPNTIJKLRGMEQ"),
        st.floats(-300, 300, allow_nan=False).map(lambda v: f"{v:.3f}"),
    ),
)
LINES = st.lists(WORDS, max_size=7).map("".join)


@settings(max_examples=400, deadline=None)
@given(LINES)
def test_every_line_gets_a_block_or_a_grbl_status_code(line):
    result = parse_block(line, ParserState([(0.0, 0.0, 0.0)] * 8))
    assert isinstance(result, Block) or result in grbl.ERRORS


def test_a_radius_arc_whose_end_is_its_start_in_the_plane_moves_straight_along_the_linear_axis():
    # Found by the test above: GRBL divides by the zero chord (NaN centre, no segments) and the
    # board goes straight to the target; the parser raised ZeroDivisionError.
    m = Machine(description())
    block = m.parse("G2R5X0Z1F100")
    assert isinstance(block, Block) and block.arc == ((0.0, 0.0, 0.0), 0.0, True)
    for _ in m.execute(block):
        pass
    m.finish()
    assert m.machine_position() == pytest.approx((0.0, 0.0, 1.0))


@settings(max_examples=200, deadline=None)
@given(st.lists(LINES, max_size=12))
def test_a_rejected_line_leaves_the_parser_state_as_it_was(lines):
    m = Machine(description())
    m.settings[12] = 0.05  # coarse arcs keep the random circles cheap
    for line in lines:
        before = copy.deepcopy((m.state.modal, m.state.feed, m.state.position, m.state.coord_offset))
        block = m.parse(line)
        if isinstance(block, int):
            assert (m.state.modal, m.state.feed, m.state.position, m.state.coord_offset) == before
            continue
        try:
            m.apply(block)
        except MachineAlarm:
            pytest.fail("soft limits are off by default: nothing may alarm")


@pytest.mark.parametrize(
    "text, value",
    [
        ("1.5", 1.5),
        ("-2", -2.0),
        ("+.5", 0.5),
        ("12345678", 12345678.0),
        ("123456789", 123456780.0),
        ("1.123456789", 1.1234567),
        ("0.000000001", 0.0),
    ],
)
def test_numbers_keep_eight_significant_digits_like_read_float(text, value):
    assert _grbl_float(text) == pytest.approx(value, abs=1e-12)
