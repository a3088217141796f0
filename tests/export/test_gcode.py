"""The G-code writer: a third-party parser accepts it, and reading it back gives the plan.

The reader below is deliberately independent of the writer: it parses with ``gcodeparser``,
frames with ``firmware_protocol.marlin``, and follows pen and feed state the way firmware does.
"""

from __future__ import annotations

import dataclasses
from functools import reduce

import numpy as np
import pytest
from gcodeparser import parse_gcode_lines
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from firmware_protocol.marlin import unframe_line
from pencilbot.errors import OutOfBedError, PencilbotError
from pencilbot.export.gcode import gcode_lines, write_gcode
from pencilbot.machine.bed import Bed, Placement
from pencilbot.machine.profile import load_profile
from pencilbot.planning.plan import Layer, Page, Plan

A4 = Page(210.0, 297.0, margin=15.0, name="A4")
PROFILES = ["grbl-servo-a4", "grbl-z-a3", "grblhal-servo-a3", "marlin-servo-a4"]
ALLOWED = {
    "grbl": {"G0", "G1", "G4", "G21", "G90", "G94", "M3"},
    "grblhal": {"G0", "G1", "G4", "G21", "G90", "G94", "M3"},
    "marlin": {"G0", "G1", "G4", "G21", "G90", "M280", "M400", "M84", "M110"},
}


def with_format(profile, **changes):
    return dataclasses.replace(profile, gcode=dataclasses.replace(profile.gcode, **changes))


def plan_of(*layers, page=A4) -> Plan:
    return Plan(page, [Layer(f"layer-{i}", paths) for i, paths in enumerate(layers)])


@dataclasses.dataclass
class Reading:
    strokes: list[np.ndarray]  # pen-down polylines, machine mm
    pen_downs: int
    pen_ups: int
    feeds_written: list[float]
    first_move_pen: str | None
    last_move: tuple[str, float, float]
    dwells: list[float]


def read_back(lines: list[str], profile) -> Reading:
    """Follow the program like firmware: every command through gcodeparser, pen and F modal."""
    down_line = profile.render(profile.pen.down_command)[-1]
    up_line = profile.render(profile.pen.up_command)[-1]
    pen, feed, pos = None, None, None
    strokes, current, feeds, dwells = [], None, [], []
    downs = ups = 0
    first_move_pen, last_move = "never", None
    for raw in lines:
        assert len(raw) <= 80, raw
        assert raw.isascii() and raw == raw.strip()
        if raw.startswith(";"):
            continue
        text = raw
        if profile.gcode.line_numbers:
            framed = unframe_line(raw)
            assert framed is not None, f"bad Marlin frame or checksum: {raw}"
            text = framed[1]
        parsed = list(parse_gcode_lines(text))
        assert len(parsed) == 1, text
        cmd = parsed[0]
        words = text.split(";")[0].split()
        assert len(cmd.params) == len(words) - 1, f"parser dropped a word of {text!r}"
        assert all(isinstance(v, int | float) and not isinstance(v, bool) for v in cmd.params.values())
        assert cmd.command_str in ALLOWED[profile.dialect], text
        if text.split(";")[0].strip() == down_line:
            assert pen != "down", "redundant pen down"
            pen, downs, current = "down", downs + 1, [pos]
        elif text.split(";")[0].strip() == up_line:
            assert pen != "up", "redundant pen up"
            if current is not None:
                strokes.append(np.array(current, dtype=float))
            pen, ups, current = "up", ups + 1, None
        if "F" in cmd.params:
            assert cmd.params["F"] != feed, f"F written without a change: {text}"
            feeds.append(float(cmd.params["F"]))
            if cmd.command_str == "G1" or profile.dialect == "marlin":
                feed = float(cmd.params["F"])
        if cmd.command_str == "G4":
            dwells.append(float(cmd.params["P"]))
        if cmd.command_str in ("G0", "G1") and ("X" in cmd.params or "Y" in cmd.params):
            target = (float(cmd.params["X"]), float(cmd.params["Y"]))
            assert target != pos, f"move to where the pen already is: {text}"
            if first_move_pen == "never":
                first_move_pen = pen
            if cmd.command_str == "G1":
                assert pen == "down" and feed == profile.motion.draw_feed
                current.append(target)
            else:
                assert pen == "up", "G0 with the pen down"
                if profile.dialect == "marlin":
                    assert feed == profile.motion.travel_feed
            pos = target
            last_move = (cmd.command_str, *target)
    return Reading(strokes, downs, ups, feeds, first_move_pen, last_move, dwells)


