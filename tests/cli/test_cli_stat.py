"""`pencilbot stat`: per-layer and total figures from a plan SVG, as a table or JSON."""

import json
import subprocess
import sys

import numpy as np
import pytest

from pencilbot.cli import main
from pencilbot.export.svg import write_svg
from pencilbot.export.svg_read import read_svg
from pencilbot.machine.profile import DEFAULT_PROFILE, load_profile
from pencilbot.planning.plan import Layer, Page, Plan
from pencilbot.planning.stats import estimate


@pytest.fixture
def plan_file(tmp_path):
    rng = np.random.default_rng(5)
    hatch = [np.array([[20.0, y], [180.0, y]]) for y in np.arange(30, 100, 2.0)]
    edges = [rng.uniform(20, 190, 2) + np.cumsum(rng.normal(0, 3, (4, 2)), 0) for _ in range(50)]
    plan = Plan(Page(210, 297, 15, "A4"), [Layer("hatch-0", hatch), Layer("edges", edges)])
    path = tmp_path / "plan.svg"
    write_svg(plan, path)
    return path


def test_json_matches_the_estimate_of_the_file(plan_file, capsys):
    assert main(["stat", str(plan_file), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    want = estimate(read_svg(plan_file), load_profile(DEFAULT_PROFILE)).as_dict()
    assert list(out["layers"]) == ["hatch-0", "edges"]
    assert out["layers"]["hatch-0"]["paths"] == 35 and out["layers"]["edges"]["segments"] == 150
    assert out["total"]["lifts"] == 85
    for key, value in want["total"].items():
        assert out["total"][key] == pytest.approx(value)


def test_profile_speeds_change_the_time(plan_file, capsys):
    main(["stat", str(plan_file), "--json"])
    default = json.loads(capsys.readouterr().out)["total"]
    main(["stat", str(plan_file), "--json", "--profile", "grbl-z-a3"])
    profiled = json.loads(capsys.readouterr().out)["total"]
    want = estimate(read_svg(plan_file), load_profile("grbl-z-a3")).total
    assert profiled["seconds"] == pytest.approx(want.seconds)
    assert profiled["seconds"] != pytest.approx(default["seconds"])
    assert profiled["pen_down_mm"] == pytest.approx(default["pen_down_mm"])


def test_table_lists_every_layer_and_the_total(plan_file):
    # the installed console script, as a user runs it
    done = subprocess.run(
        [sys.executable, "-m", "pencilbot.cli", "stat", str(plan_file)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].split() == ["layer", "pen-down", "pen-up", "lifts", "paths", "segments", "time"]
    assert [l.split()[0].strip("-") or "rule" for l in lines[1:]] == ["hatch-0", "edges", "rule", "total"]
    total = lines[-1].split()
    seconds = estimate(read_svg(plan_file), load_profile(DEFAULT_PROFILE)).total.seconds
    h, m, s = (int(v) for v in total[-1].split(":"))
    assert abs(h * 3600 + m * 60 + s - seconds) <= 0.5
    assert total[5:8] == ["85", "85", "185"]  # after "x.xx m" twice


@pytest.mark.parametrize(
    "argv, message",
    [
        (["stat", "missing.svg"], "no such file"),
        (["stat", "{plan}", "--profile", "no-such-plotter"], "no plotter profile"),
    ],
)
def test_user_errors_print_one_line_and_exit_2(plan_file, tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    argv = [a.replace("{plan}", str(plan_file)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


FOREIGN_GCODE = """(made by another tool: inches, relative moves, a Z pen, comments, an arc)
G20 G91
G0 Z0.1 ; pen up
G0 X1 Y1
G1 Z-0.2 F20
G1 X1
G1 Y1
G0 Z0.2
G0 X-1
G1 Z-0.2
G2 X0.5 Y0.5 I0.25 J0.25
G0 Z0.2
G90
G0 X0 Y0
"""

Z_INCH_PROFILE = """name = "z-inch"
dialect = "grbl"
[bed]
width = 200.0
height = 200.0
origin = "bottom-left"
[motion]
draw_feed = 1000.0
travel_feed = 2000.0
acceleration = 500.0
junction_deviation = 0.01
[pen]
kind = "z"
up = 2.54
down = -2.54
up_command = "G0 Z2.54"
down_command = "G1 Z-2.54 F500"
up_delay = 0.0
down_delay = 0.0
[gcode]
decimals = 4
header = "G21"
footer = ""
"""


def test_stat_reads_another_tools_gcode(tmp_path, capsys):
    (tmp_path / "other.nc").write_text(FOREIGN_GCODE)
    (tmp_path / "z.toml").write_text(Z_INCH_PROFILE)
    assert main(["stat", str(tmp_path / "other.nc"), "--profile", str(tmp_path / "z.toml"), "--json"]) == 0
    total = json.loads(capsys.readouterr().out)["total"]
    # Two pen-down runs: an L of 2 in, and the arc as a chord to its end point.
    assert total["paths"] == 2 and total["segments"] == 3
    assert total["pen_down_mm"] == pytest.approx((2 + 0.5 * 2**0.5) * 25.4, abs=1e-6)
    # Pen up: home → (1, 1) in, (2, 2) → (1, 2), (1.5, 2.5) → home.
    assert total["pen_up_mm"] == pytest.approx((2**0.5 + 1 + 8.5**0.5) * 25.4, abs=1e-6)


def test_stat_of_gcode_whose_pen_never_goes_down_says_which_profile_to_give(tmp_path, capsys):
    path = tmp_path / "z.gcode"
    # On grbl-z-a3's bed (homed at the far corner: X and Y run negative), as stat checks like draw.
    path.write_text("G21\nG90\nG0 Z5\nG0 X-10 Y-10\nG1 Z0\nG1 X-20\nG0 Z5\n")
    assert main(["stat", str(path)]) == 2  # the default profile's pen is a servo on M3 S…
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the pen never goes down" in err and "--profile" in err
    assert main(["stat", str(path), "--profile", "grbl-z-a3", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["total"]["pen_down_mm"] == pytest.approx(10)
