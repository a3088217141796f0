"""`pencilbot stat`: per-layer and total figures from a plan SVG, as a table or JSON."""

import json
import subprocess
import sys

import numpy as np
import pytest

from pencilbot.cli import main
from pencilbot.machine.profile import DEFAULT_PROFILE, load_profile
from pencilbot.planning.stats import estimate
from pencilbot.planning.plan import Layer, Page, Plan
from pencilbot.export.svg import read_svg, write_svg


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
        (["stat", "missing.svg"], "does not exist"),
        (["stat", "{plan}", "--profile", "no-such-plotter"], "no plotter profile"),
    ],
)
def test_user_errors_print_one_line_and_exit_2(plan_file, tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    argv = [a.replace("{plan}", str(plan_file)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
