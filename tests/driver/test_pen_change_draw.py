"""A colour job as `pencilbot export` writes it, drawn by the driver: it pauses at each pen change,
asks for that pen by name in load order, waits for the answer, and draws every pen's strokes
exactly once, over ``sim://`` and over a pty (the file-descriptor path of a USB adapter)."""

import numpy as np
import pytest
from segments import assert_same_drawing
from test_stream_sim import HandOnTheMachine, drawn

from pencilbot.driver import draw
from pencilbot.export.gcode import write_gcode
from pencilbot.machine.pens import load_pens
from pencilbot.machine.profile import load_profile
from pencilbot.planning.plan import Layer, Page, Plan
from sim.gcode.plotter import VirtualPlotter
from sim.pty_server import PtyServer

PROFILE = "grbl-servo-a4"
PENS = ("yellow", "magenta", "black")  # cmyk's load order, light to dark


@pytest.fixture(scope="module")
def colour_job(tmp_path_factory):
    """Three pens, a hatched square each, exported for the profile (pen changes included)."""
    inks = {pen.name: pen for pen in load_pens("cmyk").pens}
    layers = []
    for k, name in enumerate(PENS):
        x = 20.0 + 40.0 * k
        lines = [np.array([[x, 50.0 + y], [x + 20.0, 50.0 + y]]) for y in np.arange(0.0, 10.0, 1.0)]
        layers.append(
            Layer(f"{name}-hatch", lines, pen_width=0.5, role="hatch", pen=name, color=inks[name].color)
        )
    path = tmp_path_factory.mktemp("pens") / "colour.gcode"
    write_gcode(Plan(Page(150.0, 150.0, margin=10.0, name="test"), layers), load_profile(PROFILE), path)
    return path


@pytest.fixture(scope="module")
def reference(colour_job):
    operator = HandOnTheMachine(None)
    draw(colour_job, "sim://pens-reference", profile=PROFILE, wake_wait=0.2, operator=operator)
    return drawn("pens-reference")


@pytest.mark.parametrize("over", ["sim", "pty"])
def test_draw_pauses_for_each_pen_by_name_and_draws_every_stroke_once(colour_job, reference, over):
    operator = HandOnTheMachine(None)
    plotter = VirtualPlotter(load_profile(PROFILE), realtime=200)
    if over == "sim":
        draw(colour_job, "sim://pens-sim?realtime=200", profile=PROFILE, wake_wait=0.2, operator=operator)
        strokes = drawn("pens-sim")
        from sim import protocol_sim

        plotter = protocol_sim.plotter("pens-sim")
    else:
        with PtyServer(plotter) as server:
            draw(colour_job, server.path, profile=PROFILE, wake_wait=0.2, timeout=2.0, operator=operator)
        plotter.firmware.finish()
        strokes = plotter.machine.strokes
    assert operator.prompts == [f"paused: pen change: insert {name}" for name in PENS]
    assert_same_drawing(strokes, reference)
    # Each pen's strokes came after its own pause: one group of strokes per pen change.
    assert sorted(set(plotter.machine.stroke_pauses)) == [1, 2, 3]
