"""`pencilbot ports` names what answers on each port, over pseudo-terminals served like
`pencilbot sim-serve` serves them, without moving anything; `draw --port auto` refuses when no
plotter answers."""

from __future__ import annotations

from pencilbot.cli import main
from pencilbot.driver.ports import PortInfo, probe_all
from sim.protocol_sim import plotter_from_options
from sim.pty_server import PtyServer


def test_ports_names_each_virtual_board(capsys):
    boards = {
        name: plotter_from_options({"profile": name})
        for name in ("hp7475a", "grbl-servo-a4", "grblhal-servo-a3")
    }
    with (
        PtyServer(boards["hp7475a"]) as hpgl,
        PtyServer(boards["grbl-servo-a4"]) as grbl,
        PtyServer(boards["grblhal-servo-a3"]) as grblhal,
    ):
        assert main(["ports", hpgl.path, grbl.path, grblhal.path]) == 0
        out = dict(line.split("\t")[::2] for line in capsys.readouterr().out.splitlines())
        assert out[hpgl.path].startswith("HP-GL 7475A")
        assert out[grbl.path].startswith("GRBL 1.1h")
        assert out[grblhal.path].startswith("grblHAL")
    # Nothing moved, nothing was drawn, no pen was taken.
    assert boards["hp7475a"].board.strokes == [] and boards["hp7475a"].board.pen == 0
    assert boards["grbl-servo-a4"].machine.position[:2] == (0.0, 0.0)


def test_a_port_that_is_not_there_is_said_so():
    (info,) = probe_all([PortInfo("/dev/nonexistent-pencilbot")])
    assert info.plotter is None and info.error.startswith("cannot open")


def test_draw_port_auto_without_a_plotter_says_what_to_do(tmp_path, capsys, monkeypatch):
    from pencilbot.driver import ports

    monkeypatch.setattr(ports, "list_ports", list)
    job = tmp_path / "d.hpgl"
    job.write_bytes(b"IN;SP1;PU0,0;PD40,0;PU;SP0;\n")
    assert main(["draw", str(job), "--profile", "hp7475a", "--port", "auto"]) != 0
    assert "no plotter answered" in capsys.readouterr().err


def test_a_grblhal_board_whose_greeting_was_missed_is_still_grblhal(monkeypatch):
    # No reset as the port opens, and the greetings not listened for: only the answer to $I
    # tells it from GRBL (a loaded host can miss the greeting).
    from pencilbot.driver import ports

    monkeypatch.setattr(ports, "PROBES", tuple(p for p in ports.PROBES if p[2]))  # the questions only
    for name, family in (("grblhal-servo-a3", "grblHAL"), ("grbl-servo-a4", "GRBL")):
        with PtyServer(plotter_from_options({"profile": name}), reset_on_open=False) as server:
            (info,) = probe_all([PortInfo(server.path)])
        assert info.plotter == family, info
        assert info.version.startswith("1.1f" if family == "grblHAL" else "1.1h"), info  # (banner or $I)
