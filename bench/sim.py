"""Virtual plotter speed: lines/s accepted in instant mode, seconds to rasterise 100 000 segments.

Prints JSON. Targets: >= 20 000 lines/s accepted (instant mode); <= 3 s to rasterise 100 000
pen-down segments onto A4 at 300 dpi. Timings on a shared machine are noisy; the best of a few
repeats is reported.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

# Run as a script, this file's folder comes first on sys.path and its name would shadow the
# `sim` package it measures.
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

import numpy as np  # noqa: E402
import serial  # noqa: E402

from firmware_protocol import grbl  # noqa: E402
from sim import protocol_sim  # noqa: E402
from sim.canvas import Canvas  # noqa: E402
from sim.firmware import Firmware  # noqa: E402
from sim.machine import Machine, MachineConfig  # noqa: E402


def program(n: int, seed: int = 0) -> list[str]:
    """A pen-down random walk of ``n`` G1 moves inside an A4 bed."""
    rng = np.random.default_rng(seed)
    pts = np.cumsum(rng.normal(0, 2.0, (n, 2)), axis=0) % [200.0, 290.0] + 5.0
    return ["M3 S90", "G1 F3000"] + [f"G1 X{x:.3f} Y{y:.3f}" for x, y in pts]


def firmware_rate(lines: list[str]) -> float:
    """Lines/s through the firmware's byte interface alone."""
    fw = Firmware(Machine(MachineConfig()))
    data = b"".join(grbl.encode_line(ln) for ln in lines)
    start = time.perf_counter()
    for i in range(0, len(data), 4096):
        fw.receive(data[i:i + 4096])
        fw.take_output()
    fw.finish()
    return len(lines) / (time.perf_counter() - start)


def port_rate(lines: list[str]) -> float:
    """Lines/s through ``sim://`` with a character-counting sender (128-byte budget)."""
    protocol_sim.register()
    port = serial.serial_for_url("sim://", timeout=0.5)
    port.read(100)  # banner
    encoded = [grbl.encode_line(ln) for ln in lines]
    in_flight: list[int] = []
    pending = b""
    start = time.perf_counter()
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
    elapsed = time.perf_counter() - start
    port.close()
    return len(lines) / elapsed


def raster_seconds(n_segments: int = 100_000) -> float:
    rng = np.random.default_rng(1)
    per_path = 50
    paths = []
    for _ in range(n_segments // per_path):
        start = rng.uniform([10, 10], [200, 287])
        paths.append(start + np.cumsum(rng.normal(0, 1.5, (per_path + 1, 2)), axis=0))
    t = time.perf_counter()
    Canvas(210.0, 297.0, dpi=300, pen_width=0.5).draw_paths(paths)
    return time.perf_counter() - t


def main() -> None:
    lines = program(50_000)
    fw = max(firmware_rate(lines) for _ in range(3))
    port = max(port_rate(lines[:20_000]) for _ in range(2))
    raster = min(raster_seconds() for _ in range(2))
    print(json.dumps({
        "instant_lines_per_s_firmware": round(fw),
        "instant_lines_per_s_sim_url_char_counting": round(port),
        "target_lines_per_s": 20_000,
        "raster_100k_segments_a4_300dpi_s": round(raster, 3),
        "target_raster_s": 3.0,
        "lines_met": port >= 20_000,
        "raster_met": raster <= 3.0,
    }, indent=2))


if __name__ == "__main__":
    main()
