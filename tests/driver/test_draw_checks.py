"""`draw` trusts no file: every move is checked against the profile's bed before anything is
sent (inch, relative and arc moves followed as the board runs them), the profile comes from the
file's header, and G-code from other tools (BOM, `%`, comments, G20, G91, G2/G3) draws the
picture it describes."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image
from scipy.spatial import cKDTree
from test_stream_sim import PROFILE, fresh

from pencilbot.cli import main
from pencilbot.configs_io import config_folder
from pencilbot.driver import draw
from pencilbot.driver.gcode.bed_check import check_on_bed
from pencilbot.driver.gcode.job import load_job
from pencilbot.errors import OutOfBedError
from pencilbot.export.gcode import write_gcode
from pencilbot.machine.profile import load_profile
from pencilbot.planning.plan import Layer, Page, Plan
from sim import protocol_sim

BED = load_profile(PROFILE).bed  # X 0 .. 220, Y 0 .. 310 mm


def refusal(lines, profile=PROFILE) -> str | None:
    """The bed check's message for a program, or None if every move is on the bed."""
    try:
        check_on_bed(load_job(lines, load_profile(profile)))
    except OutOfBedError as err:
        return str(err)
    return None


def test_a_move_off_the_bed_is_named_by_line_and_coordinate_and_nothing_is_sent(tmp_path):
    path = tmp_path / "far.gcode"
    path.write_text("G21\nG90\nM3 S30\nG0 X100 Y100\nG1 X400 Y500 F3000\nG0 X0 Y0\n")
    url, name = fresh()
    with pytest.raises(OutOfBedError) as info:
        draw(path, url, profile=PROFILE, wake_wait=0.2)
    assert str(info.value).startswith(
        f"line 5 of {path} ('G1X400Y500F3000') moves to X 400.000 Y 500.000 mm, off the bed of plotter "
        "profile grbl-servo-a4 (X 0 .. 220, Y 0 .. 310 mm); nothing was sent"
    )
    assert name not in protocol_sim._PLOTTERS  # the port was never opened


def test_inch_and_relative_moves_are_checked_in_millimetres():
    # 8 in = 203.2 mm fits the 220 mm bed; three relative inch steps of 3 in (228.6 mm) do not.
    assert refusal(["G20", "G0 X8 Y8"]) is None
    assert "line 5 of <lines> ('G0X3') moves to X 228.600 Y 0.000 mm" in refusal(
        ["G20", "G91", "G0 X3", "G0 X3", "G0 X3"]
    )
    # Units switched mid-file change how later words read, not where the pen is.
    assert refusal(["G21", "G0 X200", "G20", "G91", "G0 X0.5"]) == refusal(["G21", "G0 X212.7"])


@pytest.fixture(scope="module")
def narrow(tmp_path_factory):
    """The profile with a bed cut to 110 mm wide, as a TOML file."""
    path = tmp_path_factory.mktemp("profile") / "narrow.toml"
    text = (config_folder("plotters") / f"{PROFILE}.toml").read_text()
    path.write_text(
        text.replace("width = 220.0", "width = 110.0").replace(f'name = "{PROFILE}"', 'name = "narrow"')
    )
    return str(path)


def test_an_arc_bulging_off_the_bed_is_refused_though_its_ends_are_on_it(narrow):
    # A half circle from (100, 10) to (100, 50) about (100, 30), r = 20: clockwise (G2) it bulges
    # left to x = 80, counter-clockwise (G3) right to x = 120; a bed 110 mm wide takes only G2.
    start = ["G21", "G90", "G0 X100 Y10"]
    message = refusal([*start, "G3 X100 Y50 I0 J20"], profile=narrow)
    assert "line 4 of <lines> ('G3X100Y50I0J20') its arc reaches X 120.000 Y 30.000 mm" in message
    assert refusal([*start, "G2 X100 Y50 I0 J20"], profile=narrow) is None
    # By radius 20.5 (GRBL's centre: x 100 -+ 4.5): clockwise stays left either way round;
    # counter-clockwise the short way reaches x = 95.5 + 20.5, the long way (R < 0) 104.5 + 20.5.
    assert refusal([*start, "G2 X100 Y50 R20.5"], profile=narrow) is None
    assert refusal([*start, "G2 X100 Y50 R-20.5"], profile=narrow) is None
    assert "its arc reaches X 116.000 Y 30.000 mm" in refusal([*start, "G3 X100 Y50 R20.5"], profile=narrow)
    assert "its arc reaches X 125.000 Y 30.000 mm" in refusal([*start, "G3 X100 Y50 R-20.5"], profile=narrow)


