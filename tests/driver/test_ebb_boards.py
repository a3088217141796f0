"""EBB boards that differ from the AxiDraw V3 on firmware 3.0.3: firmware 2.8.1's stop reply,
the NextDraw 8511's narrow-band servo on its own pin, and ports where the board is not an EBB
(another board, or nothing answering)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from real_plan import plan_lines
from segments import drawing_differences

import sim
from pencilbot.driver import draw
from pencilbot.errors import PlotError
from sim import protocol_sim

PLAN = list(plan_lines("axidraw-v3"))
TOLERANCE = 0.0125  # mm, as the EBB fault matrix
_names = itertools.count()


def _drawn(name: str) -> list[np.ndarray]:
    plotter = protocol_sim.plotter(name)
    plotter.firmware.finish()
    return list(plotter.drawn())


@pytest.fixture(scope="module")
def reference():
    sim.register()
    draw(PLAN, "sim://ebb-281-ref?firmware=2.8.1", profile="axidraw-v3")
    log = protocol_sim.plotter("ebb-281-ref").firmware.log
    strike = next(
        k
        for k in range(len(log) // 2, len(log))
        if log[k].startswith("LM")
        and next(c for c in reversed(log[:k]) if c.startswith("SP,")).startswith("SP,0")
    )
    yield _drawn("ebb-281-ref"), strike + 1
    protocol_sim.forget("ebb-281-ref")


@pytest.mark.parametrize("signal_code", ["", ":15"])
def test_a_stop_on_firmware_2_8_1_lifts_the_pen_and_resumes_exactly(tmp_path, reference, signal_code):
    """2.8.1 answers ES with five fields (interrupted, the FIFO's steps, the steps left): read as
    the answer, not as noise, so the pen goes up and the stop point is known."""
    strokes, strike = reference
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(PLAN) + "\n")
    name = f"ebb-281-{next(_names)}"
    with pytest.raises(PlotError) as stopped:
        draw(
            path,
            f"sim://{name}?profile=axidraw-v3&firmware=2.8.1&faults=interrupt@{strike}{signal_code}",
            profile="axidraw-v3",
            timeout=0.5,
        )
    assert "the pen stopped at X" in str(stopped.value), str(stopped.value)
    board = protocol_sim.plotter(name).firmware
    es = board.log.index("ES")
    assert any(c.startswith("SP,1") for c in board.log[es:]) and board.pen_up  # the pen was lifted
    board.faults.clear()
    draw(path, f"sim://{name}", resume=f"{path}.job.json")
    assert drawing_differences(_drawn(name), strokes, TOLERANCE) == []


def test_the_nextdraw_8511_pen_moves_on_its_own_pin(tmp_path):
    """The narrow-band servo is on RB2 and runs on one 3 ms channel: an SP without pin (RB1)
    never moves it, and nothing would be drawn."""
    sim.register()
    lines = [
        "G21",
        "G90",
        "M280 P0 S60",
        "G0 X20 Y20",
        "M280 P0 S40",
        "G1 X60 Y20 F3000",
        "G1 X60 Y40",
        "M280 P0 S60",
        "G0 X0 Y0",
    ]
    protocol_sim.forget("nd8511")
    draw(lines, "sim://nd8511?profile=nextdraw-8511", profile="nextdraw-8511")
    board = protocol_sim.plotter("nd8511")
    strokes = _drawn("nd8511")
    assert len(strokes) == 1
    assert np.allclose(strokes[0][[0, -1]], [[20, 20], [60, 40]], atol=0.02)
    assert board.firmware.servos.slots == 1 and board.firmware.servos.period == pytest.approx(0.003)


LINES = ["G21", "G90", "M280 P0 S60", "G0 X20 Y20", "M280 P0 S30", "G1 X60 Y20 F3000", "M280 P0 S60"]


def test_an_ebb_job_on_another_board_is_one_clear_line(tmp_path):
    sim.register()
    path = tmp_path / "job.gcode"
    path.write_text("\n".join(LINES) + "\n")
    with pytest.raises(PlotError) as refused:
        draw(path, "sim://?profile=grbl-servo-a4", profile="axidraw-v3", timeout=0.5)
    text = str(refused.value)
    assert "is not an EBB" in text and "error:" in text and "profile axidraw-v3" in text and "\n" not in text


def test_an_ebb_job_on_a_silent_port_is_one_clear_line(tmp_path):
    import os

    path = tmp_path / "job.gcode"
    path.write_text("\n".join(LINES) + "\n")
    master, slave = os.openpty()  # a port where nothing answers
    device = os.ttyname(slave)
    try:
        with pytest.raises(PlotError) as refused:
            draw(path, device, profile="axidraw-v3", timeout=0.5)
    finally:
        os.close(master)
        os.close(slave)
    assert str(refused.value).startswith(f"nothing answered on {device} within 0.5 s")
