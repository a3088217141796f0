"""The commands a person types at the plotter (pen, pen trial, align, walk, home) and draw's
one-run options, SVG layers, copies, plotter names and supply check, through the CLI, checked
against the virtual plotter's own record."""

from __future__ import annotations

import io
import os
import subprocess
import sys

import numpy as np
import pytest

import sim
from pencilbot.cli import main
from pencilbot.configs_io import user_folder
from pencilbot.machine.profile import load_profile
from sim import protocol_sim

sim.register()

LAYERED = """<?xml version="1.0" encoding="UTF-8"?>
<svg width="120mm" height="90mm" viewBox="0 0 120 90" version="1.1"
   xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" xmlns="http://www.w3.org/2000/svg">
  <g inkscape:label="1 frame" inkscape:groupmode="layer" id="layer1">
    <path style="fill:none;stroke:#000;stroke-width:0.3" d="M 10,10 L 110,10 L 110,80 L 10,80 Z"/>
  </g>
  <g inkscape:label="2 triangle" inkscape:groupmode="layer" id="layer2">
    <path style="fill:none;stroke:#000;stroke-width:0.3" d="M 40,60 L 80,60 L 60,25 Z"/>
    <path style="fill:none;stroke:#000;stroke-width:0.3" d="M 55,50 L 65,50"/>
  </g>
  <g inkscape:label="3 notes" inkscape:groupmode="layer" id="layer3">
    <path style="fill:none;stroke:#000;stroke-width:0.3" d="M 15,85 L 30,85"/>
  </g>
</svg>
"""
#: Layer 2 in machine mm on an AxiDraw (home top-left, Y towards the front: the SVG's own axes).
TRIANGLE = np.array([[40, 60], [80, 60], [60, 25], [40, 60]], float)
BAR = np.array([[55, 50], [65, 50]], float)


@pytest.fixture
def name(request):
    key = "cli-" + "".join(c if c.isalnum() else "-" for c in request.node.name)
    yield key
    protocol_sim.forget(key)


