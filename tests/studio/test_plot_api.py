"""Plotting through the studio's API on the virtual plotter: the pen test, one plot per plotter,
the buttons, and a stopped plot resumed from its journal."""

from __future__ import annotations

import time

import numpy as np
import pytest
from PIL import Image
from starlette.testclient import TestClient

from pencilbot import api
from pencilbot.studio.app import create_app
from pencilbot.studio.state import Studio

PORT, OWN = 8765, {"X-Studio": "1"}


class Plan:
    """Stands for the planner's full stage: the library's plan of a small photo."""

    def __init__(self, plan):
        self.plan, self.generation, self.sketch_png = plan, 0, b""


@pytest.fixture
def studio(tmp_path):
    photo = tmp_path / "bars.png"
    Image.fromarray(np.repeat(np.linspace(0, 255, 40, dtype=np.uint8)[None, :], 30, axis=0)).save(photo)
    made = Studio(sim_speed=5.0)
    made.results["full"] = Plan(api.plan(photo, page="A5", pen_width=1.0))
    yield made
    for session in made.plotters.sessions.values():
        session.press("stop")
        if session.thread is not None:
            session.thread.join(timeout=20)
    made.close()


@pytest.fixture
def client(studio):
    return TestClient(
        create_app(studio, port=PORT, names=("testserver",)), base_url=f"http://testserver:{PORT}"
    )


