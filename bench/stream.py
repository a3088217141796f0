"""Streaming speed: wall time over motion time on a real-time virtual plotter, and driver CPU cost.

Prints JSON. A 2 000-segment drawing (short strokes, pen lifts between them) is streamed to the
virtual GRBL plotter emulating 115 200 baud with its motion clock in real time, once with
character counting and once with send-and-wait. ``ratio`` = wall time / motion time, where the
motion time is the simulator's planner clock for the same lines (target ≤ 1.05 for character
counting). ``cpu_ms_per_1000_lines``: process CPU time of the driver side per 1 000 lines with the
simulator's clock instant (the simulator runs in-process, so this is an upper bound).

The large case (``--strokes``, 100 000 by default: bench/gcode.py's random strokes on A4, 600 014
lines for grbl-servo-a4) measures what a big job costs before and while it streams:
``prepare_s`` and ``prepare_peak_mb`` are the wall time and the traced memory peak from calling
``draw()`` to the first byte written to the port (reading, cleaning, tracking and checking the
file), ``held_bytes_per_line`` what the driver holds per G-code line at that moment (the job:
its one buffer of lines and its arrays), for ``draw`` of the file and for ``simulate`` of a plan
(the program text it streams plus the job); ``cpu_ms_per_1000_lines`` the process CPU time of
streaming all of it to the instant virtual plotter (simulator included). Targets: preparation
≤ 1 s and ≤ 60 MB; ≤ 120 bytes per line; CPU no worse than 65 ms per 1 000 lines.

EBB profiles (``--profile axidraw-v3``): the same 2 000-segment drawing, planned on the host and
sent as LM/SP commands one at a time to the virtual EBB (firmware 3.0.3) in real time (its FIFO
deepened with ``CU,4`` to ``fifo_depth``; ``--firmware 2.8.1``: one deep, three commands in flight). ``ratio`` = wall time / the board's busy time (the sum of what its motion
queue ran), target ≤ 1.02; ``gaps`` = idle stretches of the board between motion commands once
the job started (a starved queue), which must be none; ``shortest_move_ms`` the shortest command
the host sent (the board's minimum for LM moves without a gap is 4 ms).

Run: ``python bench/stream.py [--segments 2000] [--strokes 100000] [--profile NAME]
[--firmware 2.8.1]`` (0 skips a case; the large case runs for GRBL profiles). Timings on a shared 2-core machine are noisy.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from gcode import stroke_plan

import sim
from pencilbot.driver import draw
from pencilbot.driver.port import LineReader
from pencilbot.export.gcode import gcode_program, write_gcode
from pencilbot.machine.profile import load_profile

PROFILE = "grbl-servo-a4"
sim.register()


def drawing_lines(segments: int, per_path: int = 20, seed: int = 0) -> list[str]:
    """G-code for ``segments`` pen-down segments of 1–2 mm in random-walk paths of ``per_path``,
    each path starting a few mm from the last (like ordered pencil strokes)."""
    profile = load_profile(PROFILE)
    top_x, top_y = min(200.0, profile.bed.width - 10), min(290.0, profile.bed.height - 10)
    rng = np.random.default_rng(seed)
    up, down = profile.render(profile.pen.up_command), profile.render(profile.pen.down_command)
    lines = ["G21", "G90", *up]
    x, y = 100.0, min(150.0, top_y / 2)
    for _ in range(math.ceil(segments / per_path)):
        x, y = (
            float(np.clip(x + rng.uniform(-6, 6), 10, top_x)),
            float(np.clip(y + rng.uniform(-6, 6), 10, top_y)),
        )
        lines.append(f"G0 X{x:.3f} Y{y:.3f}")
        lines.extend(down)
        for _ in range(per_path):
            angle, step = rng.uniform(0, 2 * np.pi), rng.uniform(1, 2)
            x, y = (
                float(np.clip(x + step * np.cos(angle), 10, top_x)),
                float(np.clip(y + step * np.sin(angle), 10, top_y)),
            )
            lines.append(f"G1 X{x:.3f} Y{y:.3f} F{profile.motion.draw_feed:.0f}")
        lines.extend(up)
    return lines


def stream_once(path: Path, options: str, send_and_wait: bool) -> dict:
    """Stream the file once; wall and CPU seconds of the whole draw() and the plotter's clock."""
    from sim import protocol_sim

    name = f"bench-{'wait' if send_and_wait else 'count'}-{time.monotonic_ns()}"
    wall0, cpu0 = time.perf_counter(), time.process_time()
    draw(
        path,
        f"sim://{name}?profile={PROFILE}&{options}",
        profile=PROFILE,
        send_and_wait=send_and_wait,
        progress="quiet",
        wake_wait=0.5,
    )
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    motion = protocol_sim.plotter(name).seconds
    protocol_sim.forget(name)
    return {
        "wall_s": round(wall, 2),
        "motion_s": round(motion, 2),
        "ratio": round(wall / motion, 4),
        "cpu_s": round(cpu, 2),
    }


