"""The driver over a real pseudo-terminal (the same file-descriptor path as a USB adapter)."""

import json

import pytest
from test_stream_sim import PROFILE, HandOnTheMachine, assert_same_drawing, job  # noqa: F401 (job: a shared fixture)

from pencilbot.cli import main
from pencilbot.driver import draw
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from sim.faults import Faults
from sim.gcode.plotter import VirtualPlotter
from sim.pty_server import PtyServer


def accepted(plotter):
    return [line for line in plotter.firmware.accepted_lines() if line]


def test_exactly_once_over_a_pty_with_json_progress(job, capsys):
    path, lines = job
    plotter = VirtualPlotter(load_profile(PROFILE), baud=115200, realtime=50)
    with PtyServer(plotter) as server:
        code = main(["draw", str(path), "--port", server.path, "--profile", PROFILE, "--json-lines"])
    assert code == 0
    assert accepted(plotter) == lines and plotter.firmware.lost_bytes == 0
    records = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert records[-1]["event"] == "done"
    progress = [r for r in records if r["event"] == "progress"]
    assert progress[-1]["line"] == progress[-1]["total"] == len(lines)
    assert progress[-1]["percent"] == 100.0
    assert all(r["state"] in ("Idle", "Run", "") for r in progress)
    assert [r["line"] for r in progress] == sorted(r["line"] for r in progress)


def test_pty_vanishing_mid_job_then_resume_on_a_new_pty(job):
    path, lines = job
    reference = VirtualPlotter(load_profile(PROFILE))
    with PtyServer(reference) as server:
        draw(path, server.path, profile=PROFILE, wake_wait=0.2)

    plotter = VirtualPlotter(load_profile(PROFILE), faults=Faults.parse("drop@40"))
    with PtyServer(plotter) as server, pytest.raises(PlotError) as info:
        draw(path, server.path, profile=PROFILE, wake_wait=0.2, timeout=2.0)
    assert "serial port vanished" in str(info.value) and "--resume" in str(info.value)

    plotter.firmware.faults.at.clear()
    plotter.firmware.link_dropped = False  # plugged back in, on a new device path
    with PtyServer(plotter) as server:
        # The board reset as the port opened: it counts from 0, 0 again, so the resume asks the
        # user to jog to a mark before it draws.
        draw(path, server.path, resume=f"{path}.job.json", wake_wait=0.2, operator=HandOnTheMachine(plotter))
    plotter.firmware.finish()
    reference.firmware.finish()
    assert_same_drawing(plotter.machine.strokes, reference.machine.strokes)
    assert set(lines) <= set(accepted(plotter))
    assert plotter.machine.strokes


def test_a_hold_from_the_machine_shows_paused_and_waits_past_the_timeout_for_its_cycle_start(job, capsys):
    import os
    import threading

    from waiting import until

    from pencilbot.driver.gcode.session import POLL_INTERVAL

    path, lines = job
    plotter = VirtualPlotter(load_profile(PROFILE), realtime=50, faults=Faults.parse("hold@30"))
    with PtyServer(plotter, reset_on_open=False) as server:

        def press_cycle_start_on_the_machine():
            firmware = plotter.firmware
            until(lambda: firmware.state() == "Hold:0", "the hold")
            # Held until the sender's status polls (one each POLL_INTERVAL) span three timeouts.
            held_at = firmware.queries
            until(lambda: firmware.queries >= held_at + int(3 * 0.5 / POLL_INTERVAL) + 1, "the polls")
            fd = os.open(server.path, os.O_WRONLY | os.O_NOCTTY)  # another hand on the board
            os.write(fd, b"~")
            os.close(fd)

        threading.Thread(target=press_cycle_start_on_the_machine, daemon=True).start()
        code = main(
            [
                "draw",
                str(path),
                "--port",
                server.path,
                "--profile",
                PROFILE,
                "--json-lines",
                "--timeout",
                "0.5",
            ]
        )
    assert code == 0
    assert accepted(plotter) == lines
    records = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert any(r.get("state") == "paused: feed hold on the machine" for r in records)
