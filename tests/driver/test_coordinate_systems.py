"""The bed check follows every coordinate system a file can use (G53, G92/G92.1, G10 L2/L20,
G54-G59, G28/G30) as the virtual plotter (GRBL 1.1h's parser) runs it, or refuses the file by
line: a move that the numbers alone put on the bed but an offset sends off it never reaches the
board."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_stream_sim import PROFILE, accepted, drawn, fresh

from pencilbot.cli import main
from pencilbot.driver.gcode.drawn import drawn_paths
from pencilbot.driver.gcode.job import load_job
from pencilbot.driver.gcode.modal import ModalState, advance, clean_line, track
from pencilbot.machine.profile import load_profile
from sim import protocol_sim
from sim.gcode.machine import Machine

GRBL = load_profile(PROFILE)  # bed X 0 .. 220, Y 0 .. 310 mm


def draw_cli(capsys, tmp_path, lines, *extra):
    path = tmp_path / "job.gcode"
    path.write_text("\n".join(lines) + "\n")
    url, name = fresh()
    code = main(["draw", str(path), "--port", url, "--profile", PROFILE, "-q", *extra])
    return code, capsys.readouterr().err, name, path


# Each of these reaches X 350 or more in machine coordinates while every number in it is on the bed.
OFF_BED = {
    "G53": (["G21", "G90", "G0 X10 Y10", "G53 G0 X500 Y10", "G0 X10 Y10"], 4, "X 500.000 Y 10.000"),
    "G92": (["G21", "G90", "G0 X200 Y100", "G92 X0 Y0", "G0 X150 Y0"], 5, "X 350.000 Y 100.000"),
    "G10 L20": (["G21", "G90", "G0 X200 Y10", "G10 L20 P1 X0 Y0", "G0 X200 Y0"], 5, "X 400.000 Y 10.000"),
    "G10 L2": (["G21", "G90", "G10 L2 P1 X150 Y0", "G0 X200 Y10"], 4, "X 350.000 Y 10.000"),
    "G10 L2 P2 + G55": (
        ["G21", "G90", "G10 L2 P2 X150 Y0", "G0 X200 Y10", "G55", "G0 X200 Y10"],
        6,
        "X 350.000 Y 10.000",
    ),
    "G20 G92": (["G20", "G90", "G0 X8 Y4", "G92 X0 Y0", "G0 X6 Y0"], 5, "X 355.600 Y 101.600"),
    "G91 G10 L20 P0": (
        ["G21", "G91", "G0 X200 Y10", "G10 L20 P0 X0 Y0", "G90", "G0 X0 Y0", "G91", "G0 X150"],
        8,
        "X 350.000 Y 10.000",
    ),
    "G28 via": (
        ["G21", "G90", "G28.1", "G0 X100 Y100", "G92 X0 Y0", "G28 X300 Y0"],
        6,
        "X 400.000 Y 100.000",
    ),
}


@pytest.mark.parametrize("case", sorted(OFF_BED))
def test_a_move_an_offset_sends_off_the_bed_is_refused_by_line_and_nothing_is_sent(capsys, tmp_path, case):
    lines, line, where = OFF_BED[case]
    code, err, name, path = draw_cli(capsys, tmp_path, lines)
    reaches = "passes through" if "via" in case else "moves to"
    assert code == 2 and err.startswith(
        f"pencilbot: error: line {line} of {path} ({clean_line(lines[line - 1])!r}) {reaches} {where} mm, "
        "off the bed of plotter profile grbl-servo-a4"
    ), err
    assert "Traceback" not in err and err.count("\n") == 1
    assert name not in protocol_sim._PLOTTERS  # the port was never opened


def test_the_virtual_plotter_sends_the_carriage_where_the_bed_check_says(tmp_path):
    # The same lines run by the simulator's GRBL parser: the machine position the check refused.
    for lines, line, where in OFF_BED.values():
        machine = Machine(GRBL)
        for text in lines[:line]:
            block = machine.parse(clean_line(text))
            assert not isinstance(block, int), (text, block)
            target = block.target  # a G28's: its via point
            machine.apply(block)
        x, y = (float(v) for v in where.replace("X ", "").replace("Y ", "").split())
        assert target[:2] == pytest.approx((x, y)), lines
        assert load_job(lines, GRBL).off_bed[:3] == (line - 1, pytest.approx(x), pytest.approx(y))


@pytest.mark.parametrize(
    "lines, line, what",
    [
        (
            ["G21", "G90", "G55", "G0 X10 Y10"],
            4,
            "moves in coordinate system G55, whose offset the board keeps",
        ),
        (["G21", "G90", "G10 L2 P3 X5", "G56 G0 X10 Y10"], 4, "moves in coordinate system G56"),
        (["G21", "G90", "G0 X10 Y10", "G28"], 4, "goes to the position the board stored with G28.1"),
        (["G21", "G90", "G0 X10 Y10", "G30 X20"], 4, "goes to the position the board stored with G30.1"),
    ],
)
def test_a_move_that_rests_on_an_offset_only_the_board_knows_is_refused_by_line(
    capsys, tmp_path, lines, line, what
):
    code, err, name, path = draw_cli(capsys, tmp_path, lines)
    assert code == 2 and err.startswith(
        f"pencilbot: error: line {line} of {path} ({clean_line(lines[line - 1])!r}) {what}"
    ), err
    assert "nothing was sent" in err and "To draw it, set it in the file first" in err
    assert name not in protocol_sim._PLOTTERS


def test_offsets_that_keep_the_drawing_on_the_bed_draw_where_the_board_puts_them(capsys, tmp_path):
    # A square drawn at work 0..20 after G92 at machine (50, 60); then G92.1, G55 set by G10,
    # G53 and G28 with its stored position: every move lands where GRBL puts it, on the bed.
    square = ["M3 S90", "G1 X20 Y0 F3000", "G1 X20 Y20", "G1 X0 Y20", "G1 X0 Y0", "M3 S30"]
    lines = [
        "G21",
        "G90",
        "M3 S30",
        "G0 X50 Y60",
        "G92 X0 Y0",
        *square,
        "G92.1",
        "G10 L2 P2 X100 Y100",
        "G55 G0 X0 Y0",
        *square,
        "G54",
        "G53 G0 X5 Y5",
        "G0 X30 Y30",
        "G28.1",
        "G0 X60 Y10",
        "G28",
    ]
    code, err, name, _ = draw_cli(capsys, tmp_path, lines)
    assert code == 0, err
    strokes = sorted(np.round(s[:, :2], 3).tolist() for s in drawn(name))
    assert strokes == [
        [[50, 60], [70, 60], [70, 80], [50, 80], [50, 60]],
        [[100, 100], [120, 100], [120, 120], [100, 120], [100, 100]],
    ]
    machine = protocol_sim.plotter(name).machine
    assert machine.position[:2] == pytest.approx((30.0, 30.0))  # G28: the G28.1 point
    assert [clean_line(line) for line in lines] == accepted(name)
    # `stat` reads the same pen-down paths from the file alone.
    paths = drawn_paths(load_job(lines, GRBL))
    assert (
        sorted(np.round(paths.points[a:b], 3).tolist() for a, b in zip(paths.offsets[:-1], paths.offsets[1:]))
        == strokes
    )


def test_a_start_line_after_an_offset_is_refused_before_anything_is_sent(capsys, tmp_path):
    lines = ["G21", "G90", "G0 X50 Y60", "G92 X0 Y0", "G0 X10 Y10", "G92.1", "G0 X10 Y10"]
    code, err, name, path = draw_cli(capsys, tmp_path, lines, "--start-line", "5")
    assert code == 2 and err.startswith(
        f"pencilbot: error: line 5 of {path} comes after lines that change the "
        "work coordinates (G92, G10, G54-G59), which a resume cannot restore"
    )
    assert name not in protocol_sim._PLOTTERS
    code, err, name, _ = draw_cli(capsys, tmp_path, lines, "--start-line", "7")  # G92.1: machine again
    assert code == 0, err


_value = st.integers(-400, 400).map(lambda v: v / 4)
_token = st.one_of(
    st.builds("G10L2P{}X{}Y{}".format, st.integers(0, 7), _value, _value),
    st.builds("G10L20P{}X{}Y{}".format, st.integers(0, 6), _value, _value),
    st.builds("G10L{}P1X{}".format, st.sampled_from([1, 3]), _value),  # refused by the board: no change
    st.builds("G92X{}Y{}".format, _value, _value),
    st.builds("G92Y{}".format, _value),
    st.builds("G53G0X{}Y{}".format, _value, _value),
    st.builds("G53X{}".format, _value),
    st.builds("G{}".format, st.integers(54, 59)),
    st.builds("G{}G0X{}Y{}".format, st.integers(54, 59), _value, _value),
    st.builds("G0X{}Y{}".format, _value, _value),
    st.builds("X{}".format, _value),
    st.builds("G28X{}".format, _value),
    st.builds("G30Y{}".format, _value),
    st.sampled_from(["G90", "G91", "G20", "G21", "G92.1", "G28", "G30", "G28.1", "G30.1", "G92"]),
)


@settings(max_examples=60, deadline=None)
@given(st.lists(_token, min_size=1, max_size=15))
def test_tracked_positions_equal_the_virtual_plotter_s_line_by_line(tokens):
    # Every stored position set first (the tracker takes what the file never set as unknown).
    setup = [f"G10L2P{p}X{3 * p}Y{-2 * p}" for p in range(1, 7)] + ["G28.1", "G30.1"]
    lines = setup + tokens
    columns = track(lines, GRBL.pen_model).columns
    machine, state = Machine(GRBL), ModalState()
    for i, line in enumerate(lines):
        block = machine.parse(line)
        if not isinstance(block, int):
            machine.apply(block)
        state = advance(state, line, GRBL.pen_model)  # line by line, as a checkpoint continues
        expected = machine.position[:2]
        assert (columns["mx"][i], columns["my"][i]) == pytest.approx(expected, abs=1e-9), lines[: i + 1]
        work = tuple(
            np.subtract(machine.position, machine.work_offset())[:2]
        )  # the parser's, not the carriage's
        assert (columns["x_mm"][i], columns["y_mm"][i]) == pytest.approx(work, abs=1e-9), lines[: i + 1]
        assert state.position_mm()[:2] == pytest.approx(work, abs=1e-9), lines[: i + 1]
