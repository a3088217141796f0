"""Clients no one here wrote, against `pencilbot sim-serve` on a pseudo-terminal: Evil Mad
Scientist's plotink asking what AxiDraw's software asks before a plot (QC, QL/SL, QT/ST, PI,
QR/SR, QU), and saxi's command lines (EM, SR, S2 pen heights on RP4, LM, QM, QC, QB) as its
ebb.ts writes them. Every answer is the one the client reads: an error line or a missing OK
would leave plotink waiting 100 s per query, and saxi rejecting the command."""

from __future__ import annotations

import logging
import signal
import subprocess
import sys

import numpy as np
import pytest
import serial
from PIL import Image
from plotink import ebb_motion, ebb_serial  # the test extra (pip install -e .[test])


def _serve(tmp_path, *extra):
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
            *extra,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    return proc, proc.stdout.readline().strip(), out


def _stop(proc):
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 0, stderr


@pytest.mark.parametrize("supply, powered", [("9.1", True), ("0", False)])
def test_plotink_gets_every_answer_it_reads(tmp_path, caplog, supply, powered):
    proc, path, _ = _serve(tmp_path, "--supply", supply)
    caplog.set_level(logging.INFO, logger="plotink")
    port = ebb_serial.testPort(path)
    assert port is not None
    try:
        assert ebb_motion.queryVoltage(port) is powered  # QC: V+ read as plotink reads it (< 250: no power)
        ebb_motion.setEBBLV(port, 37)  # SL / QL: where AxiDraw's software keeps its pen state
        assert ebb_motion.queryEBBLV(port) == 37
        ebb_serial.write_nickname(port, "studio-left")
        assert ebb_serial.query_nickname(port, verbose=False) == "studio-left"
        ebb_motion.sendEnableMotors(port, 2)  # EM,2,2: 8x
        assert ebb_motion.query_enable_motors(port) == (2, 2)  # PI on the drivers' enable and MS pins
        ebb_motion.sendDisableMotors(port)
        assert ebb_motion.query_enable_motors(port) == (0, 0)
        ebb_motion.servo_timeout(port, 60000, 1)  # SR,60000,1
        assert ebb_serial.query(port, "QR\r").strip() == "1"
        ebb_motion.PBOutConfig(port, 3, 0)  # PD / PO on B3
        assert ebb_serial.query(port, "QU,2\r").strip() == "QU,32"
    finally:
        ebb_serial.closePort(port)
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR]
    _stop(proc)


def test_saxi_commands_are_answered_and_its_pen_draws(tmp_path):
    """saxi (ebb.ts): EM, SR, S2,height,4,rate,delay for the pen (RP4 = RB1), LM for motion with
    steps of either sign, QM until idle, QC read up to its OK; a 20 x 10 mm L drawn pen down."""
    proc, path, out = _serve(tmp_path)
    lines: list[str] = []
    with serial.Serial(path, timeout=5) as port:

        def send(cmd, until_ok=True):
            port.write(f"{cmd}\r".encode())
            got = []
            for _ in range(4):  # at most a data line and OK, blank halves of "\n\r" between
                line = port.read_until(b"\n").decode().strip()
                if line:
                    got.append(line)
                if line and (not until_ok or line == "OK" or line.startswith("!")):
                    break
            return got

        assert send("EM,1,1") == ["OK"]
        assert send("SR,0,1") == ["OK"]
        up, down = 20641, 15248  # saxi's pen positions for 60 % / 30 % on an AxiDraw's range
        assert send(f"S2,{up},4,0,100") == ["OK"]
        assert send(f"S2,{down},4,1000,200") == ["OK"]  # rate in units per 24 ms, then 200 ms wait
        rate = round(3000 * ((1 << 31) / 25000))  # 3000 steps/s, as saxi's axisRate computes it
        for steps1, steps2 in ((1600, 1600), (800, -800)):  # +20 mm along X, then +10 mm along Y
            lines += send(f"LM,{rate},{steps1},0,{rate},{steps2},0")
        assert send(f"S2,{up},4,0,100") == ["OK"]
        for _ in range(100):  # saxi's waitUntilMotorsIdle (the board runs a command per query)
            if send("QM", until_ok=False) == ["QM,0,0,0,0"]:
                break
        assert send("QM", until_ok=False) == ["QM,0,0,0,0"]
        qc = send("QC")
        assert len(qc) == 2 and qc[1] == "OK" and int(qc[0].split(",")[1]) > 250  # saxi: > 6 V powered
        assert send("QB") == ["0", "OK"]
    assert lines == ["OK", "OK"]
    _stop(proc)
    ink = 1 - np.asarray(Image.open(out).convert("L"), dtype=float) / 255
    assert ink.max() > 0.5
