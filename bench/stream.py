"""Streaming speed: wall time over motion time on a real-time virtual plotter, and driver CPU cost.

Prints JSON. A 2 000-segment drawing (short strokes, pen lifts between them) is streamed to the
virtual GRBL plotter emulating 115 200 baud with its motion clock in real time, once with
character counting and once with send-and-wait. ``ratio`` = wall time / motion time, where the
motion time is the simulator's planner clock for the same lines (target ≤ 1.05 for character
counting). ``cpu_ms_per_1000_lines``: process CPU time of the driver side per 1 000 lines with the
simulator's clock instant (the simulator runs in-process, so this is an upper bound).

Run: ``python bench/stream.py [--segments 2000]``. Timings on a shared 2-core machine are noisy.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

import sim
from pencilbot.driver import draw
from pencilbot.machine.profile import load_profile

PROFILE = "grbl-servo-a4"
sim.register()


def drawing_lines(segments: int, per_path: int = 20, seed: int = 0) -> list[str]:
    """G-code for ``segments`` pen-down segments of 1–2 mm in random-walk paths of ``per_path``,
    each path starting a few mm from the last (like ordered pencil strokes)."""
    profile = load_profile(PROFILE)
    rng = np.random.default_rng(seed)
    up, down = profile.render(profile.pen.up_command), profile.render(profile.pen.down_command)
    lines = ["G21", "G90", *up]
    x, y = 100.0, 150.0
    for _ in range(math.ceil(segments / per_path)):
        x, y = float(np.clip(x + rng.uniform(-6, 6), 10, 200)), float(np.clip(y + rng.uniform(-6, 6), 10, 290))
        lines.append(f"G0 X{x:.3f} Y{y:.3f}")
        lines.extend(down)
        for _ in range(per_path):
            angle, step = rng.uniform(0, 2 * np.pi), rng.uniform(1, 2)
            x, y = float(np.clip(x + step * np.cos(angle), 10, 200)), float(np.clip(y + step * np.sin(angle), 10, 290))
            lines.append(f"G1 X{x:.3f} Y{y:.3f} F{profile.motion.draw_feed:.0f}")
        lines.extend(up)
    return lines


def stream_once(path: Path, options: str, send_and_wait: bool) -> dict:
    """Stream the file once; wall and CPU seconds of the whole draw() and the plotter's clock."""
    from sim import protocol_sim

    name = f"bench-{'wait' if send_and_wait else 'count'}-{time.monotonic_ns()}"
    wall0, cpu0 = time.perf_counter(), time.process_time()
    draw(path, f"sim://{name}?profile={PROFILE}&{options}", profile=PROFILE, send_and_wait=send_and_wait,
         progress="quiet", wake_wait=0.5)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    motion = protocol_sim.plotter(name).seconds
    protocol_sim.forget(name)
    return {"wall_s": round(wall, 2), "motion_s": round(motion, 2), "ratio": round(wall / motion, 4),
            "cpu_s": round(cpu, 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--segments", type=int, default=2000)
    args = parser.parse_args()
    lines = drawing_lines(args.segments)
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
    print(json.dumps({
        "segments": args.segments,
        "lines": len(lines),
        "character_counting": counting,
        "send_and_wait": waiting,
        "cpu_ms_per_1000_lines": round(1000 * instant["cpu_s"] / len(lines) * 1000, 1),
        "note": "wall = whole draw() incl. wake; motion = the plotter's simulated clock; the simulator "
                "runs in the same process, so CPU includes it (an upper bound); shared 2-core machine",
    }, indent=1))


if __name__ == "__main__":
    main()
