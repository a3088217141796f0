"""At the plotter (issue 31): the commands a person types, on every family's virtual plotter.

For each profile a virtual plotter is served on a pseudo-terminal as ``pencilbot sim-serve``
serves it (:class:`sim.pty_server.PtyServer`, no reset on open: a board whose port does not reset
it, so its pen state carries from one command to the next), and the real CLI runs in its own
process against the pty: ``pen toggle`` twice, ``pen cycle``, ``align``, ``walk --x 10 --y 5``,
``home``, and ``pen trial`` answered ``35``, ``+``, Enter, Enter. Each step records what the CLI
printed (its exit code, its one line) and what the virtual board's own record says afterwards:
its pen (EBB: the servo's state; GRBL: the machine's pen; HP-GL: the pen's solenoid) and where
its carriage really is (mm). The trial's saved heights are read back from the user's profile.

Marlin has no virtual board (the simulator speaks GRBL's protocol, the EBB's and HP-GL), so it is
listed as not run.

Usage: ``python bench/at_plotter.py [--profiles axidraw-v3,grbl-servo-a4,...]`` (prints JSON).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

PROFILES = "axidraw-v3,nextdraw-8511,grbl-servo-a4,grbl-z-a3,grblhal-servo-a3,hp7475a,marlin-servo-a4"
STEPS = (
    ["pen", "toggle"],
    ["pen", "toggle"],
    ["pen", "cycle"],
    ["align"],
    ["walk", "--x", "10", "--y", "5"],
    ["home"],
    ["pen", "trial"],
)
TRIAL_ANSWERS = "35\n+\n\n\n"


def _board(profile):
    from sim.protocol_sim import plotter_from_options

    return plotter_from_options({"profile": profile})


def _pen_down(plotter) -> bool:
    board = plotter.firmware
    if hasattr(board, "pen_up"):
        return not board.pen_up
    machine = plotter.machine
    return bool(machine.pen_down if hasattr(machine, "pen_down") else board.down)


def _carriage(plotter) -> list[float]:
    if hasattr(plotter, "position"):
        xy = plotter.position()
    elif hasattr(plotter.machine, "carriage_position"):
        xy = plotter.machine.carriage_position()
    else:
        xy = np.array([plotter.board.x, plotter.board.y]) * 0.025
    return [round(float(v), 3) for v in xy[:2]]


def run_profile(profile: str, config: Path) -> dict:
    from pencilbot.machine.profile import load_profile
    from sim.pty_server import PtyServer
    from sim.wires import check_simulated

    try:
        check_simulated(load_profile(profile))
    except Exception as exc:  # noqa: BLE001 - reported
        return {"profile": profile, "run": False, "why": str(exc)}
    plotter = _board(profile)
    env = {**os.environ, "PENCILBOT_CONFIG_DIR": str(config)}
    steps = []
    with PtyServer(plotter, reset_on_open=False) as server:
        for step in STEPS:
            command = [
                sys.executable,
                "-m",
                "pencilbot.cli",
                *step,
                "--port",
                server.path,
                "--profile",
                profile,
            ]
            done = subprocess.run(
                command,
                input=TRIAL_ANSWERS if step[-1] == "trial" else "",
                capture_output=True,
                text=True,
                timeout=120,
                env=env,
            )
            said = (
                (done.stdout.strip().splitlines() or [""])[-1]
                if done.returncode == 0
                else done.stderr.strip()
            )
            steps.append(
                {
                    "command": f"pencilbot {' '.join(step)} --port PTY --profile {profile}",
                    "exit": done.returncode,
                    "said": said.split(": ", 1)[-1] if step[-1] == "trial" else said,
                    "board_pen_down": _pen_down(plotter),
                    "board_carriage_mm": _carriage(plotter),
                }
            )
    saved = config / "plotters" / f"{profile}.toml"
    heights = None
    if saved.is_file():
        pen = load_profile(str(saved)).pen
        heights = {"down": pen.down, "up": pen.up}
    return {"profile": profile, "run": True, "steps": steps, "saved_heights": heights}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--profiles", default=PROFILES)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        results = [run_profile(name, Path(folder)) for name in args.profiles.split(",")]
    print(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
