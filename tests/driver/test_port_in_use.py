"""The port is ours: a second `draw` on a port in use stops at once with one message, and the
first job, which holds the port, draws exactly what it would alone."""

import subprocess
import sys
import threading

import numpy as np
import pytest
from test_stream_sim import PROFILE, drawing, fresh

from pencilbot.cli import main
from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from sim import protocol_sim
from sim.gcode.plotter import VirtualPlotter
from sim.pty_server import PtyServer

BUSY = "is in use by another program (another pencilbot draw?) — wait for it or close it"


@pytest.fixture
def long_job(tmp_path):
    """A plot of about 27 s of machine time: long enough to try a second sender."""
    lines = drawing(strokes=30, per_stroke=8)
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    return path, [clean_line(line) for line in lines]


def segments(plotter: VirtualPlotter) -> list[tuple]:
    """Every pen-down segment the board drew, ends rounded to 1 µm, sorted (a multiset)."""
    plotter.firmware.finish()
    pairs = [np.round(np.hstack([s[:-1, :2], s[1:, :2]]), 3) for s in plotter.machine.strokes if len(s) > 1]
    return sorted(map(tuple, np.vstack(pairs).tolist()))


def alone(lines: list[str]) -> list[tuple]:
    url, name = fresh()
    draw(lines, url, profile=PROFILE, wake_wait=0.2)
    return segments(protocol_sim.plotter(name))


def started(plotter: VirtualPlotter, worker: threading.Thread) -> None:
    """Wait until the first job is streaming (some lines accepted), while it runs."""
    while worker.is_alive() and len(plotter.firmware.accepted_lines()) < 20:
        worker.join(0.01)
    assert worker.is_alive(), "the first job ended before the second sender tried"


def test_second_draw_on_a_sim_port_in_use_is_refused_and_the_first_is_exact(long_job):
    path, lines = long_job
    url, name = fresh("realtime=20")
    errors = []
    first = threading.Thread(target=lambda: _catch(errors, draw, path, url, profile=PROFILE, wake_wait=0.2))
    first.start()
    plotter = None
    while plotter is None and first.is_alive():
        plotter = protocol_sim._PLOTTERS.get(name)
        first.join(0.01)
    started(plotter, first)
    with pytest.raises(PlotError) as info:
        draw(path, f"sim://{name}", profile=PROFILE, wake_wait=0.2)
    assert str(info.value) == f"sim://{name} {BUSY}"
    assert first.is_alive()  # refused at once, while the first job still holds the port
    first.join(60)
    assert len(errors) == 1 and not isinstance(errors[0], Exception), errors
    assert [line for line in plotter.firmware.accepted_lines() if line] == lines
    assert segments(plotter) == alone(lines)


def test_second_draw_on_a_pty_in_use_is_one_message_and_the_first_is_exact(long_job):
    path, lines = long_job
    # 5x real time: about 5 s of plotting, so the second process (Python's start-up included)
    # tries the port while the first job holds it, even on a busy machine.
    plotter = VirtualPlotter(load_profile(PROFILE), baud=115200, realtime=5)
    errors = []
    with PtyServer(plotter) as server:
        first = threading.Thread(
            target=lambda: _catch(
                errors, main, ["draw", str(path), "--port", server.path, "--profile", PROFILE, "-q"]
            )
        )
        first.start()
        started(plotter, first)
        other = path.with_name("another.gcode")  # another job (the same file's own journal would refuse it)
        other.write_bytes(path.read_bytes())
        second = subprocess.run(
            [
                sys.executable,
                "-m",
                "pencilbot.cli",
                "draw",
                str(other),
                "--port",
                server.path,
                "--profile",
                PROFILE,
            ],
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert first.is_alive()  # the second gave up at once, not after waiting on the board
        first.join(60)
    assert second.returncode != 0 and second.stdout == ""
    assert second.stderr == f"pencilbot: error: {server.path} {BUSY}\n"
    assert errors == [0]
    # Nothing of the second sender reached the board, and its open did not reset it mid-job.
    assert [line for line in plotter.firmware.accepted_lines() if line] == lines
    assert segments(plotter) == alone(lines)


def test_a_port_is_free_again_once_its_job_ends(long_job):
    _path, lines = long_job
    url, name = fresh()
    draw(lines, url, profile=PROFILE, wake_wait=0.2)
    draw(lines, f"sim://{name}", profile=PROFILE, wake_wait=0.2)  # no "in use": the first closed it
    assert len([line for line in protocol_sim.plotter(name).firmware.accepted_lines() if line]) == 2 * len(
        lines
    )


def _catch(results, function, *args, **kwargs):
    """Run ``function`` and keep what it returned, or the exception it raised."""
    try:
        results.append(function(*args, **kwargs))
    except Exception as exc:  # noqa: BLE001 - reported by the test's assertions
        results.append(exc)