def big_job(strokes: int) -> dict:
    """Prepare, hold and stream a job of ``strokes`` random strokes (see the module docstring)."""
    from sim import protocol_sim

    plan = stroke_plan(strokes)
    profile = load_profile(PROFILE)
    figures = {"strokes": strokes}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "big.gcode"
        lines = write_gcode(plan, profile, path, source="bench").lines
        figures["lines"] = lines
        # draw streams the file; simulate streams the program text it holds (counted as held).
        for what, gcode in (("draw", path), ("simulate", gcode_program(plan, profile, source="bench"))):
            seconds, _, _ = until_first_byte(gcode, traced=False)
            _, current, peak = until_first_byte(gcode, traced=True)
            text = len(gcode) if isinstance(gcode, bytes) else 0
            figures[what] = {
                "prepare_s": round(seconds, 3),
                "prepare_peak_mb": round(peak / 1e6, 1),
                "held_bytes_per_line": round((current + text) / lines, 1),
            }
        name = f"bench-big-{time.monotonic_ns()}"
        cpu0 = time.process_time()
        draw(path, f"sim://{name}?profile={PROFILE}", profile=PROFILE, progress="quiet", wake_wait=0.2)
        figures["cpu_ms_per_1000_lines"] = round((time.process_time() - cpu0) / lines * 1e6, 1)
        protocol_sim.forget(name)
    figures["targets"] = {
        "prepare_s": 1.0,
        "prepare_peak_mb": 60,
        "held_bytes_per_line": 120,
        "cpu_ms_per_1000_lines": 65,
    }
    return figures


class _FirstByte(Exception):
    """Raised at the driver's first write to the port: the measurement ends there."""


def until_first_byte(gcode, *, traced: bool) -> tuple[float, int, int]:
    """Seconds from calling draw() to its first write to the port, and the memory traced then
    (current and peak bytes; 0 unless ``traced``)."""
    from sim import protocol_sim

    name, write, seen = f"bench-first-{time.monotonic_ns()}", LineReader.write, {}
    started = time.perf_counter()

    def first(reader, data):
        seen["seconds"] = time.perf_counter() - started
        seen["memory"] = tracemalloc.get_traced_memory() if traced else (0, 0)
        raise _FirstByte

    LineReader.write = first
    if traced:
        tracemalloc.start()
    try:
        draw(gcode, f"sim://{name}?profile={PROFILE}", profile=PROFILE, progress="quiet", wake_wait=0.2)
    except _FirstByte:
        pass
    finally:
        LineReader.write = write
        tracemalloc.stop()
        protocol_sim.forget(name)
    return seen["seconds"], *seen["memory"]


def main() -> None:
    global PROFILE
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--segments", type=int, default=2000, help="real-time streaming case (0: skip)")
    parser.add_argument("--strokes", type=int, default=100_000, help="large job case (0: skip)")
    parser.add_argument(
        "--profile",
        default=PROFILE,
        help=f"plotter profile (default {PROFILE}); an EBB one "
        "(e.g. axidraw-v3) measures host-planned streaming to the virtual EBB",
    )
    parser.add_argument(
        "--firmware", default="3.0.3", help="the virtual EBB's firmware (2.8.1: a FIFO one deep)"
    )
    args = parser.parse_args()
    PROFILE = args.profile
    report = {"profile": PROFILE}
    if load_profile(PROFILE).firmware.capabilities.host_motion:
        if args.segments:
            report.update(realtime_ebb(args.segments, args.firmware))
        print(json.dumps(report, indent=1))
        return
    if args.segments:
        report.update(realtime(args.segments))
    if args.strokes:
        report["large_job"] = big_job(args.strokes)
    print(json.dumps(report, indent=1))


