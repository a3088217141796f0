"""HP-GL on the virtual HP 7475A: plot time against the estimate, and how well polling keeps
the plotter's buffer fed.

Prints JSON. The coffee photo (skimage) is planned on A4 and exported for ``hp7475a``
(``instructions``, ``bytes``); it is drawn over ``sim://`` with the plotter's clock instant:
``simulated_s`` (the virtual plotter's motion and pen time) against ``estimated_s`` (the one
estimate ``stat`` and ``export`` print) as ``time_ratio`` (target within 2 %). Then the first
``--paths`` strokes are drawn with the clock at ``--realtime`` times real time at 9600 baud:
``wall_over_motion`` = wall time / (simulated time / realtime) (1.0: the buffer never ran dry
while the sender polled ESC.B), ``max_fill`` the most bytes the buffer held (≤ 1024) and
``overflows`` the bytes lost (must be 0).

Run: ``python bench/hpgl.py [--paths 40] [--realtime 1]`` (real time at 9600 baud: the wire, 960 bytes/s, is part of what is measured).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import skimage.data

import sim
from pencilbot import api
from pencilbot.driver import draw
from pencilbot.export.hpgl import write_hpgl
from pencilbot.machine.profile import load_profile
from pencilbot.planning.stats import estimate
from sim import protocol_sim


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--paths", type=int, default=40)
    parser.add_argument("--realtime", type=float, default=1.0)
    args = parser.parse_args()
    sim.register()
    profile = load_profile("hp7475a")
    plan = api.plan(skimage.data.coffee())
    with tempfile.TemporaryDirectory() as folder:
        whole = Path(folder) / "coffee.hpgl"
        summary = write_hpgl(plan, profile, whole)
        draw(whole, "sim://bench-instant?profile=hp7475a", profile="hp7475a")
        board = protocol_sim.plotter("bench-instant").board
        estimated = estimate(plan, profile).total.seconds
        layer = plan.layers[0]
        small_plan = replace(plan, layers=(replace(layer, paths=layer.paths[: args.paths]),))
        small = Path(folder) / "small.hpgl"
        write_hpgl(small_plan, profile, small)
        started = time.perf_counter()
        draw(
            small,
            f"sim://bench-real?profile=hp7475a&baud=9600&realtime={args.realtime}",
            profile="hp7475a",
            baud=9600,
        )
        wall = time.perf_counter() - started
        real = protocol_sim.plotter("bench-real").board
    print(
        json.dumps(
            {
                "instructions": summary.instructions,
                "bytes": summary.bytes,
                "estimated_s": round(estimated, 2),
                "simulated_s": round(board.clock, 2),
                "time_ratio": round(board.clock / estimated, 4),
                "strokes": len(board.strokes),
                "plan_paths": len(plan.paths()),
                "realtime": args.realtime,
                "paths": args.paths,
                "motion_s": round(real.clock, 2),
                "wall_over_motion": round(wall / (real.clock / args.realtime), 3),
                "max_fill": real.max_fill,
                "overflows": real.overflows,
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
