"""The port is ours: a second `draw` on a port in use stops at once with one message, and the
first job, which holds the port, draws exactly what it would alone."""

import subprocess
import sys
import threading

import numpy as np
import pytest
from test_stream_sim import PROFILE, drawing, fresh

from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from sim import protocol_sim
from sim.gcode.plotter import VirtualPlotter
from sim.pty_server import PtyServer

SAFETY = 60.0  # s: a bound for a broken run only; no result depends on it
BUSY = "is in use by another program (another pencilbot draw?) — wait for it or close it"


PEN_CHANGE = "M0 (pen change: insert red)"


@pytest.fixture
def long_job(tmp_path):
    """A plot with a pen change halfway (after a pen-up line: it changes no stroke), written to a
    file, and its lines as the board takes them."""
    lines = drawing(strokes=30, per_stroke=8)
    half = next(i for i in range(len(lines) // 2, len(lines)) if lines[i] == "M3 S30") + 1
    lines = [*lines[:half], PEN_CHANGE, *lines[half:]]
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    return path, [clean_line(line) for line in lines]


class HeldAtThePenChange:
    """Someone at the plotter who changes the pen when the test says so: until then the first
    job holds the port, paused at its pen change (no wall clock decides when the second sender
    tries)."""

    def __init__(self):
        self.paused, self.go_on = threading.Event(), threading.Event()

    def pause(self, prompt):
        self.paused.set()
        assert self.go_on.wait(SAFETY), "the test never let the first job go on"

    def jog_to_mark(self, prompt, mark, jog):
        raise AssertionError(prompt)


def segments(plotter: VirtualPlotter) -> list[tuple]:
    """Every pen-down segment the board drew, ends rounded to 1 µm, sorted (a multiset)."""
    plotter.firmware.finish()
    pairs = [np.round(np.hstack([s[:-1, :2], s[1:, :2]]), 3) for s in plotter.machine.strokes if len(s) > 1]
    return sorted(map(tuple, np.vstack(pairs).tolist()))


def alone(lines: list[str]) -> list[tuple]:
    """What the job draws with nobody else at the port (without its pen change)."""
    url, name = fresh()
    draw([line for line in lines if line != clean_line(PEN_CHANGE)], url, profile=PROFILE, wake_wait=0.2)
    return segments(protocol_sim.plotter(name))


def test_second_draw_on_a_sim_port_in_use_is_refused_and_the_first_is_exact(long_job):
    path, lines = long_job
    url, name = fresh()
    errors, hand = [], HeldAtThePenChange()
    first = threading.Thread(
        target=lambda: _catch(errors, draw, path, url, profile=PROFILE, wake_wait=0.2, operator=hand)
    )
    first.start()
    assert hand.paused.wait(SAFETY)  # the first job holds the port, paused
    with pytest.raises(PlotError) as info:
        draw(path, f"sim://{name}", profile=PROFILE, wake_wait=0.2)
    assert str(info.value) == f"sim://{name} {BUSY}"
    hand.go_on.set()
    first.join(SAFETY)
    assert len(errors) == 1 and not isinstance(errors[0], Exception), errors
    plotter = protocol_sim.plotter(name)
    assert [line for line in plotter.firmware.accepted_lines() if line] == lines
    assert segments(plotter) == alone(lines)


def test_second_draw_on_a_pty_in_use_is_one_message_and_the_first_is_exact(long_job):
    path, lines = long_job
    plotter = VirtualPlotter(load_profile(PROFILE), baud=115200)
    errors, hand = [], HeldAtThePenChange()
    with PtyServer(plotter) as server:
        first = threading.Thread(
            target=lambda: _catch(errors, draw, path, server.path, profile=PROFILE, operator=hand)
        )
        first.start()
        assert hand.paused.wait(SAFETY)  # the first job holds the port, paused
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
        hand.go_on.set()
        first.join(SAFETY)
    assert second.returncode != 0 and second.stdout == ""
    assert second.stderr == f"pencilbot: error: {server.path} {BUSY}\n"
    assert len(errors) == 1 and not isinstance(errors[0], Exception), errors
    # Nothing of the second sender reached the board, and its open did not reset it mid-job.
    assert [line for line in plotter.firmware.accepted_lines() if line] == lines
    assert segments(plotter) == alone(lines)


def test_a_port_is_free_again_once_its_job_ends(long_job):
    _path, lines = long_job
    lines = [line for line in lines if line != clean_line(PEN_CHANGE)]
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
