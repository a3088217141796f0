"""Plot time of a G-code file on real GRBL 1.1h, next to pencilbot's estimate and simulation.

Real GRBL here is the firmware's own C source (planner, stepper, protocol, G-code parser)
compiled for the host by grbl-sim, which stands in the AVR's timers, serial port and EEPROM.
This script sends the profile's settings (``$1``, ``$10``–``$12``, ``$30``–``$32``,
``$100``–``$132``: rates, acceleration, junction deviation, travel; no homing or soft limits),
then the file with its comments and blank lines taken out, and reads the firmware's simulated
clock. It prints JSON: GRBL's seconds from the job's first line until everything has run and
the board is idle (``total``), split into the time the steppers ran (``moving``), the ``G4``
dwells, the stepper idle lock GRBL waits out in its stepper interrupt after every stop
(``idle_lock``, ``$1`` ms) and the rest (``other``: serial and parsing gaps); pencilbot's
estimate (``stat``), the virtual plotter's clock (``simulate``), the G-code header's estimate,
and each as a ratio of GRBL's total (``motion`` compares the estimate less the program's dwells
and its idle locks with GRBL's moving time).

Usage::

    python bench/real_grbl.py FILE.gcode [--grbl-sim PATH] [--profile NAME]

``PATH`` defaults to ``$GRBL_SIM``. Neither the tests nor CI need it.

Building ``grbl_sim.exe`` (third-party code: GRBL 1.1h, github.com/gnea/grbl, and grbl-sim by
Jens Geisler and Adam Shelly, github.com/grbl/grbl-sim, both GPLv3)::

    git clone https://github.com/gnea/grbl && cd grbl/grbl
    git clone https://github.com/grbl/grbl-sim && cd grbl-sim
    git apply /path/to/pencilbot/bench/grbl_sim_lockstep.patch
    make new

grbl-sim as published runs the firmware and the simulated hardware in two threads at roughly
real time, with delays taken from the host's clock, a serial receive check written for GRBL
0.9's 128-byte ring (1.1's holds 129: bytes are lost) and a transmit wait that never ends
when the firmware prints more than its buffer holds; it cannot time a plot. The patch
(``grbl_sim_lockstep.patch``, pencilbot's) runs both in one thread in simulated time only:
the firmware as on an infinitely fast CPU, the hardware stepped tick by tick (16 MHz) wherever
the firmware waits (no serial data, a full segment buffer, a dwell, the idle lock), so a run is
exactly repeatable; it exits when every line has been answered and run, printing the summary
this script reads. GRBL's own files are not changed. A 90 s plot takes about 20 s to run.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from pencilbot.commands.stat import gcode_plan
from pencilbot.driver.gcode.job import gcode_blocks
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.machine.profile import DEFAULT_PROFILE, load_profile
from pencilbot.planning.stats import estimate
from sim import bulk, protocol_sim
from sim.gcode.settings import grbl_settings

#: The settings sent before the job (homing and soft limits stay off: the job starts at 0, 0).
SENT = (1, 10, 11, 12, 30, 31, 32, 100, 101, 102, 110, 111, 112, 120, 121, 122, 130, 131, 132)

#: GRBL rounds every dwell up to whole steps of this many seconds (``DWELL_TIME_STEP``).
DWELL_STEP = 0.05


def settings_lines(profile) -> list[str]:
    """``$n=value`` lines giving the board the settings the virtual GRBL has for ``profile``."""
    settings = grbl_settings(profile)
    return [f"${key}={settings[key]:g}" for key in SENT]


def job_lines(path: Path) -> list[str]:
    """The file's commands as the driver sends them (:func:`~pencilbot.driver.gcode.modal.clean_line`),
    without blank lines."""
    return [line for line in map(clean_line, path.read_text().splitlines()) if line]


def program_dwell(lines: list[str]) -> float:
    """Seconds of ``G4 P`` dwell in ``lines``, each rounded up as GRBL runs it."""
    total = 0.0
    for line in lines:
        match = re.match(r"G0*4P([\d.]+)", line)
        if match:
            total += -(-float(match.group(1)) // DWELL_STEP) * DWELL_STEP
    return total


def run_grbl(exe: str, settings: list[str], job: list[str]) -> dict:
    """Run ``job`` after ``settings`` on grbl_sim.exe; GRBL's seconds and its stretches of motion.

    Raises
    ------
    RuntimeError
        The firmware refused a line or raised an alarm.
    """
    data = "".join(line + "\n" for line in settings + job).encode()
    with tempfile.TemporaryDirectory() as cwd:  # the simulated EEPROM is a file there
        run = subprocess.run(
            [exe, "-n", "-k", str(len(settings)), "-b", os.devnull],
            input=data,
            capture_output=True,
            cwd=cwd,
            check=True,
        )
    answers = run.stdout.decode().split("Grbl 1.1", 1)[-1].splitlines()
    refused = [line for line in answers if line.startswith(("error", "ALARM"))]
    if refused:
        raise RuntimeError(f"GRBL refused the job: {refused[:3]}")
    summary = re.search(r"^lockstep (.*)$", run.stderr.decode(), re.M)
    figures = {key: float(value) for key, value in (item.split("=") for item in summary.group(1).split())}
    figures["other"] = figures["total"] - figures["moving"] - figures["dwell"] - figures["idle_lock"]
    figures["stops"] = run.stderr.decode().count("interval ")
    return figures


def simulated_seconds(path: Path, profile_name: str) -> float:
    """The virtual plotter's clock after running the file at once (what ``simulate`` prints)."""
    plotter = protocol_sim.plotter_from_options({"profile": profile_name, "realtime": "0", "limits": "bed"})
    if bulk.run_blocks(plotter.machine, gcode_blocks(path)) is not None:
        raise RuntimeError(f"the virtual plotter could not run {path} at once")
    return plotter.seconds


def header_seconds(path: Path) -> float | None:
    """The ``estimated time`` the G-code header states, in seconds (None without one)."""
    match = re.search(r"^; estimated time: \S+ \((\d+(?:\.\d+)?) s\)", path.read_text(), re.M)
    return float(match.group(1)) if match else None


def compare(path: Path, exe: str, profile_name: str) -> dict:
    """GRBL's figures, pencilbot's, and their ratios (pencilbot ÷ GRBL)."""
    profile = load_profile(profile_name)
    job = job_lines(path)
    grbl = run_grbl(exe, settings_lines(profile), job)
    stat = estimate(gcode_plan(path, profile), profile).total.seconds
    ours = {"stat": stat, "simulate": simulated_seconds(path, profile_name), "header": header_seconds(path)}
    ratios = {key: value / grbl["total"] for key, value in ours.items() if value is not None}
    idle = grbl["stops"] * profile.firmware.idle_lock  # the estimate's idle locks, one per stop
    ratios["motion"] = (stat - program_dwell(job) - idle) / grbl["moving"]
    return {
        "file": str(path),
        "profile": profile_name,
        "grbl": grbl,
        "pencilbot": ours,
        "ratio": {key: round(value, 4) for key, value in ratios.items()},
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("gcode", type=Path)
    parser.add_argument(
        "--grbl-sim",
        default=os.environ.get("GRBL_SIM"),
        help="path of grbl_sim.exe built as this script's docstring says (default $GRBL_SIM)",
    )
    parser.add_argument("--profile", default=DEFAULT_PROFILE)
    args = parser.parse_args(argv)
    if not args.grbl_sim:
        parser.error("give --grbl-sim or set GRBL_SIM (see this script's docstring to build it)")
    print(json.dumps(compare(args.gcode, args.grbl_sim, args.profile), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
