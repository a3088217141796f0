"""Real EBB clients on the virtual AxiDraw (``sim-serve --profile axidraw-v3``): how long each
waited for an answer and how far what it drew lies from its input.

Prints JSON, one record per client:

* ``pyaxidraw``: AxiDraw's own Python API plotting a test SVG (``plot_setup`` / ``plot_run``). Its
  code is not on PyPI and is not part of pencilbot: give a folder where ``pyaxidraw``, ``axicli``
  and ``axidrawinternal`` (evil-mad/axidraw's ``cli/pyaxidraw``, ``cli/axicli`` and
  ``inkscape driver``) import from, and a Python with its dependencies (``ink_extensions``,
  ``lxml``, ``plotink``, ``tqdm``), as ``--axidraw-site`` and ``--axidraw-python``; skipped without.
* ``plotink``: Evil Mad Scientist's helpers asking the pre-plot questions (QC, QL/SL, QT, PI, QU)
  and drawing a square with XM moves.

``max_wait_s`` is the longest the board heard nothing from the client once it began (a client
stuck waiting for an answer that never comes shows as a gap: 100 s for plotink's OK);
``seconds`` the client's whole run and ``client_cpu_s`` the processor time it used (a client that
only waits on the board has far more of the first); ``refusals`` the error lines it got; ``worst_mm`` the largest distance from a point drawn to the
input's lines and from the input's points to what was drawn (pen-down only); ``commands`` what
the board took.

Run: ``python bench/ebb_clients.py [--axidraw-site DIR --axidraw-python PYTHON]``
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sim.protocol_sim import plotter_from_options
from sim.pty_server import PtyServer

SVG = """<svg xmlns="http://www.w3.org/2000/svg" width="120mm" height="90mm" viewBox="0 0 120 90">
<path d="M 20 20 L 100 20 L 100 70 L 20 70 Z" fill="none" stroke="black"/>
<path d="M 30 30 L 90 60" fill="none" stroke="black"/>
<circle cx="60" cy="45" r="15" fill="none" stroke="black"/>
</svg>"""


def input_lines() -> list[np.ndarray]:
    """The SVG's shapes as polylines (mm), the circle finely sampled."""
    t = np.linspace(0, 2 * np.pi, 2001)
    return [
        np.array([[20, 20], [100, 20], [100, 70], [20, 70], [20, 20]], float),
        np.array([[30, 30], [90, 60]], float),
        np.column_stack([60 + 15 * np.cos(t), 45 + 15 * np.sin(t)]),
    ]


def _densify(line: np.ndarray, step: float = 0.02) -> np.ndarray:
    out = [line[:1]]
    for a, b in zip(line[:-1], line[1:]):
        n = max(int(np.ceil(np.hypot(*(b - a)) / step)), 1)
        out.append(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    return np.vstack(out)


def worst_distance(drawn: list[np.ndarray], wanted: list[np.ndarray]) -> float:
    """The larger of the two one-sided distances between the point clouds (densified lines)."""
    from scipy.spatial import cKDTree

    got = np.vstack([_densify(s) for s in drawn if len(s) > 1])
    want = np.vstack([_densify(s) for s in wanted])
    return float(max(cKDTree(want).query(got)[0].max(), cKDTree(got).query(want)[0].max()))


class _Watched:
    """The plotter, with the time of every write from the client."""

    def __init__(self, plotter):
        self.plotter, self.times, self.replies = plotter, [], []

    def __getattr__(self, name):
        return getattr(self.plotter, name)

    def read(self) -> bytes:
        data = self.plotter.read()
        self.replies += [line for line in data.decode("ascii", "replace").splitlines() if line.strip()]
        return data

    def write(self, data: bytes) -> None:
        self.times.append(time.monotonic())
        self.plotter.write(data)


PYAXIDRAW = """
import sys
import serial
from pyaxidraw import axidraw
ad = axidraw.AxiDraw()
ad.plot_setup(sys.argv[2])
ad.options.port = serial.Serial(sys.argv[1], timeout=1.0)  # a pty is no USB device it can find by name
ad.options.model = 1
ad.plot_run()
"""

PLOTINK = """
import sys
from plotink import ebb_motion, ebb_serial
port = ebb_serial.testPort(sys.argv[1])
assert ebb_motion.queryVoltage(port)
ebb_motion.setEBBLV(port, 12); ebb_motion.queryEBBLV(port)
ebb_serial.query_nickname(port); ebb_serial.query(port, "QU,2\\r")
ebb_motion.sendEnableMotors(port, 1); ebb_motion.query_enable_motors(port)
ebb_motion.setPenUpPos(port, 20641); ebb_motion.setPenDownPos(port, 15248)
ebb_motion.sendPenUp(port, 150)
ebb_motion.doABMove(port, 1600, 1600, 400)  # XM: X and Y steps (80 per mm): to (20, 20) mm
ebb_motion.sendPenDown(port, 150)
for dx, dy in ((6400, 0), (0, 4000), (-6400, 0), (0, -4000)):
    ebb_motion.doABMove(port, dx, dy, 800)
ebb_motion.sendPenUp(port, 150)
ebb_serial.closePort(port)
"""


def run_client(name: str, python: str, script: str, env: dict, svg: Path) -> dict:
    import resource

    plotter = _Watched(plotter_from_options({"profile": "axidraw-v3", "realtime": "0"}))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with PtyServer(plotter, reset_on_open=False) as served:
        t0 = time.monotonic()
        done = subprocess.run(
            [python, "-c", script, served.path, str(svg)],
            capture_output=True,
            text=True,
            env=env,
            timeout=900,
        )
        seconds = time.monotonic() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    board = plotter.plotter
    board.firmware.finish()
    times = np.array(plotter.times)  # from its first command (not its start-up and imports)
    strokes = list(board.drawn())
    wanted = (
        input_lines()
        if name == "pyaxidraw"
        else [np.array([[20, 20], [100, 20], [100, 70], [20, 70], [20, 20]], float)]
    )
    return {
        "client": name,
        "returncode": done.returncode,
        "seconds": round(seconds, 2),
        "client_cpu_s": round(cpu, 2),
        "refusals": sum("Err" in line for line in plotter.replies),
        "max_wait_s": round(float(np.diff(times).max()), 3) if len(times) > 1 else None,
        "strokes": len(strokes),
        "worst_mm": round(worst_distance(strokes, wanted), 4) if strokes else None,
        "commands": len(board.firmware.log),
        "stderr_tail": done.stderr[-300:] if done.returncode else "",
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--axidraw-site", help="folder importing pyaxidraw, axicli, axidrawinternal")
    parser.add_argument("--axidraw-python", help="a Python with pyaxidraw's dependencies")
    args = parser.parse_args()
    import os

    with tempfile.TemporaryDirectory() as tmp:
        svg = Path(tmp) / "test.svg"
        svg.write_text(SVG)
        records = [run_client("plotink", sys.executable, PLOTINK, dict(os.environ), svg)]
        if args.axidraw_site and args.axidraw_python:
            env = {**os.environ, "PYTHONPATH": args.axidraw_site, "HOME": tmp}
            records.append(run_client("pyaxidraw", args.axidraw_python, PYAXIDRAW, env, svg))
    for record in records:
        print(json.dumps(record))


if __name__ == "__main__":
    main()