def _one_error_line(err: str) -> str:
    lines = [line for line in err.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("pencilbot: error: ") and "Traceback" not in err, err
    return lines[0]


def test_pen_toggle_on_an_ebb_sim_serve_pty_reads_the_pen_back(tmp_path):
    """The real CLI in its own process, the board on a pseudo-terminal."""
    from sim.ebb.plotter import VirtualEbb
    from sim.pty_server import PtyServer

    plotter = VirtualEbb(load_profile("axidraw-v3"))
    cli = [sys.executable, "-m", "pencilbot.cli", "pen", "toggle", "--profile", "axidraw-v3"]
    env = {**os.environ, "PENCILBOT_CONFIG_DIR": str(user_folder())}
    with PtyServer(plotter, reset_on_open=False) as server:
        said = []
        for _ in range(2):
            done = subprocess.run(
                [*cli, "--port", server.path], capture_output=True, text=True, timeout=60, env=env
            )
            assert done.returncode == 0, done.stderr
            said.append((done.stdout.strip(), plotter.firmware.pen_up))
    assert said == [
        ("pen toggle: the plotter reports the pen down", False),
        ("pen toggle: the plotter reports the pen up", True),
    ]


@pytest.mark.parametrize(
    "profile,where", [("axidraw-v3", "X10 Y5"), ("grbl-servo-a4", "X10 Y5"), ("hp7475a", "X10 Y5")]
)
def test_walk_align_and_home_commands(profile, where, name, capsys):
    port = ["--port", f"sim://{name}", "--profile", profile]
    assert main(["walk", "--x", "10", "--y", "5", *port]) == 0
    assert capsys.readouterr().out.strip() == f"walked X10 Y5 mm; the carriage is at {where}"
    assert main(["home", *port]) == 0
    assert capsys.readouterr().out.strip() == "home: the carriage is at X0 Y0"
    code = main(["align", *port])
    out, err = capsys.readouterr()
    if profile == "hp7475a":
        assert code == 3 and "no command that switches its motors off" in _one_error_line(err)
    else:
        assert code == 0 and out.startswith("motors off")


def test_the_pen_trial_keeps_the_accepted_heights_in_the_users_profile(name, capsys, monkeypatch):
    monkeypatch.setattr(sys, "stdin", io.StringIO("35\n+\n\n75\n\n"))
    assert main(["pen", "trial", "--port", f"sim://{name}", "--profile", "axidraw-v3"]) == 0
    out = capsys.readouterr().out
    saved = user_folder() / "plotters" / "axidraw-v3.toml"
    assert f"saved pen down 40, pen up 75 to {saved}" in out
    text = saved.read_text()
    assert "up = 75\ndown = 40\n" in text and "# percent of the servo range" in text  # comments kept
    assert (load_profile("axidraw-v3").pen.down, load_profile("axidraw-v3").pen.up) == (40, 75)
    assert protocol_sim.plotter(name).firmware.pen_up  # left raised


def test_quitting_the_trial_saves_nothing(name, capsys, monkeypatch):
    monkeypatch.setattr(sys, "stdin", io.StringIO("35\nq\n"))
    assert main(["pen", "trial", "--port", f"sim://{name}", "--profile", "axidraw-v3"]) == 0
    assert "nothing saved" in capsys.readouterr().out
    assert not (user_folder() / "plotters" / "axidraw-v3.toml").exists()


def _config(text: str) -> None:
    user_folder().mkdir(parents=True, exist_ok=True)
    (user_folder() / "config.toml").write_text(text)


def test_a_plotter_named_in_the_config_and_an_unknown_name(name, capsys):
    _config(f'[ports]\nstudio = "sim://{name}"\n')
    assert main(["pen", "down", "--port", "studio", "--profile", "axidraw-v3"]) == 0
    assert not protocol_sim.plotter(name).firmware.pen_up
    assert main(["pen", "up", "--port", "attic", "--profile", "axidraw-v3"]) == 3
    line = _one_error_line(capsys.readouterr().err)
    assert "no plotter named 'attic': config.toml names studio under [ports]" in line


def test_a_bad_ports_table_is_one_line(capsys):
    _config("[ports]\nstudio = 3\n")
    assert main(["pen", "up", "--port", "studio"]) == 2
    assert "[ports] must hold plotter names, each a port" in _one_error_line(capsys.readouterr().err)


def _drawn(name):
    return [np.asarray(s, float)[:, :2] for s in protocol_sim.plotter(name).machine.strokes]


def test_draw_an_svgs_layer_2_twice(tmp_path, name, capsys):
    svg = tmp_path / "drawing.svg"
    svg.write_text(LAYERED)
    args = [
        "draw",
        str(svg),
        "--profile",
        "axidraw-v3",
        "--layer",
        "2",
        "--copies",
        "2",
        "--port",
        f"sim://{name}",
    ]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "layer 2 triangle" in err and "copy 1 of 2 drawn" in err
    drawn = _drawn(name)
    assert len(drawn) == 4
    for got, want in zip(drawn, [TRIANGLE, BAR, TRIANGLE, BAR]):
        assert (
            _off_polyline(got, want) < 0.02 and _off_polyline(want, got) < 0.02
        )  # both ways: all of it, only it


def _off_polyline(points, line) -> float:
    """How far the farthest of ``points`` is from the polyline ``line`` (mm)."""
    a, b = line[:-1][None], line[1:][None]
    p = points[:, None]
    t = np.clip(((p - a) * (b - a)).sum(-1) / np.maximum(((b - a) ** 2).sum(-1), 1e-12), 0, 1)
    return float(np.hypot(*(p - (a + t[..., None] * (b - a))).transpose(2, 0, 1)).min(axis=1).max())


def test_draw_layer_that_is_not_there_is_one_line(tmp_path, name, capsys):
    svg = tmp_path / "drawing.svg"
    svg.write_text(LAYERED)
    assert main(["draw", str(svg), "--profile", "axidraw-v3", "--layer", "7", "--port", f"sim://{name}"]) != 0
    assert "has no layer 7 (its layers: '1 frame', '2 triangle', '3 notes')" in _one_error_line(
        capsys.readouterr().err
    )


def _gcode(tmp_path, profile):
    svg = tmp_path / "drawing.svg"
    svg.write_text(LAYERED)
    out = tmp_path / "drawing.gcode"
    assert main(["export", str(svg), "-o", str(out), "--profile", profile, "-q"]) == 0
    return out


def test_one_run_pen_height_and_speed_on_an_ebb(tmp_path, name, capsys):
    job = _gcode(tmp_path, "axidraw-v3")
    args = [
        "draw",
        str(job),
        "--profile",
        "axidraw-v3",
        "--port",
        f"sim://{name}",
        "-q",
        "--pen-down-height",
        "42",
        "--speed-down",
        "1200",
    ]
    assert main(args) == 0
    board = protocol_sim.plotter(name).firmware
    servo = load_profile("axidraw-v3").ebb.servo_position(42)
    assert f"SC,5,{servo}" in board.log
    plain = f"{name}-plain"
    assert main(["draw", str(job), "--profile", "axidraw-v3", "--port", f"sim://{plain}", "-q"]) == 0
    slower, usual = protocol_sim.plotter(name).seconds, protocol_sim.plotter(plain).seconds
    protocol_sim.forget(plain)
    assert slower > 1.5 * usual  # 1200 mm/min drawing instead of 3300


def test_one_run_values_on_a_written_gcode_file_for_grbl_are_refused(tmp_path, name, capsys):
    job = _gcode(tmp_path, "grbl-servo-a4")
    assert main(["draw", str(job), "--port", f"sim://{name}", "--speed-down", "900"]) == 3
    assert "--speed-down change the moves and pen commands pencilbot writes for GRBL" in _one_error_line(
        capsys.readouterr().err
    )


def test_an_ebb_without_motor_power_is_refused_before_anything_moves(tmp_path, name, capsys):
    job = _gcode(tmp_path, "axidraw-v3")
    with sim.protocol_sim.Serial(f"sim://{name}?profile=axidraw-v3") as port:
        port.plotter.firmware.supply_volts = 0.0
    assert main(["draw", str(job), "--profile", "axidraw-v3", "--port", f"sim://{name}"]) == 3
    line = _one_error_line(capsys.readouterr().err)
    assert "the plotter's motors have no power: its board reads 0.3 V at the power jack" in line
    assert not any(cmd.startswith(("LM", "SP", "EM")) for cmd in protocol_sim.plotter(name).firmware.log)


def test_a_resumed_job_keeps_its_one_run_values(tmp_path, name, capsys):
    import json

    from pencilbot.driver.journal import journal_path

    job = _gcode(tmp_path, "axidraw-v3")
    port = f"sim://{name}?profile=axidraw-v3&faults=error@30"
    assert (
        main(["draw", str(job), "--profile", "axidraw-v3", "--port", port, "-q", "--pen-down-height", "42"])
        == 3
    )
    record = json.loads(journal_path(job).read_text())
    assert record["options"]["overrides"] == {"pen": {"down": 42.0}}
    board = protocol_sim.plotter(name).firmware
    board.log.clear()
    assert main(["draw", "--resume", str(journal_path(job)), "--port", f"sim://{name}", "-q"]) == 0
    servo = load_profile("axidraw-v3").ebb.servo_position(42)
    assert f"SC,5,{servo}" in board.log
