"""Virtual plotter speed: lines/s accepted in instant mode, seconds to rasterise 100 000 segments.

Prints JSON. Targets: >= 20 000 lines/s accepted (instant mode); <= 3 s to rasterise 100 000
pen-down segments onto A4 at 300 dpi. Lines per second are measured three ways: the firmware
alone (bytes in, replies out), through ``sim://`` with this script's minimal character-counting
sender, and through ``sim://`` with pencilbot's own driver (``pencilbot.driver.draw``, what
``pencilbot draw`` and ``simulate`` do: job journal, progress, fault handling), which is the
throughput a user gets. Timings on a shared machine are noisy: the best of a few repeats is
reported, by wall clock and by this process's CPU time (what the code costs when it does not
have to wait for a core; the simulator runs in this process, so CPU counts both sides).
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np
import serial

import sim
from firmware_protocol import grbl
from pencilbot.driver import draw
from pencilbot.machine.profile import DEFAULT_PROFILE, load_profile
from pencilbot.render import Canvas
from sim.gcode.firmware import Firmware
from sim.gcode.machine import Machine


def program(n: int, seed: int = 0) -> list[str]:
    """A pen-down random walk of ``n`` G1 moves inside an A4 bed."""
    rng = np.random.default_rng(seed)
    pts = np.cumsum(rng.normal(0, 2.0, (n, 2)), axis=0) % [200.0, 290.0] + 5.0
    return ["M3 S90", "G1 F3000"] + [f"G1 X{x:.3f} Y{y:.3f}" for x, y in pts]


def timed(fn) -> tuple[float, float]:
    """(wall, cpu) seconds of ``fn()``."""
    wall, cpu = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - wall, time.process_time() - cpu


def firmware_run(lines: list[str]):
    """Feed the lines through the firmware's byte interface alone."""
    fw = Firmware(Machine(load_profile(DEFAULT_PROFILE)))
    data = b"".join(grbl.encode_line(ln) for ln in lines)

    def run():
        for i in range(0, len(data), 4096):
            fw.receive(data[i : i + 4096])
            fw.take_output()
        fw.finish()

    return run


def port_run(lines: list[str]):
    """Send the lines through ``sim://`` with a character-counting sender (128-byte budget)."""
    sim.register()
    port = serial.serial_for_url("sim://", timeout=0.5)
    port.read(len("\r\nGrbl 1.1h ['$' for help]\r\n"))
    encoded = [grbl.encode_line(ln) for ln in lines]
    return lambda: _stream(port, encoded)


def _stream(port, encoded: list[bytes]) -> None:
    in_flight: list[int] = []
    pending = b""
    i = 0
    while i < len(encoded) or in_flight:
        batch = []
        while i < len(encoded) and sum(in_flight) + len(encoded[i]) <= grbl.RX_BUFFER_SIZE:
            in_flight.append(len(encoded[i]))
            batch.append(encoded[i])
            i += 1
        if batch:
            port.write(b"".join(batch))
        pending += port.read(max(port.in_waiting, 1))
        *replies, pending = pending.split(b"\r\n")
        for reply in replies:
            if reply == b"ok" or reply.startswith(b"error:"):
                in_flight.pop(0)
    port.close()


def driver_run(lines: list[str], folder: Path):
    """Stream the lines from a G-code file with pencilbot's driver to an instant ``sim://``."""
    path = folder / "bench.gcode"
    path.write_text("\n".join(lines) + "\n")
    return lambda: draw(
        path,
        f"sim://bench-driver-{time.monotonic_ns()}",
        profile="grbl-servo-a4",
        progress="quiet",
        wake_wait=0.0,
    )


def raster_run(n_segments: int = 100_000):
    rng = np.random.default_rng(1)
    per_path = 50
    paths = []
    for _ in range(n_segments // per_path):
        start = rng.uniform([10, 10], [200, 287])
        paths.append(start + np.cumsum(rng.normal(0, 1.5, (per_path + 1, 2)), axis=0))
    return lambda: Canvas(210.0, 297.0, dpi=300, pen_width=0.5).draw_paths(paths)


def best(make_run, repeats: int) -> tuple[float, float]:
    """Shortest (wall, cpu) seconds over ``repeats`` fresh runs."""
    times = [timed(make_run()) for _ in range(repeats)]
    return min(t[0] for t in times), min(t[1] for t in times)


def main() -> None:
    lines = program(50_000)
    fw_wall, fw_cpu = best(lambda: firmware_run(lines), 3)
    port_lines = lines[:20_000]
    port_wall, port_cpu = best(lambda: port_run(port_lines), 2)
    with tempfile.TemporaryDirectory() as folder:
        driver_wall, driver_cpu = best(lambda: driver_run(port_lines, Path(folder)), 2)
    raster_wall, raster_cpu = best(raster_run, 2)
    port_rate_cpu = len(port_lines) / port_cpu
    print(
        json.dumps(
            {
                "instant_lines_per_s_firmware": {
                    "wall": round(len(lines) / fw_wall),
                    "cpu": round(len(lines) / fw_cpu),
                },
                "instant_lines_per_s_sim_url_char_counting": {
                    "wall": round(len(port_lines) / port_wall),
                    "cpu": round(port_rate_cpu),
                },
                "instant_lines_per_s_sim_url_pencilbot_driver": {
                    "wall": round(len(port_lines) / driver_wall),
                    "cpu": round(len(port_lines) / driver_cpu),
                },
                "target_lines_per_s": 20_000,
                "raster_100k_segments_a4_300dpi_s": {
                    "wall": round(raster_wall, 3),
                    "cpu": round(raster_cpu, 3),
                },
                "target_raster_s": 3.0,
                "lines_met_cpu": port_rate_cpu >= 20_000,
                "driver_lines_met_cpu": len(port_lines) / driver_cpu >= 20_000,
                "raster_met_cpu": raster_cpu <= 3.0,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