@settings(max_examples=150, deadline=None)
@given(
    cx=st.floats(20, 200),
    cy=st.floats(20, 290),
    r=st.floats(1, 60),
    a0=st.floats(0, 2 * math.pi),
    sweep=st.floats(0.05, 2 * math.pi - 0.05),
    ccw=st.booleans(),
    by_radius=st.booleans(),
    inches=st.booleans(),
    relative=st.booleans(),
)
def test_any_arc_is_refused_exactly_when_its_curve_leaves_the_bed(
    cx, cy, r, a0, sweep, ccw, by_radius, inches, relative
):
    a1 = a0 + sweep if ccw else a0 - sweep
    p0 = np.array([cx + r * math.cos(a0), cy + r * math.sin(a0)])
    p1 = np.array([cx + r * math.cos(a1), cy + r * math.sin(a1)])
    curve = np.array([[cx + r * math.cos(a), cy + r * math.sin(a)] for a in np.linspace(a0, a1, 4000)])
    (x0, x1), (y0, y1) = BED.machine_range()
    margin = np.min(
        np.stack([curve[:, 0] - x0, x1 - curve[:, 0], curve[:, 1] - y0, y1 - curve[:, 1]]), axis=0
    )
    if np.min(np.abs(margin)) < 0.05 or not (x0 <= p0[0] <= x1 and y0 <= p0[1] <= y1):
        return  # too close to an edge to tell by sampling, or the start itself is off
    k = 25.4 if inches else 1.0
    end = (p1 - p0 if relative else p1) / k
    if by_radius:  # R > 0: the short way round, R < 0: the long way
        centre = f"R{(r if sweep <= math.pi else -r) / k:.9f}"
    else:
        centre = "I{:.9f}J{:.9f}".format(*((np.array([cx, cy]) - p0) / k))
    lines = [
        "G21",
        "G90",
        f"G0X{p0[0]:.9f}Y{p0[1]:.9f}",
        "G20" if inches else "G21",
        "G91" if relative else "G90",
        f"G{3 if ccw else 2}X{end[0]:.9f}Y{end[1]:.9f}{centre}F100",
    ]
    assert (refusal(lines) is not None) == bool((margin < 0).any())


def exported(tmp_path, profile: str):
    plan = Plan(Page(210.0, 297.0, name="A4"), [Layer("edges", [np.array([[30.0, 30.0], [90.0, 60.0]])])])
    path = tmp_path / f"{profile}.gcode"
    write_gcode(plan, load_profile(profile), path)
    return path


