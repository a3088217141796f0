"""A stop signal to the studio during a plot (SIGINT, SIGTERM, SIGHUP, SIGQUIT), as a closed
terminal or a ``kill`` sends it: the server ends, the plot stops with the pen up, its G-code and
journal (status stopped) are kept out of the server's removed folder, the way to resume is said,
and the resume draws exactly what an uninterrupted plot draws.

The server runs in this process's main thread (only it gets signals); a helper thread starts the
plot through the page's API on the virtual plotter and, once lines are drawn, sends the signal.
A signal the studio does not catch reaches the test's own handler and fails the test.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import threading
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import sim
from pencilbot import api
from pencilbot.driver import draw
from pencilbot.driver.journal import load_journal
from pencilbot.driver.stop_signals import STOP_SIGNALS
from sim import protocol_sim

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "driver"))  # the drawings' yardstick
from segments import drawing_differences

PROFILE = "grbl-servo-a4"
SIGNALS = [s for s in ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT") if hasattr(signal, s)]


class NotCaught(Exception):
    pass


class Plan:
    """Stands for the planner's full stage: the library's plan of a small photo."""

    def __init__(self, plan):
        self.plan, self.generation, self.sketch_png = plan, 0, b""


def _guard(signum, _frame):
    raise NotCaught(signal.Signals(signum).name)


@pytest.fixture
def guarded():
    saved = {signum: signal.signal(signum, _guard) for signum in STOP_SIGNALS}
    yield
    for signum, handler in saved.items():
        signal.signal(signum, handler)


def _post(url: str, path: str, body: dict) -> dict:
    request = urllib.request.Request(url.rstrip("/") + path, data=json.dumps(body).encode(), method="POST",
                                     headers={"X-Studio": "1", "Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=60) as answer:
        return json.loads(answer.read())


@pytest.mark.parametrize("signame", SIGNALS)
def test_a_signal_to_the_studio_mid_plot_stops_it_resumably(tmp_path, monkeypatch, guarded, signame):
    from pencilbot.studio.server import prepare

    sim.register()
    for board in (f"studio-{PROFILE}", "studio-ref"):  # another test's plot on these names is not this one's
        protocol_sim.forget(board)
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "state"))
    photo = tmp_path / "bars.png"
    Image.fromarray(np.repeat(np.linspace(0, 255, 40, dtype=np.uint8)[None, :], 30, axis=0)).save(photo)
    running = prepare(None, listen_port=0, profile=PROFILE, sim_speed=20.0)
    running.studio.results["full"] = Plan(api.plan(photo, page="100x70", pen_width=1.0))
    folder = running.studio.folder
    seen: dict = {}

    def plot_then_signal():
        try:
            for _ in range(600):  # uvicorn listening (a 10 s bound)
                if running.server.started:
                    break
                threading.Event().wait(1 / 60)
            _post(running.url, "/api/plot", {"port": "sim://", "profile": PROFILE})
            session = running.studio.plotters.get("sim://")
            while (session.record.get("running") or 0) < 10 and session.active:
                running.studio.wait_change(running.studio.version, 5.0)  # woken by each progress record
            seen["gcode"] = session.gcode.read_text()
            seen["active"] = session.active
        finally:
            os.kill(os.getpid(), getattr(signal, signame))

    helper = threading.Thread(target=plot_then_signal)
    helper.start()
    said = running.serve()
    helper.join()
    assert seen["active"], "the plot ended before the signal"
    assert not folder.exists()  # the upload, the G-code and the journal of the server's folder went
    assert len(said) == 1 and "stopped with the pen up" in said[0] and "Resume with: pencilbot draw --resume" in said[0]
    plotter = protocol_sim.plotter(f"studio-{PROFILE}")  # the studio's virtual plotter of this profile
    plotter.firmware.finish()
    assert not plotter.machine.pen_down
    journal_file = Path(said[0].split("--resume ", 1)[1].split(" --port")[0])
    journal = load_journal(journal_file)
    assert journal.status == "stopped" and Path(journal.gcode).read_text() == seen["gcode"]

    draw(journal.gcode, f"sim://studio-{PROFILE}", resume=str(journal_file))
    plotter.firmware.finish()
    resumed = list(plotter.machine.strokes)
    draw(journal.gcode, f"sim://studio-ref?profile={PROFILE}", profile=PROFILE)
    reference = protocol_sim.plotter("studio-ref")
    reference.firmware.finish()
    assert drawing_differences(resumed, list(reference.machine.strokes), 0.001) == []
    protocol_sim.forget(f"studio-{PROFILE}")
    protocol_sim.forget("studio-ref")