def expected_strokes(plan: Plan, profile) -> list[tuple[np.ndarray, np.ndarray]]:
    """(rounded machine polyline, kept original page points) for every non-empty path."""
    placement = Placement.on_bed(plan.page, profile.bed)
    out = []
    for path in plan.paths():
        if not len(path):
            continue
        machine = np.round(placement.to_machine(path), profile.gcode.decimals)
        keep = np.ones(len(path), dtype=bool)
        keep[1:] = (machine[1:] != machine[:-1]).any(axis=1)
        out.append((machine[keep], path[keep]))
    return out


def check_program(plan: Plan, profile) -> Reading:
    lines = gcode_lines(plan, profile, source="test")
    reading = read_back(lines, profile)
    expected = expected_strokes(plan, profile)
    assert reading.pen_downs == len(expected)  # one pen down per drawn path
    assert reading.pen_ups == len(expected) + 1  # one before the first move, one after each path
    assert len(reading.strokes) == len(expected)
    placement = Placement.on_bed(plan.page, profile.bed)
    tolerance = 0.5 * 10.0**-profile.gcode.decimals + 1e-9
    for got, (machine, page_points) in zip(reading.strokes, expected):
        np.testing.assert_allclose(got, machine + 0.0, atol=1e-9)
        np.testing.assert_allclose(placement.to_page(got), page_points, atol=tolerance, rtol=0)
    assert reading.first_move_pen == "up"
    assert reading.last_move == ("G0", 0.0, 0.0)  # home, pen up
    return reading


# --- hypothesis: any plan on the page, any shipped profile, any precision -----------------------

coordinate = st.one_of(
    st.floats(15.0, 195.0, allow_nan=False),
    st.sampled_from([15.0, 100.0, 100.0004, 195.0]),  # repeats make joins and rounding duplicates
)
point = st.tuples(coordinate, coordinate.map(lambda v: v * 297.0 / 210.0))
path = st.lists(point, min_size=0, max_size=6).map(lambda p: np.array(p, dtype=float).reshape(-1, 2))
layers = st.lists(st.lists(path, max_size=6), min_size=1, max_size=3)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(layers, st.sampled_from(PROFILES), st.integers(0, 6), st.booleans())
def test_any_plan_reads_back_within_rounding(layer_paths, name, decimals, numbered):
    profile = with_format(load_profile(name), decimals=decimals)
    if numbered and profile.dialect == "marlin":
        profile = with_format(profile, line_numbers=True)
    check_program(plan_of(*layer_paths), profile)


@pytest.mark.parametrize("name", PROFILES)
def test_a_real_looking_plan_in_every_profile(name):
    rng = np.random.default_rng(1)
    strokes = [rng.uniform([20, 20], [190, 277], (rng.integers(2, 8), 2)) for _ in range(300)]
    hatch = [np.array([[20.0, y], [190.0, y]]) for y in np.arange(20, 277, 0.7)]
    reading = check_program(plan_of(hatch, strokes), load_profile(name))
    assert reading.pen_downs == len(strokes) + len(hatch)


def test_grbl_gets_one_feed_marlin_alternates():
    plan = plan_of([np.array([[20.0, 20], [30, 30]]), np.array([[40.0, 40], [50, 50]])])
    grbl = read_back(gcode_lines(plan, load_profile("grbl-servo-a4")), load_profile("grbl-servo-a4"))
    assert grbl.feeds_written == [3000.0]  # GRBL's G0 ignores F: set the drawing feed once
    marlin_profile = load_profile("marlin-servo-a4")
    marlin = read_back(gcode_lines(plan, marlin_profile), marlin_profile)
    assert marlin.feeds_written == [7200.0, 3000.0, 7200.0, 3000.0, 7200.0]  # last: home


def test_pen_template_that_sets_feed_makes_the_writer_restate_it():
    z = load_profile("grbl-z-a3")
    z = dataclasses.replace(z, pen=dataclasses.replace(z.pen, down_command="G1 Z{down} F300"))
    plan = plan_of([np.array([[20.0, 20], [30, 30]]), np.array([[40.0, 40], [50, 50]])])
    lines = gcode_lines(plan, z)
    draws = [line for line in lines if line.startswith("G1 X")]
    assert all(line.endswith(" F2400") for line in draws)  # after every pen down


