"""`pencilbot export` end to end: a real photo or plan SVG in, G-code a third-party parser and the
virtual GRBL accept out; every user mistake one message, exit 2, no file."""

import subprocess
import sys

import numpy as np
import pytest
import skimage.data
from gcodeparser import parse_gcode_lines
from PIL import Image
from skimage.transform import resize

from pencilbot.cli import main
from pencilbot.configs_io import config_folder
from pencilbot.export.svg import write_svg
from pencilbot.machine.profile import list_profiles, load_profile
from pencilbot.planning.plan import Layer, Page, Plan


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    """A small real photo (camera man, 160 px) so planning takes well under a second."""
    path = tmp_path_factory.mktemp("in") / "camera.png"
    pixels = resize(skimage.data.camera(), (160, 160), anti_aliasing=True)
    Image.fromarray((pixels * 255).astype(np.uint8)).save(path)
    return path


@pytest.fixture(scope="module")
def plan_svg(tmp_path_factory):
    """A hand-built plan written by pencilbot's own SVG writer: a square and a diagonal."""
    square = np.array([[20.0, 20.0], [120.0, 20.0], [120.0, 120.0], [20.0, 120.0], [20.0, 20.0]])
    plan = Plan(
        Page(210.0, 297.0, name="A4"), [Layer("edges", [square, np.array([[20.0, 20.0], [120.0, 120.0]])])]
    )
    path = tmp_path_factory.mktemp("plan") / "square.svg"
    write_svg(plan, path)
    return path


def commands(path) -> list:
    """Every command line of a G-code file, parsed by gcodeparser (comments left out)."""
    return list(parse_gcode_lines(path.read_text(encoding="ascii")))


def test_console_script_exports_a_photo_that_the_virtual_grbl_draws(photo, tmp_path):
    from sim.gcode.firmware import Firmware
    from sim.gcode.machine import Machine

    out = tmp_path / "camera.gcode"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pencilbot.cli",
            "export",
            str(photo),
            "-o",
            str(out),
            "--profile",
            "grbl-servo-a4",
            "--page",
            "A5",
            "--pen-width",
            "0.8",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert f"wrote {out} for grbl-servo-a4" in proc.stdout
    text = out.read_text(encoding="ascii")
    assert f"; source: {photo}" in text and "; page: A5 148 x 210 mm" in text
    parsed = commands(out)
    downs = sum(c.command_str == "M3" and c.params["S"] == 90 for c in parsed)
    assert downs > 50 and f"{downs} paths" in proc.stdout  # one pen down per path
    assert max(map(len, text.splitlines())) <= 80
    board = Firmware(Machine(load_profile("grbl-servo-a4")))
    board.take_output()
    for line in text.splitlines():
        board.receive(line.encode("ascii") + b"\n")
        assert board.take_output() == b"ok\r\n", line
    board.machine.finish()
    drawn = np.concatenate(board.machine.strokes)
    # an A5 sheet in the bed's bottom-left corner, drawn inside its 15 mm margins
    assert drawn.min() >= 15 - 1e-9 and drawn[:, 0].max() <= 148 - 15 and drawn[:, 1].max() <= 210 - 15
    assert [p.name for p in tmp_path.iterdir()] == ["camera.gcode"]  # no temp file left


def test_plan_svg_exports_its_paths_exactly(plan_svg, tmp_path, capsys):
    out = tmp_path / "square.gcode"
    assert main(["export", str(plan_svg), "-o", str(out), "--profile", "grbl-z-a3"]) == 0
    assert "2 paths" in capsys.readouterr().out
    moves = [(c.command_str, c.params.get("X"), c.params.get("Y")) for c in commands(out) if "X" in c.params]
    # grbl-z-a3 is homed back-right with negative work space, the A4 sheet in that corner:
    # page (x, y) is machine (x - 210, y - 297)
    assert moves == [
        ("G0", -190, -277),
        ("G1", -90, -277),
        ("G1", -90, -177),
        ("G1", -190, -177),
        ("G1", -190, -277),
        ("G1", -90, -177),  # the diagonal starts where the square ended: no travel, lift kept
        ("G0", 0, 0),
    ]


def test_default_output_sits_beside_the_input_and_quiet_prints_nothing(plan_svg, tmp_path, capsys):
    copy = tmp_path / "drawing.svg"
    copy.write_bytes(plan_svg.read_bytes())
    assert main(["export", str(copy), "-q"]) == 0
    assert (tmp_path / "drawing.gcode").is_file()
    assert capsys.readouterr().out == ""


