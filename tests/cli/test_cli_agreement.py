"""demo, stat (of the plan and of the G-code), the G-code header and the virtual plotter agree on
plot time and pen-up travel, for every shipped plotter profile: one estimate (planning.stats) and
one motion model behind them."""

from __future__ import annotations

import json
import re

import pytest
from skimage import data
from skimage import io as skio

from pencilbot.cli import main
from pencilbot.machine.profile import list_profiles, load_profile


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    path = tmp_path_factory.mktemp("agreement") / "camera.png"
    skio.imsave(path, data.camera()[::4, ::4])
    return path


def run_json(argv, capsys) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def _hpgl(name: str) -> bool:
    return getattr(load_profile(name).firmware, "flow", "") == "polled"


@pytest.mark.parametrize("name", [n for n in list_profiles() if not _hpgl(n)])
def test_demo_stat_header_and_simulator_agree(name, photo, tmp_path, capsys):
    out = tmp_path / "demo"
    demo = run_json(["demo", str(photo), "-o", str(out), "--profile", name, "--page", "A5", "--json"], capsys)
    header = (out / "drawing.gcode").read_text()
    header_seconds = int(re.search(r"; estimated time: \d+:\d\d:\d\d \((\d+) s\)", header).group(1))
    header_up = float(re.search(r"; pen down [\d.]+ mm, pen up ([\d.]+) mm", header).group(1))
    stat = run_json(["stat", str(out / "plan.svg"), "--profile", name, "--json"], capsys)["total"]
    # stat of the G-code reads back the paths the pen draws, whatever the pen and the dialect
    gcode = run_json(["stat", str(out / "drawing.gcode"), "--profile", name, "--json"], capsys)["total"]
    for key in ("paths", "lifts", "segments"):
        assert gcode[key] == stat[key]
    for key in ("pen_down_mm", "pen_up_mm", "seconds"):
        assert gcode[key] == pytest.approx(stat[key], rel=1e-4, abs=0.05)

    assert abs(header_seconds - demo["estimated_s"]) <= 0.5 + 1e-9  # the header says "372 s" for 372.4
    assert header_up / 1000 == pytest.approx(demo["pen_up_m"], abs=0.005 + 1e-9)  # (metres to 0.01)
    # stat reads the plan back from its SVG (coordinates to the µm): the same figures
    assert stat["seconds"] == pytest.approx(demo["estimated_s"], rel=1e-3, abs=0.05)
    assert stat["pen_up_mm"] == pytest.approx(header_up, rel=1e-4, abs=0.05)
    if load_profile(name).firmware.capabilities.realtime_protocol:
        # The virtual plotter's planner runs the same rules move by move, Z moves included.
        assert demo["simulated_s"] == pytest.approx(demo["estimated_s"], rel=0.05)
        assert demo["simulated_s"] == pytest.approx(demo["estimated_s"], rel=0.005)  # in fact closer still
        assert demo["simulated_pen_up_m"] == pytest.approx(demo["pen_up_m"], abs=0.01)
    elif load_profile(name).firmware.capabilities.host_motion:
        # An EBB: the host plans with the same model; LM phases of at least 4 ms and the step grid
        # cost a little, the board's 25 kHz ticks time it.
        assert demo["simulated_s"] == pytest.approx(demo["estimated_s"], rel=0.02)
        assert demo["simulated_pen_up_m"] == pytest.approx(demo["pen_up_m"], abs=0.01)
    else:
        assert demo["simulated_s"] is None  # its firmware is not one the virtual plotter speaks


@pytest.mark.parametrize("name", [n for n in list_profiles() if _hpgl(n)])
def test_hpgl_demo_stat_and_simulator_agree(name, photo, tmp_path, capsys):
    """An HP-GL plotter: demo writes drawing.hpgl; stat of it reads back the plan's strokes (to a
    plotter unit) and the virtual plotter takes the estimated time."""
    out = tmp_path / "demo"
    demo = run_json(
        ["demo", "--input", str(photo), "--out", str(out), "--profile", name, "--page", "A5", "--json"],
        capsys,
    )
    stat = run_json(["stat", str(out / "plan.svg"), "--profile", name, "--json"], capsys)["total"]
    hpgl = run_json(["stat", str(out / "drawing.hpgl"), "--profile", name, "--json"], capsys)["total"]
    assert hpgl["paths"] == stat["paths"] and hpgl["lifts"] == stat["lifts"]
    assert hpgl["pen_down_mm"] == pytest.approx(stat["pen_down_mm"], rel=2e-3)
    assert stat["seconds"] == pytest.approx(demo["estimated_s"], rel=1e-3, abs=0.05)
    assert demo["simulated_s"] == pytest.approx(demo["estimated_s"], rel=0.02)