def wait(condition, what, timeout=60.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return
        time.sleep(0.05)
    pytest.fail(f"waited for {what}")


@pytest.mark.parametrize(
    "profile", ["grbl-z-a3", "grbl-servo-a4", "grblhal-servo-a3", "axidraw-v3", "hp7475a"]
)
def test_the_machine_controls_of_every_family_on_the_virtual_plotter(client, profile):
    def press(action, **extra):
        response = client.post(
            f"/api/machine/{action}", json={"port": "sim://", "profile": profile, **extra}, headers=OWN
        )
        assert response.status_code == 200, response.text
        return response.json()["said"]

    said = press("pen-down")
    assert said in ("the pen is down", "pen down sent")
    if said == "the pen is down":  # a plotter that reports its pen: the toggle lifts it
        assert press("pen-toggle") == "the pen is up"
    assert press("pen-up") in ("the pen is up", "pen up sent")
    walked = press("walk", dx=10, dy=5)
    assert walked.startswith("walked"), walked
    assert press("home").startswith("home"), profile
    if profile == "hp7475a":  # no motor command: said in plain words, not a 500
        refused = client.post(
            "/api/machine/motors-off", json={"port": "sim://", "profile": profile}, headers=OWN
        )
        assert refused.status_code == 400 and "no command that switches its motors" in refused.json()["error"]
    else:
        assert "motors off" in press("motors-off")
    refused = client.post(
        "/api/machine/walk", json={"port": "sim://", "profile": profile, "dx": 500}, headers=OWN
    )
    assert refused.status_code == 400 and "smaller steps" in refused.json()["error"]
    client.post(
        "/api/machine/motors-on", json={"port": "sim://", "profile": profile}, headers=OWN
    )  # as found


def test_one_plot_per_plotter_its_buttons_and_a_resume(client, studio):
    response = client.post("/api/plot", json={"port": "sim://"}, headers=OWN)
    assert response.status_code == 200 and response.json()["status"] == "running"
    session = studio.plotters.get("sim://")
    assert client.post("/api/plot", json={"port": "sim://"}, headers=OWN).status_code == 409
    assert client.post("/api/machine/pen-down", json={"port": "sim://"}, headers=OWN).status_code == 409
    wait(lambda: (session.record.get("running") or 0) > 15, "the machine draws")
    drawing = client.get("/api/plot-paths", params={"port": "sim://"}).json()
    assert drawing["bed"] == [220.0, 310.0] and len(drawing["lines"]) * 2 == len(drawing["points"]) > 0

    assert client.post("/api/plot/pause", json={"port": "sim://"}, headers=OWN).status_code == 200
    wait(lambda: session.record.get("state", "").startswith("paused"), "the hold shown")
    assert client.post("/api/plot/pause", json={"port": "sim://"}, headers=OWN).status_code == 200
    wait(lambda: not session.record.get("state", "").startswith("paused"), "it runs again")

    assert client.post("/api/plot/stop", json={"port": "sim://"}, headers=OWN).status_code == 200
    session.thread.join(timeout=30)
    assert session.status == "stopped" and "pen raised" in session.message and session.resumable
    stopped_at = session.record.get("running")

    assert client.post("/api/plot/resume-job", json={"port": "sim://"}, headers=OWN).status_code == 200
    wait(
        lambda: (session.record.get("running") or 0) > (stopped_at or 0) or not session.active,
        "the resumed plot",
    )
    assert session.status == "running" or session.status == "done"
    assert client.post("/api/plot/nonsense", json={"port": "sim://"}, headers=OWN).status_code == 404


def test_downloads_are_the_exporters_output(client, studio):
    from pencilbot.export.gcode import gcode_program
    from pencilbot.export.svg import svg_text
    from pencilbot.machine.profile import load_profile

    plan = studio.results["full"].plan
    svg = client.get("/api/download/plan.svg")
    assert svg.status_code == 200 and svg.text == svg_text(plan)
    assert svg.headers["content-disposition"] == 'attachment; filename="plan.svg"'
    gcode = client.get("/api/download/plan.gcode", params={"profile": "grbl-z-a3"})
    assert gcode.status_code == 200 and gcode.content == gcode_program(plan, load_profile("grbl-z-a3"))
    assert client.get("/api/download/sketch.png").status_code == 404  # no sketch planned


def test_a_lost_position_asks_for_a_re_zero_that_the_page_answers(studio, tmp_path):
    """A reset in motion loses the position; the resume asks the page to jog the pen to a mark
    (a dialog), takes its jogs, and a give-up is one plain message."""
    from pencilbot.studio.plotting import Plotters

    gcode = tmp_path / "job.gcode"
    api.export_gcode(studio.results["full"].plan, "grbl-servo-a4", gcode)
    plotters = Plotters()
    session = plotters.start(
        "sim://",
        "sim://studio-rezero?profile=grbl-servo-a4&realtime=20&faults=abort@60",
        "grbl-servo-a4",
        gcode,
    )
    session.thread.join(timeout=60)
    assert (
        session.status == "stopped"
        and "(ALARM:3: the board was reset while moving, so it lost its position)" in session.message
    ), session.message
    assert session.resumable and 'Press "Resume the stopped plot"' in session.message
    for terminal_words in (
        str(tmp_path),
        "pencilbot draw",
        "--resume",
        ".gcode",
        "Machine position",
    ):  # written for a terminal
        assert terminal_words not in session.message, session.message
    plotters.resume("sim://")
    wait(lambda: session.prompt is not None or not session.active, "the re-zero dialog")
    assert session.prompt["kind"] == "rezero" and "Jog the raised pen" in session.prompt["text"]
    session.press("jog", 1.0, 0.0)
    session.press("give up")
    session.thread.join(timeout=30)
    assert session.status == "stopped" and session.message.startswith("re-zero abandoned")
    assert session.prompt is None


def test_a_double_click_on_a_pen_change_answers_only_that_pen_change(studio, client, tmp_path):
    """Two presses of "Done, go on" for the first pen change (a double click: both name the
    dialog shown) must leave the second pen change waiting for its own answer."""
    from pencilbot.machine.pens import load_pens

    photo = tmp_path / "bars.png"
    Image.fromarray(np.repeat(np.linspace(0, 255, 40, dtype=np.uint8)[None, :], 30, axis=0)).convert(
        "RGB"
    ).save(photo)
    whole = tmp_path / "cmyk.gcode"
    api.export_gcode(
        api.plan(photo, page="A5", pen_width=1.0, pens=load_pens("cmyk")), "grbl-servo-a4", whole
    )
    lines = whole.read_text().splitlines()
    changes = [i for i, line in enumerate(lines) if line.startswith("M0 (pen change")]
    gcode = tmp_path / "two-pens.gcode"  # the start, the first two pen changes with a few moves each, the end
    gcode.write_text(
        "\n".join(lines[: changes[0] + 12] + lines[changes[1] - 2 : changes[1] + 12] + lines[-6:]) + "\n"
    )
    session = studio.plotters.start(
        "sim://", "sim://studio-pens?profile=grbl-servo-a4&realtime=20", "grbl-servo-a4", gcode
    )
    wait(lambda: session.prompt is not None or not session.active, "the first pen change")
    first = session.prompt
    assert first is not None and "insert yellow" in first["text"], session.message
    for _ in range(2):
        response = client.post(
            "/api/plot/go", json={"port": "sim://", "prompt": first.get("id")}, headers=OWN
        )
        assert response.status_code == 200
    wait(
        lambda: (session.prompt or first).get("id") != first.get("id") or not session.active,
        "the second pen change",
    )
    assert session.active and session.prompt is not None and "insert cyan" in session.prompt["text"], (
        session.message
    )
    client.post("/api/plot/go", json={"port": "sim://", "prompt": session.prompt.get("id")}, headers=OWN)
    session.thread.join(timeout=60)
    assert session.status == "done", session.message
