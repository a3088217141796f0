"""HP-GL senders no one here wrote, against the virtual 7475A on a pseudo-terminal (as
`pencilbot sim-serve --profile hp7475a` serves it): hpgl-buddy plotting its "house" scene, one
4036-byte PD instruction (four times the buffer: the plotter must run it as it arrives), and
chiplotle3 drawing a square and a circle. What each drew is compared with its input."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

from firmware_protocol import hpgl as protocol
from sim.protocol_sim import plotter_from_options
from sim.pty_server import PtyServer

BIN = os.path.dirname(sys.executable)


def test_hpgl_buddy_plots_one_instruction_four_times_the_buffer(tmp_path):
    house = tmp_path / "house.hpgl"
    subprocess.run(
        [os.path.join(BIN, "hpgl-buddy"), "demo", "--scene", "house", "--out", str(house)],
        check=True,
        capture_output=True,
        timeout=60,
    )
    found, _ = protocol.split_instructions(house.read_bytes())
    at = next(k for k, i in enumerate(found) if i.mnemonic == "PD")
    pd, start = found[at], found[at - 1].params  # PU to the first point, then the one PD
    assert len(pd.encode()) > 4 * 1000
    plotter = plotter_from_options({"profile": "hp7475a"})
    with PtyServer(plotter) as served:
        done = subprocess.run(
            [
                os.path.join(BIN, "hpgl-buddy"),
                "plot",
                str(house),
                "--port",
                served.path,
                "--model",
                "hp7475a",
                "--buffer-stall-timeout",
                "5",
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert done.returncode == 0, done.stderr[-800:]
    board = plotter.board
    board.finish()
    assert "ESC.L" in done.stderr or "1024" in done.stderr  # it asked the buffer's size and was told
    assert board.overflows == 0
    (stroke,) = board.strokes
    want = np.vstack([start[-2:], np.reshape(pd.params, (-1, 2))])
    want = want[np.r_[True, np.any(want[1:] != want[:-1], axis=1)]]  # a repeated point is no move
    assert np.array_equal(np.rint(stroke / plotter.profile.paper.unit_mm), want)  # every point, exactly


CHIPLOTLE = """
import serial, sys
from chiplotle3 import hpgl
from chiplotle3.plotters.hp7475a import HP7475A
plotter = HP7475A(serial.Serial(sys.argv[1], 9600, timeout=2))
plotter.select_pen(1)
plotter.write(hpgl.PU([(1000, 1000)]))
plotter.write(hpgl.PD([(3000, 1000), (3000, 3000), (1000, 3000), (1000, 1000)]))
plotter.write(hpgl.PU([(5000, 2000)]))
plotter.write(hpgl.CI(800))
plotter.select_pen(0)
print(plotter.actual_position)
"""


def test_chiplotle3_draws_a_square_and_a_circle(tmp_path):
    plotter = plotter_from_options({"profile": "hp7475a"})
    env = {**os.environ, "HOME": str(tmp_path)}  # chiplotle3 keeps its settings in ~/.chiplotle
    with PtyServer(plotter) as served:
        done = subprocess.run(
            [sys.executable, "-c", CHIPLOTLE, served.path],
            input="\n\n",
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert done.returncode == 0, done.stderr[-800:]
    assert "[Coordinate([5000, 2000]), 0]" in done.stdout  # OA: back at the circle's centre, pen up
    board = plotter.board
    board.finish()
    square, circle = (s / plotter.profile.paper.unit_mm for s in board.strokes)
    assert np.rint(square).tolist() == [[1000, 1000], [3000, 1000], [3000, 3000], [1000, 3000], [1000, 1000]]
    assert np.allclose(np.hypot(*(circle - [5000, 2000]).T), 800, atol=0.75) and len(circle) == 73
    assert board.error == 0 and not board.unemulated
