"""HP-GL grammar: instructions survive encoding and a buffer filled in any chunks; device
control sequences come out of a byte stream wherever they fall."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from firmware_protocol import ProtocolError, hpgl

_MNEMONICS = ["IN", "SP", "PU", "PD", "PA", "PR", "VS", "OI", "OA", "OS", "OE"]
instructions = st.builds(
    hpgl.Instruction,
    st.sampled_from(_MNEMONICS),
    st.lists(st.integers(-32767, 32767).map(float), max_size=6).map(tuple),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(instructions, max_size=20), st.lists(st.integers(1, 30), max_size=40))
def test_instructions_round_trip_through_any_chunking(program, cuts):
    data = b"\n".join(i.encode() for i in program)
    whole, used = hpgl.split_instructions(data, final=True)
    assert whole == program and used == len(data)
    # A buffer filled a chunk at a time gives the same instructions, none before its ';'.
    got, buffer, at = [], b"", 0
    for cut in cuts + [len(data)]:
        buffer += data[at : at + cut]
        at += cut
        found, used = hpgl.split_instructions(buffer, final=False)
        got += found
        buffer = buffer[used:]
    got += hpgl.split_instructions(buffer, final=True)[0]
    assert got == program


def test_instructions_without_terminators_and_with_spaces():
    found, _ = hpgl.split_instructions(b"IN;SP1PU 10 20PD30,40,+50,-60;PU", final=True)
    assert found == [
        hpgl.Instruction("IN"),
        hpgl.Instruction("SP", (1.0,)),
        hpgl.Instruction("PU", (10.0, 20.0)),
        hpgl.Instruction("PD", (30.0, 40.0, 50.0, -60.0)),
        hpgl.Instruction("PU"),
    ]


def test_a_label_runs_to_its_etx_and_garbage_is_refused():
    found, _ = hpgl.split_instructions(b"LBhello; world\x03PU;", final=True)
    assert found == [hpgl.Instruction("LB", (), "hello; world"), hpgl.Instruction("PU")]
    with pytest.raises(ProtocolError):
        hpgl.split_instructions(b"PU1,2;7;", final=True)
    with pytest.raises(ProtocolError):
        hpgl.split_instructions(b"PU1,x2;", final=True)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.sampled_from([b"PU1,2;", b"\x1b.B", b"\x1b.E", b"\x1b.K", b"\x1b.I81;;17:", b"PD3,4;"]),
        max_size=15,
    )
)
def test_device_control_is_taken_out_wherever_it_falls(parts):
    data = b"".join(parts)
    sequences, rest, left = hpgl.split_device_control(data)
    assert left == 0
    assert rest == b"".join(p for p in parts if not p.startswith(b"\x1b"))
    assert [s[0] for s in sequences] == [p[2:3] for p in parts if p.startswith(b"\x1b")]
    assert all(params == b"81;;17" for letter, params in sequences if letter == b"I")


def test_an_unfinished_sequence_is_kept_for_later():
    sequences, rest, left = hpgl.split_device_control(b"PU;\x1b.")
    assert sequences == [] and rest == b"PU;" and left == 2


def test_answers_and_units():
    assert hpgl.parse_answer("1024\r") == (1024,)
    assert hpgl.parse_answer(" 400,300,1") == (400, 300, 1)
    with pytest.raises(ProtocolError):
        hpgl.parse_answer("7475A")
    assert hpgl.to_units(10.0) == 400 and hpgl.encode("PD", 1, 2.5) == b"PD1,2.5;"
