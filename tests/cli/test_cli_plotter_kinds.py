"""A job meets a plotter of its kind, or one clear line says it did not: ``--port auto`` with
only another kind of plotter answering, ``simulate`` of an HP-GL file without ``--profile``,
and ``draw -v`` (what the board said it is) on every family."""

from __future__ import annotations

import pytest

from pencilbot.cli import main
from sim.protocol_sim import plotter_from_options
from sim.pty_server import PtyServer

HPGL = b"IN;SP1;PU400,400;PD4400,400,4400,2400;PU;SP0;\n"
GCODE = "G21\nG90\nM280 P0 S60\nG0 X20 Y20\nM280 P0 S30\nG1 X60 Y20 F3000\nM280 P0 S60\n"


def test_port_auto_with_only_a_plotter_of_another_kind_says_so(tmp_path, capsys, monkeypatch):
    from pencilbot.driver import ports

    job = tmp_path / "d.gcode"
    job.write_text(GCODE)
    with PtyServer(plotter_from_options({"profile": "grbl-servo-a4"})) as grbl:
        monkeypatch.setattr(ports, "list_ports", lambda: [ports.PortInfo(grbl.path)])
        assert main(["draw", str(job), "--profile", "axidraw-v3", "--port", "auto", "-q"]) != 0
    err = capsys.readouterr().err.strip()
    assert "no EBB plotter answered for profile axidraw-v3" in err and grbl.path in err and "GRBL" in err
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "d.gcode.job.json").exists()


@pytest.mark.parametrize("name", ["drawing.hpgl", "drawing.txt"])
def test_simulate_picks_an_hpgl_plotter_for_hpgl(tmp_path, capsys, name):
    """By the file's name, or by its first bytes when the name says nothing."""
    job = tmp_path / name
    job.write_bytes(HPGL)
    out = tmp_path / "out.png"
    assert main(["simulate", str(job), "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "1 pen-down strokes" in said and "on hp7475a" in said and out.is_file()


@pytest.mark.parametrize(
    "profile, suffix, program, board",
    [
        ("hp7475a", ".hpgl", HPGL, "board: 7475A"),
        ("axidraw-v3", ".gcode", GCODE.encode(), "board: EBBv13_and_above EB Firmware Version 3.0.3"),
        (
            "grbl-servo-a4",
            ".gcode",
            GCODE.replace("M280 P0 S60", "M5").replace("M280 P0 S30", "M3 S1000").encode(),
            "board: Grbl 1.1h",
        ),
    ],
)
def test_draw_verbose_says_what_answered_on_every_family(tmp_path, capsys, profile, suffix, program, board):
    job = tmp_path / f"d{suffix}"
    job.write_bytes(program)
    assert main(["draw", str(job), "--profile", profile, "--port", "sim://", "-v"]) == 0
    err = capsys.readouterr().err
    assert board in err and f"profile {profile}" in err
    assert not (tmp_path / f"d{suffix}.job.json").exists()  # done: no job left to block the next draw
    assert main(["draw", str(job), "--profile", profile, "--port", "sim://", "-q"]) == 0