def test_the_profile_comes_from_the_file_s_header(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("PENCILBOT_PROFILE", "grbl-servo-a4")  # a default elsewhere does not override the file
    path = exported(tmp_path, "grbl-z-a3")
    url, name = fresh("profile=grbl-z-a3")
    assert main(["draw", str(path), "--port", url, "-q"]) == 0
    assert not path.with_name(path.name + ".job.json").exists()  # finished: no journal is left
    accepted = protocol_sim.plotter(name).firmware.accepted_lines()
    assert any(line.startswith(("G0Z", "G1Z")) for line in accepted)  # the Z pen's commands
    assert not any(line.startswith("M3") for line in accepted)


def test_a_profile_other_than_the_header_s_is_refused_with_what_to_do(tmp_path, capsys):
    path = exported(tmp_path, "grbl-z-a3")
    assert main(["draw", str(path), "--port", "sim://", "--profile", "grbl-servo-a4"]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"pencilbot: error: {path} was made for plotter profile grbl-z-a3 (line 1 of its header), not "
        "grbl-servo-a4: its pen commands and bed are that plotter's. Leave out --profile (or give "
        "--profile grbl-z-a3), or export the drawing again for grbl-servo-a4\n"
    )
    assert (
        main(["draw", str(path), "--port", "sim://?profile=grbl-z-a3", "--profile", "grbl-z-a3", "-q"]) == 0
    )


def test_simulate_takes_the_header_s_profile_too_and_refuses_another(tmp_path, capsys):
    path = exported(tmp_path, "grbl-z-a3")
    out = tmp_path / "z.png"
    assert main(["simulate", str(path), "-o", str(out), "--dpi", "20"]) == 0
    assert "on grbl-z-a3" in capsys.readouterr().out
    # Named, even as the default profile, it must be the file's.
    assert main(["simulate", str(path), "-o", str(out), "--profile", "grbl-servo-a4"]) == 2
    assert "was made for plotter profile grbl-z-a3" in capsys.readouterr().err


def test_a_header_naming_an_unknown_profile_asks_for_one(tmp_path, capsys):
    path = tmp_path / "theirs.gcode"
    path.write_text(
        "; pencilbot G-code for someone-elses (grbl)\n; source: x\n; profile: /nowhere/theirs.toml\nG21\n"
    )
    assert main(["draw", str(path), "--port", "sim://"]) == 2
    err = capsys.readouterr().err
    assert "made for plotter profile someone-elses" in err and "--profile" in err and "Traceback" not in err


# --- G-code from other tools ---------------------------------------------------------------------

FOREIGN = (
    b"\xef\xbb\xbf"
    + b"""%
(from a CAM tool: a BOM, tape markers, comments, inch and relative moves, arcs)
G21 G90 G17 ; millimetres, absolute
M3 S30
G0 X60 Y60
M3 S90 (pen down)
G2 X60 Y60 I0 J-25 F2000 ; a full circle, centre (60, 35), r = 25
M3 S30
G20 G90 G0 X4 Y6 ; inches: (101.6, 152.4) mm
M3 S90
G91 G1 X2 F80 ; a 2 in square, relative
Y2
X-2
Y-2
G90 G21 M3 S30
G0 X150 Y60
M3 S90
G3 X190 Y60 R20 F2000 ; counter-clockwise from the left: the lower half of a circle about (170, 60)
G3 X150 Y60 R20 ; and back over the top: the whole circle, r = 20
M3 S30
G0 X0 Y0
%
"""
)


SQUARE = np.array([[101.6, 152.4], [152.4, 152.4], [152.4, 203.2], [101.6, 203.2], [101.6, 152.4]])
CIRCLES = [((60.0, 35.0), 25.0), ((170.0, 60.0), 20.0)]


def distance_to_shapes(points: np.ndarray) -> np.ndarray:
    """Each point's distance (mm) to the nearest shape FOREIGN draws (two circles, a square)."""
    near = [np.abs(np.hypot(*(points - centre).T) - r) for centre, r in CIRCLES]
    for a, b in zip(SQUARE[:-1], SQUARE[1:]):
        t = np.clip((points - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
        near.append(np.hypot(*(points - (a + t[:, None] * (b - a))).T))
    return np.min(near, axis=0)


def shape_points() -> list[np.ndarray]:
    """Points every 0.5 mm or so along each shape."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    circles = [np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)]) for (cx, cy), r in CIRCLES]
    return [*circles, np.vstack([np.linspace(a, b, 100) for a, b in zip(SQUARE[:-1], SQUARE[1:])])]


def distance_to(points: np.ndarray, others: np.ndarray) -> np.ndarray:
    """Each point's distance (mm) to the nearest of ``others``."""
    return cKDTree(others).query(points)[0]


def test_foreign_gcode_draws_exactly_the_shapes_it_describes(tmp_path):
    path = tmp_path / "theirs.nc"
    path.write_bytes(FOREIGN)
    url, name = fresh()
    draw(path, url, profile=PROFILE, wake_wait=0.2)
    strokes = protocol_sim.plotter(name).machine.strokes
    drawn = np.vstack(
        [
            np.linspace(a, b, int(np.hypot(*(b - a)) / 0.02) + 2)  # a point every 0.02 mm
            for s in strokes
            for a, b in zip(s[:-1, :2], s[1:, :2])
        ]
    )
    # Every drawn point is on one of the shapes (arcs are chords within GRBL's $12 = 0.002 mm)...
    assert distance_to_shapes(drawn).max() < 0.005
    # ...and every shape is drawn all the way round.
    for shape in shape_points():
        assert distance_to(shape, drawn).max() < 0.015
    assert len(strokes) == 3


def test_simulate_renders_the_foreign_shapes_and_nothing_else(tmp_path):
    path = tmp_path / "theirs.nc"
    path.write_bytes(FOREIGN)
    out, dpi = tmp_path / "plot.png", 100
    assert main(["simulate", str(path), "-o", str(out), "--dpi", str(dpi), "--pen-width", "0.5", "-q"]) == 0
    dark = 1.0 - np.asarray(Image.open(out).convert("L"), dtype=np.float64) / 255.0
    rows, cols = np.nonzero(dark > 0.5)
    mm = 25.4 / dpi
    inked = np.column_stack([(cols + 0.5) * mm, BED.height - (rows + 0.5) * mm])
    # Ink lies within half a pen and a pixel of a shape; every shape is inked all round.
    assert distance_to_shapes(inked).max() < 0.25 + 1.5 * mm
    for shape in shape_points():
        assert distance_to(shape, inked).max() < 1.5 * mm


def test_stat_of_gcode_reads_it_with_the_header_s_profile(tmp_path, capsys):
    path = exported(tmp_path, "grbl-z-a3")
    assert main(["stat", str(path), "--json"]) == 0  # the default profile's servo pen would never go down
    report = json.loads(capsys.readouterr().out)
    assert report["profile"] == "grbl-z-a3" and report["total"]["pen_down_mm"] == pytest.approx(
        math.hypot(60, 30), abs=0.01
    )