def realtime(segments: int) -> dict:
    """The 2 000-segment case: wall over motion time, and the driver's CPU per 1 000 lines."""
    lines = drawing_lines(segments)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.gcode"
        path.write_text("\n".join(lines) + "\n")
        counting = stream_once(path, "baud=115200&realtime=1", send_and_wait=False)
        waiting = stream_once(path, "baud=115200&realtime=1", send_and_wait=True)
        instant = stream_once(path, "baud=0&realtime=0", send_and_wait=False)
    counting["target"], counting["met"] = 1.05, counting["ratio"] <= 1.05
    # A starved planner also slows the motion itself (more stops), so compare with the motion
    # time of a full planner too.
    waiting["ratio_to_counting_motion"] = round(waiting["wall_s"] / counting["motion_s"], 4)
    return {
        "segments": segments,
        "lines": len(lines),
        "character_counting": counting,
        "send_and_wait": waiting,
        "cpu_ms_per_1000_lines": round(1000 * instant["cpu_s"] / len(lines) * 1000, 1),
        "note": "wall = whole draw() incl. wake; motion = the plotter's simulated clock; the simulator "
        "runs in the same process, so CPU includes it (an upper bound); shared 2-core machine",
    }


def realtime_ebb(segments: int, firmware: str = "3.0.3") -> dict:
    """The 2 000-segment case on an EBB board: host-planned LM moves, the FIFO full, real time."""
    from sim import protocol_sim

    lines = drawing_lines(segments)
    sent = []
    original = LineReader.write

    def spy(reader, data):
        sent.append(data)
        return original(reader, data)

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.gcode"
        path.write_text("\n".join(lines) + "\n")
        name = f"bench-ebb-{time.monotonic_ns()}"
        LineReader.write = spy
        try:
            wall0, cpu0 = time.perf_counter(), time.process_time()
            draw(
                path,
                f"sim://{name}?profile={PROFILE}&realtime=1&firmware={firmware}",
                profile=PROFILE,
                progress="quiet",
            )
            wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
        finally:
            LineReader.write = original
        board = protocol_sim.plotter(name)
        busy, gaps = board.busy_seconds, board.firmware.gaps  # idle stretches once the first move ran
        depth = board.firmware.fifo_size
        protocol_sim.forget(name)
    profile = load_profile(PROFILE)
    moves = [d for d in sent if d[:3] in (b"LM,", b"SP,")]
    shortest = _shortest_lm_ms(moves)
    return {
        "firmware": firmware,
        "fifo_depth": depth,
        "segments": segments,
        "lines": len(lines),
        "commands": len(moves),
        "wall_s": round(wall, 2),
        "busy_s": round(busy, 2),
        "ratio": round(wall / busy, 4),
        "target": 1.02,
        "met": wall / busy <= 1.02,
        "gaps": len([g for g in gaps if g > 0]),
        "longest_gap_ms": round(1000 * max(gaps, default=0.0), 3),
        "shortest_move_ms": shortest,
        "board_minimum_ms": profile.ebb.min_move_ms,
        "cpu_s": round(cpu, 2),
        "note": "wall = whole draw() incl. wake and set-up; busy = what the board's motion queue ran "
        "(its clock at 25 kHz ticks); simulator in the same process; shared 2-core machine",
    }


def _shortest_lm_ms(commands: list[bytes]) -> float:
    """Duration of the shortest LM among ``commands`` (from its words, as the board runs it), ms."""
    from firmware_protocol import ebb

    shortest = math.inf
    for data in commands:
        if not data.startswith(b"LM,"):
            continue
        words = [int(w) for w in data[3:].strip().split(b",")]
        ticks = max(
            ebb.lm_ticks(abs(words[3 * i + 1]), words[3 * i], words[3 * i + 2]) if words[3 * i + 1] else 0
            for i in range(2)
        )
        shortest = min(shortest, ticks * ebb.TICK * 1000)
    return round(shortest, 3)


if __name__ == "__main__":
    main()