def test_dwell_units_follow_the_dialect():
    plan = plan_of([np.array([[20.0, 20], [30, 30]])])
    grbl = load_profile("grbl-servo-a4")
    assert "G4 P0.15" in gcode_lines(plan, grbl) and "G4 P0.2" in gcode_lines(plan, grbl)  # seconds
    marlin = load_profile("marlin-servo-a4")
    assert "G4 P150" in gcode_lines(plan, marlin) and "G4 P200" in gcode_lines(plan, marlin)  # ms
    z = load_profile("grbl-z-a3")  # no delay: no dwell at all
    assert not any(line.startswith("G4") for line in gcode_lines(plan, z))


def test_pen_blocks_come_whole_and_in_order():
    profile = load_profile("marlin-servo-a4")
    lines = gcode_lines(plan_of([np.array([[20.0, 20], [30, 30]])]), profile)
    body = [line for line in lines if not line.startswith(";")]
    start = body.index("M280 P0 S20")
    # the A4 sheet lies turned on the landscape bed: page (30, 30) is at X 297-30, Y 210-30
    assert body[start - 1 : start + 3] == ["M400", "M280 P0 S20", "G4 P200", "G1 X267 Y180 F3000"]
    assert body[-3:] == ["G4 P150", "G0 X0 Y0 F7200", "M84 ; release the motors"]


def test_marlin_line_numbers_and_checksums():
    profile = with_format(load_profile("marlin-servo-a4"), line_numbers=True)
    lines = gcode_lines(plan_of([np.array([[20.0, 20], [30, 30.5]])]), profile)
    commands = [line for line in lines if not line.startswith(";")]
    assert commands[0] == "N0 M110 N0*125"  # the reset Marlin hosts send, checksum by hand
    for n, line in enumerate(commands):
        body, star, checksum = line.rpartition("*")
        assert star and body.startswith(f"N{n} ")
        assert int(checksum) == reduce(lambda a, b: a ^ b, body.encode("ascii"), 0)
        assert ";" not in body  # a trailing comment would hide the '*' from Marlin
        assert unframe_line(line) is not None


def test_header_states_source_profile_page_time_and_lengths():
    plan = plan_of([np.array([[20.0, 20], [50, 60]])])  # 50 mm of drawing
    lines = gcode_lines(plan, load_profile("grbl-servo-a4"), source="photos/cat.jpg")
    header = "\n".join(line for line in lines if line.startswith(";"))
    assert "source: photos/cat.jpg" in header
    assert "grbl-servo-a4 (grbl)" in header and "plotters/grbl-servo-a4.toml" in header
    assert "page: A4 210 x 297 mm on a 220 x 310 mm bed" in header
    assert "sheet upright in the bed's bottom-left corner" in header
    assert "estimated time: 0:00:" in header
    assert "pen down 50.0 mm" in header and "1 paths" in header
    assert "layer layer-0: 1 paths" in header


def test_long_or_odd_names_stay_on_one_short_ascii_line():
    plan = Plan(A4, [Layer("hatch " + "é" * 100, [np.array([[20.0, 20], [30, 30]])])])
    lines = gcode_lines(plan, load_profile("grbl-servo-a4"), source="/very/" + "long/" * 40 + "ß\nx.jpg")
    assert max(map(len, lines)) <= 80
    assert all(line.isascii() for line in lines)
    assert sum(line.startswith("; source: /very/") for line in lines) == 1


def test_empty_plan_still_lifts_the_pen_and_goes_home():
    profile = load_profile("grbl-servo-a4")
    reading = check_program(plan_of([], [np.zeros((0, 2))]), profile)
    assert reading.pen_downs == 0 and reading.pen_ups == 1


# --- placement on the bed ------------------------------------------------------------------------


def corners(page: Page) -> np.ndarray:
    return np.array([[0, 0], [page.width, 0], [0, page.height], [page.width, page.height]], float)


def test_placement_puts_the_sheet_in_the_origin_corner():
    page = Page(100.0, 50.0)
    bl, br, tl, tr = corners(page)
    cases = {
        ("bottom-left", False, False): {tuple(bl): (0, 0), tuple(tr): (100, 50)},
        ("top-left", False, False): {tuple(tl): (0, 0), tuple(bl): (0, 50)},
        ("bottom-right", False, False): {tuple(br): (0, 0), tuple(bl): (100, 0)},
        ("top-right", True, True): {tuple(tr): (0, 0), tuple(bl): (-100, -50)},
        ("bottom-left", True, False): {tuple(tr): (-100, 50)},
    }
    for (origin, ix, iy), mapping in cases.items():
        placement = Placement.on_bed(page, Bed(200.0, 200.0, origin, ix, iy))
        assert not placement.rotated
        for page_point, machine in mapping.items():
            np.testing.assert_allclose(placement.to_machine(np.array([page_point]))[0], machine)


