"""`pencilbot sim-serve --profile axidraw-v3` as a real EBB for a third-party client: Evil Mad
Scientist's plotink (its EBB serial and motion helpers, from PyPI) on the printed pty; and the
must-show command line, export then draw over sim://."""

import logging
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image
from plotink import ebb_motion, ebb_serial  # the test extra (pip install -e .[test])


@pytest.fixture
def served(tmp_path):
    out = tmp_path / "served.png"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "pencilbot.cli",
            "sim-serve",
            "--profile",
            "axidraw-v3",
            "--realtime",
            "0",
            "-o",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    path = proc.stdout.readline().strip()
    yield proc, path, out
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=20)


def _idle(port):
    end = time.monotonic() + 10
    while int(ebb_serial.query(port, "QG\r").strip(), 16) & 0x0F:
        assert time.monotonic() < end, "the board never came to rest"


def test_plotink_talks_to_sim_serve_as_to_a_real_board(served, caplog):
    proc, path, out = served
    assert path.startswith("/dev/")
    caplog.set_level(logging.INFO, logger="plotink")
    port = ebb_serial.testPort(path)  # plotink's own check: 'v' answered with "EBB..."
    assert port is not None
    try:
        assert ebb_serial.queryVersion(port) == "EBBv13_and_above EB Firmware Version 3.0.3\r\n"
        assert ebb_serial.min_version(port, "2.6.2") is True
        ebb_motion.sendEnableMotors(port, 1)
        ebb_motion.setPenUpPos(port, 20641)
        ebb_motion.setPenDownPos(port, 15248)
        ebb_motion.setPenDownRate(port, 1079)
        ebb_motion.sendPenDown(port, 200)
        ebb_motion.doABMove(port, 800, 0, 500)  # 10 mm along X on an AxiDraw, pen down
        ebb_motion.doABMove(port, 0, 800, 500)  # then 10 mm along Y
        ebb_motion.sendPenUp(port, 150)
        _idle(port)
        assert ebb_motion.query_steps(port) == (1600, 0)
        assert ebb_motion.QueryPenUp(port) is True
        assert ebb_serial.query(port, "QE\r") == "16,16\n"  # then plotink reads the "\rOK" line
    finally:
        ebb_serial.closePort(port)
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR]  # every reply as plotink expects
    proc.send_signal(signal.SIGINT)
    _stdout, stderr = proc.communicate(timeout=20)
    assert proc.returncode == 0, stderr
    ink = 1 - np.asarray(Image.open(out).convert("L"), dtype=float) / 255
    assert ink.max() > 0.5  # the L drawn with the pen down is on the bed


def test_export_then_draw_over_sim(tmp_path):
    """The issue's command line: export a plan SVG for axidraw-v3, draw it over sim://."""
    from pencilbot.export.svg import write_svg
    from pencilbot.planning.plan import Layer, Page, Plan

    lines = [
        np.array([[10.0, 10.0 + y], [60.0, 12.0 + y], [60.0, 30.0 + y]]) for y in np.arange(0.0, 20.0, 2.0)
    ]
    svg = tmp_path / "plan.svg"
    write_svg(
        Plan(
            Page(100.0, 80.0, margin=5.0, name="test"), (Layer("hatch", lines, pen_width=0.5, role="hatch"),)
        ),
        svg,
    )
    gcode = tmp_path / "d.gcode"
    cli = [sys.executable, "-m", "pencilbot.cli"]
    subprocess.run(
        [*cli, "export", str(svg), "-o", str(gcode), "--profile", "axidraw-v3"], check=True, timeout=120
    )
    done = subprocess.run(
        [*cli, "draw", str(gcode), "--profile", "axidraw-v3", "--port", "sim://", "-q"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
