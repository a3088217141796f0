"""An EBB job's queue: G4 dwells become the board's timed waits (``SM,ms,0,0``), and firmware
3.x gets a deeper motion FIFO (``CU,4``, within ``QU,2``) while 2.x keeps its one place."""

import numpy as np
import pytest

import sim
from pencilbot.driver import draw
from pencilbot.driver.ebb.plot import FIFO_DEPTH
from sim import protocol_sim

PROFILE = "axidraw-v3"
DRAWING = [
    "G21",
    "G90",
    "M280 P0 S60",
    "G0 X20 Y20",
    "M280 P0 S30",
    "G1 X60 Y20 F3000",
    "G1 X60 Y40",
    "M280 P0 S60",
    "G4 P0.5",
    "G0 X80 Y60",
    "M280 P0 S30",
    "G4 P1.25",
    "G1 X100 Y60",
    "M280 P0 S60",
    "G0 X0 Y0",
]


def _run(name, lines, options=""):
    sim.register()
    protocol_sim.forget(name)
    draw(lines, f"sim://{name}?profile={PROFILE}{options}", profile=PROFILE)
    board = protocol_sim.plotter(name)
    board.firmware.finish()
    return board


def test_dwells_are_the_boards_timed_waits_where_the_file_has_them():
    plain = _run("ebb-q-plain", [line for line in DRAWING if not line.startswith("G4")])
    dwelt = _run("ebb-q-dwell", DRAWING)
    log = [c for c in dwelt.firmware.log if c[:2] in ("LM", "SM", "SP")]  # the queue's commands
    assert [c for c in log if c.startswith("SM")] == ["SM,500,0,0", "SM,1250,0,0"]
    # each after the pen command before it, before the move after it
    first, second = log.index("SM,500,0,0"), log.index("SM,1250,0,0")
    assert log[first - 1].startswith("SP,1") and log[first + 1].startswith("LM")
    assert log[second - 1].startswith("SP,0") and log[second + 1].startswith("LM")
    assert dwelt.seconds - plain.seconds == pytest.approx(1.75, abs=1e-3)
    assert all(np.array_equal(a, b) for a, b in zip(dwelt.drawn(), plain.drawn()))
    assert len(dwelt.drawn()) == len(plain.drawn()) == 2


@pytest.mark.parametrize("version, depth", [("3.0.3", FIFO_DEPTH), ("2.8.1", 1)])
def test_the_fifo_is_deepened_only_on_firmware_that_has_it(version, depth):
    board = _run(f"ebb-q-{version}", DRAWING, f"&firmware={version}")
    log = board.firmware.log
    assert board.firmware.fifo_size == depth
    assert ("QU,2" in log, f"CU,4,{FIFO_DEPTH}" in log) == (
        (True, True) if version == "3.0.3" else (False, False)
    )
    reference = _run("ebb-q-ref", DRAWING)
    assert all(np.array_equal(a, b) for a, b in zip(board.drawn(), reference.drawn()))
    assert len(board.drawn()) == 2