def test_a_sheet_that_only_fits_turned_is_turned():
    bed = Bed(300.0, 218.0, "bottom-left")
    portrait = Placement.on_bed(Page(210.0, 297.0), bed)
    assert portrait.rotated and portrait.size == (297.0, 210.0)
    # top-left of the page goes to the bed's bottom-left: the top edge lies along the left side
    np.testing.assert_allclose(portrait.to_machine(np.array([[0.0, 297.0], [0.0, 0.0]])), [[0, 0], [297, 0]])
    assert not Placement.on_bed(Page(297.0, 210.0), bed).rotated
    assert not Placement.on_bed(Page(420.0, 297.0), bed).rotated  # fits neither way: as it is


@settings(max_examples=80, deadline=None)
@given(
    st.sampled_from(["bottom-left", "top-left", "bottom-right", "top-right"]),
    st.booleans(),
    st.booleans(),
    st.floats(50, 400),
    st.floats(50, 400),
    st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=20),
)
def test_machine_mapping_inverts_and_stays_on_the_bed(origin, ix, iy, width, height, unit_points):
    page = Page(width, height)
    bed = Bed(max(width, height), max(width, height), origin, ix, iy)
    placement = Placement.on_bed(page, bed)
    points = np.array(unit_points) * [width, height]
    machine = placement.to_machine(points)
    np.testing.assert_allclose(placement.to_page(machine), points, atol=1e-9)
    (x0, x1), (y0, y1) = placement.machine_range()
    assert (machine[:, 0] >= x0 - 1e-9).all() and (machine[:, 0] <= x1 + 1e-9).all()
    assert (machine[:, 1] >= y0 - 1e-9).all() and (machine[:, 1] <= y1 + 1e-9).all()
    # mirror images are a wiring fault, not a placement: orientation is kept (det > 0 up to signs)
    signs = (
        (-1 if ix else 1)
        * (-1 if iy else 1)
        * (-1 if origin.endswith("right") else 1)
        * (-1 if origin.startswith("top") else 1)
    )
    e = placement.to_machine(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]))
    det = np.linalg.det(np.array([e[1] - e[0], e[2] - e[0]]))
    assert np.sign(det) == signs


# --- refusing to write -------------------------------------------------------------------------


def test_out_of_bed_plan_is_refused_and_leaves_no_file(tmp_path):
    profile = load_profile("grbl-servo-a4")  # 220 x 310 bed
    plan = plan_of([np.array([[20.0, 20], [250.0, 30]])], page=Page(300.0, 300.0, name="big"))
    out = tmp_path / "drawing.gcode"
    with pytest.raises(OutOfBedError) as err:
        write_gcode(plan, profile, out)
    message = str(err.value)
    assert "X 20 .. 250" in message and "X 0 .. 220" in message and "grbl-servo-a4" in message
    assert list(tmp_path.iterdir()) == []


def test_refused_export_keeps_the_previous_file(tmp_path):
    out = tmp_path / "drawing.gcode"
    out.write_text("previous\n")
    plan = plan_of([np.array([[20.0, -5.0], [30.0, 30.0]])])  # below the page, below the bed
    with pytest.raises(OutOfBedError, match=r"Y -5 \.\. 30"):
        write_gcode(plan, load_profile("grbl-servo-a4"), out)
    assert out.read_text() == "previous\n"
    assert [p.name for p in tmp_path.iterdir()] == ["drawing.gcode"]


def test_not_a_number_is_refused(tmp_path):
    plan = plan_of([np.array([[20.0, np.nan], [30.0, 30.0]])])
    with pytest.raises(PencilbotError, match="not numbers"):
        write_gcode(plan, load_profile("grbl-servo-a4"), tmp_path / "x.gcode")
    assert list(tmp_path.iterdir()) == []


def test_missing_folder_is_a_clear_error(tmp_path):
    plan = plan_of([np.array([[20.0, 20.0], [30.0, 30.0]])])
    with pytest.raises(PencilbotError, match="does not exist"):
        write_gcode(plan, load_profile("grbl-servo-a4"), tmp_path / "nope" / "x.gcode")


def test_failed_rename_leaves_no_temporary_file(tmp_path):
    blocker = tmp_path / "drawing.gcode"
    blocker.mkdir()  # a folder where the file should go: the final rename fails
    plan = plan_of([np.array([[20.0, 20.0], [30.0, 30.0]])])
    with pytest.raises(PencilbotError, match=r"cannot write .*drawing.gcode"):
        write_gcode(plan, load_profile("grbl-servo-a4"), blocker)
    assert [p.name for p in tmp_path.iterdir()] == ["drawing.gcode"] and blocker.is_dir()