def test_several_inputs_go_into_a_folder(plan_svg, tmp_path):
    second = tmp_path / "again.svg"
    second.write_bytes(plan_svg.read_bytes())
    folder = tmp_path / "out"
    folder.mkdir()
    assert (
        main(["export", str(plan_svg), str(second), "-o", str(folder), "--profile", "marlin-servo-a4"]) == 0
    )
    assert sorted(p.name for p in folder.iterdir()) == ["again.gcode", "square.gcode"]
    assert any(c.command_str == "M280" for c in commands(folder / "again.gcode"))


def test_profile_by_file_path(plan_svg, tmp_path, monkeypatch):
    # The profile named as a short relative path: the header's comment is cut at the line limit,
    # and a long temporary folder (a pytest-xdist worker's) would cut the path it must show.
    monkeypatch.chdir(tmp_path)
    profile = "mine.toml"
    text = open_shipped("plotters/grbl-servo-a4.toml")
    (tmp_path / profile).write_text(text.replace("decimals = 3", "decimals = 1"), encoding="utf-8")
    out = tmp_path / "p.gcode"
    assert main(["export", str(plan_svg), "-o", str(out), "--profile", profile]) == 0
    assert f"; profile: {profile}\n" in out.read_text()


def open_shipped(name: str) -> str:
    return (config_folder("plotters").parent / name).read_text(encoding="utf-8")


def test_list_profiles(capsys):
    with pytest.raises(SystemExit) as done:  # as --version does: no input needed
        main(["export", "--list-profiles"])
    assert done.value.code == 0
    out = capsys.readouterr().out
    for name in list_profiles():
        assert name in out and load_profile(name).description in out


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--profile", "axidraw"], "no plotter profile named 'axidraw'"),
        (["--page", "A4"], "--page apply to photos and to other tools' SVGs only"),
        (["--pen-width", "1", "--downscale"], "--downscale apply to photos only"),
        (["-o", "{tmp}/drawing.txt"], "name the output"),
        (["-o", "{tmp}/missing/drawing.gcode"], "does not exist"),
    ],
)
def test_mistakes_with_a_plan_are_one_line_and_leave_no_file(plan_svg, tmp_path, capsys, extra, message):
    extra = [e.replace("{tmp}", str(tmp_path)) for e in extra]
    argv = ["export", str(plan_svg), *extra]
    if "-o" not in argv:
        argv += ["-o", str(tmp_path / "drawing.gcode")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error: ") and message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_bad_profile_file_is_refused_before_planning(photo, tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        open_shipped("plotters/grbl-servo-a4.toml").replace("draw_feed = 3000.0", "draw_feed = -5")
    )
    assert main(["export", str(photo), "-o", str(tmp_path / "x.gcode"), "--profile", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"plotter profile {bad}: [motion] draw_feed = -5 is invalid" in err
    assert not (tmp_path / "x.gcode").exists()


def test_page_larger_than_the_bed_is_refused_with_its_extent(photo, tmp_path, capsys):
    out = tmp_path / "a3.gcode"
    assert main(["export", str(photo), "-o", str(out), "--profile", "grbl-servo-a4", "--page", "A3"]) == 2
    err = capsys.readouterr().err
    assert "does not fit the bed of plotter profile grbl-servo-a4" in err and "X 0 .. 220" in err
    assert list(tmp_path.iterdir()) == []


def test_no_input_and_bad_pen_width(photo, tmp_path, capsys):
    assert main(["export"]) == 2
    assert "give a photo or plan SVG" in capsys.readouterr().err
    assert main(["export", str(photo), "-o", str(tmp_path / "x.gcode"), "--pen-width", "-1"]) == 2
    assert "--pen-width must be at least 0.05" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_large_photo_is_refused_or_downscaled_as_asked(photo, tmp_path, capsys):
    out = tmp_path / "small.gcode"
    assert main(["export", str(photo), "-o", str(out), "--max-pixels", "10000"]) == 2
    assert "--downscale" in capsys.readouterr().err and not out.exists()
    assert main(["export", str(photo), "-o", str(out), "--max-pixels", "10000", "--downscale", "-q"]) == 0
    assert out.is_file()


def test_an_output_in_a_missing_folder_is_refused_before_the_input_is_read(tmp_path, capsys):
    broken = tmp_path / "broken.png"
    broken.write_bytes(b"not a picture")  # were it read first, this would be the error
    assert main(["export", str(broken), "-o", str(tmp_path / "nope" / "x.gcode")]) == 2
    err = capsys.readouterr().err
    assert "folder" in err and "nope" in err and "does not exist" in err and err.count("\n") == 1