def test_write_gcode_writes_what_gcode_lines_returns(tmp_path):
    plan = plan_of([np.array([[20.0, 20.0], [30.0, 30.0], [40.0, 20.0]])])
    profile = load_profile("marlin-servo-a4")
    summary = write_gcode(plan, profile, tmp_path / "x.gcode", source="s")
    text = (tmp_path / "x.gcode").read_text(encoding="ascii")
    assert text.splitlines() == gcode_lines(plan, profile, source="s")
    assert summary.bytes == len(text) and summary.lines == len(text.splitlines())
    assert summary.paths == 1 and summary.placement.rotated


def test_a_path_ending_at_home_needs_no_return_move():
    profile = load_profile("grbl-servo-a4")
    lines = gcode_lines(plan_of([np.array([[20.0, 20.0], [10.0, 10.0], [0.0, 0.0]])]), profile)
    assert lines.count("G1 X0 Y0") == 1 and "G0 X0 Y0" not in lines
    assert lines[-2:] == ["M3 S30", "G4 P0.15"]


# --- the virtual GRBL runs it --------------------------------------------------------------------


@pytest.mark.parametrize("name", ["grbl-servo-a4", "grbl-z-a3", "grblhal-servo-a3"])
def test_virtual_grbl_accepts_every_line_and_draws_the_plan(name):
    from sim.gcode.firmware import Firmware
    from sim.gcode.machine import Machine

    profile = load_profile(name)
    rng = np.random.default_rng(7)
    paths = [rng.uniform([20, 20], [190, 277], (rng.integers(2, 6), 2)) for _ in range(40)]
    plan = plan_of(paths)
    board = Firmware(Machine(profile))
    board.take_output()  # banner
    for line in gcode_lines(plan, profile):
        board.receive(line.encode("ascii") + b"\n")
        assert board.take_output() == b"ok\r\n", line  # send-and-wait: one ok per line
    board.machine.finish()
    placement = Placement.on_bed(plan.page, profile.bed)
    assert len(board.machine.strokes) == len(paths)
    for drawn, path in zip(board.machine.strokes, paths):
        np.testing.assert_allclose(placement.to_page(drawn), path, atol=0.5e-3 + 1e-9, rtol=0)


@pytest.mark.parametrize(("travel", "draw"), [(600, 12000.25), (7200, 3000), (1e4, 1)])
def test_feeds_of_any_length_are_written_whole(travel, draw):
    marlin = load_profile("marlin-servo-a4")
    profile = dataclasses.replace(
        marlin, motion=dataclasses.replace(marlin.motion, travel_feed=travel, draw_feed=draw)
    )
    reading = check_program(
        plan_of([np.array([[20.0, 20], [30, 30]]), np.array([[40.0, 40], [50, 50]])]), profile
    )
    assert reading.feeds_written == [travel, draw, travel, draw, travel]


def test_a_pen_command_longer_than_every_move_is_written_whole():
    # The writer lays every line into one table as wide as its longest line: a profile's pen
    # command may be the longest (here with a comment), and must not be cut.
    z = load_profile("grbl-z-a3")
    down = "G1 Z{down} F300 (lower the pen slowly onto the paper)"
    z = dataclasses.replace(z, pen=dataclasses.replace(z.pen, down_command=down))
    lines = gcode_lines(plan_of([np.array([[20.0, 20], [30, 30]])]), z)
    written = [line for line in lines if line.startswith("G1 Z")]
    assert written and all(line.endswith("(lower the pen slowly onto the paper)") for line in written)
    assert max(map(len, written)) > max(len(line) for line in lines if line.startswith(("G0 X", "G1 X")))


@pytest.mark.parametrize("first", [True, False])
def test_a_repeated_point_gives_no_move_even_at_the_start_of_the_plan(first):
    # A drawing move that lands where the pen already is goes nowhere: not written, also when
    # it is the second point of the first path of the plan.
    profile = load_profile("grbl-servo-a4")
    doubled = np.array([[20.0, 20.0], [20.0, 20.0], [30.0, 30.0]])
    other = np.array([[50.0, 50.0], [60.0, 50.0]])
    lines = gcode_lines(plan_of([doubled, other] if first else [other, doubled]), profile)
    draws = [line for line in lines if line.startswith("G1 X")]
    assert len(draws) == 2  # one drawing move per path
