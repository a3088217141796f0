"""Every way a plot stops, at many places of a real plan: does the resume draw it exactly?

In-process sweep over the virtual plotter (a real board: it counts from 0, 0 after a power-up
and loses its position in a reset or alarm in motion). A real plan (skimage's coffee, the one of
``tests/driver/real_plan.py``) is streamed, a fault strikes at one of ``--positions`` board lines
spread over the job, and the job is resumed until it ends: first with nobody at the machine,
then, if that is refused because the position is lost, with a hand that jogs to the mark. The
drawing is then compared with the uninterrupted run's, segment by segment to 1 µm
(``tests/driver/segments.py``).

Fault kinds: Ctrl-C, SIGTERM, SIGHUP (signals the virtual plotter sends this process when the
line arrives: ``interrupt@LINE:SIGNAL``), Ctrl-C mid-move (at a moment of the machine's clock
spread over the job, ``interrupt@SECONDSs``: anywhere inside a move, on the way out or back over
a stroke; not on the instant clock, which has no moments), a refused line, a hard-limit alarm, a soft reset
(ALARM:3 in motion), the port vanishing (then plugged back: the board is reset by the open),
and a power cycle. × GRBL and grblHAL × character counting and send-and-wait × the clock
(``tick``, the default: the virtual plotter's line clock, 10 ms of machine time per line
answered, so the machine is mid-move with its planner full when the fault strikes, the same in
every run; ``instant``: motion runs when the planner is full or a line waits for it;
``realtime``: 200× real time, which depends on the host's speed).

Prints JSON: ``runs``; ``tracebacks`` (anything but a PlotError; must be 0) with the first few;
``exact`` (stopped, resumed without help, drawing exact); ``refused_then_exact`` (the first
resume refused for a lost position, the guided one exact); ``finished`` (the fault did not stop
the job, drawing exact); ``redrawn`` (nothing missing and nothing off the drawing, but a
stretch of at most ``REDRAWN_MAX`` mm that the reference draws was drawn once more: a stop the
position alone cannot place, on a stroke that runs straight back over itself, with no answer,
report or count to tell the passes apart, resumes from the first pass); ``wrong`` (any other
difference) with the first few differences; ``failed``: the name of every wrong run and
traceback (``FIRMWARE-CLOCK-MODE-KIND-LINE``, to run again alone).
"Exact" is the uninterrupted run's pen-down segments to 1 µm, plus only the ink a coasting
carriage laid past the end of its move when the motors stopped dead (``with_overrun`` counts
those runs; the virtual plotter records that ink, which no sender can take back). A refused
line is put on the nearest dwell with character counting (the lines after it ran before the
stop, so a refused move would change the path itself), anywhere with send-and-wait.

Run: ``python bench/fault_sweep.py [--positions 50] [--clock tick,instant,realtime] [--jobs 6]``
(``--positions 5`` for a quick run).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import re
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "driver"))

from real_plan import plan_lines
from segments import drawing_differences

import sim
from pencilbot.driver import draw
from pencilbot.errors import PlotError
from sim import protocol_sim

sim.register()

WAKE_LINES = 4  # empty lines the driver's wake-up sends first (the board logs them)
KINDS = {
    "ctrl-c": "interrupt@{k}",
    "SIGTERM": "interrupt@{k}:15",
    "SIGHUP": "interrupt@{k}:1",
    "error": "error@{k}",
    "alarm": "alarm@{k}",
    "reset": "abort@{k}",
    "port drop": "drop@{k}",
    "power cycle": "reset@{k}",
    "ctrl-c mid-move": "interrupt@{k}s",  # at a moment of the machine's clock, not as a line arrives
}
#: Kinds that strike at a moment of the simulated clock: their positions are seconds into the job.
AT_A_MOMENT = {"ctrl-c mid-move"}
PROFILES = {"grbl": "grbl-servo-a4", "grblhal": "grblhal-servo-a3"}
CLOCKS = {"tick": "&tick=0.01", "instant": "", "realtime": "&realtime=200"}
#: mm: the longest stretch a ``redrawn`` run may draw once more than the reference.
REDRAWN_MAX = 0.01
_ONCE_MORE = re.compile(r"^(\d+\.\d+) mm of .* drawn \d+ times \(reference: ([1-9]\d*), drawn: \d+\)$")


class Hand:
    """Someone at the machine: jogs to the mark by where the carriage really is."""

    jog_step = 0.0  # by the exact float: the driver's own error is what the sweep measures

    def __init__(self, name: str):
        self.name = name

    def pause(self, prompt):
        pass

    def jog_to_mark(self, prompt, mark, jog):
        x, y, _ = protocol_sim.plotter(self.name).machine.carriage_position()
        jog(mark.xy[0] - x, mark.xy[1] - y)


def drawn(name: str):
    plotter = protocol_sim.plotter(name)
    plotter.firmware.finish()
    return plotter.machine.strokes


def one_run(lines, profile, name, spec, clock, send_and_wait, folder) -> tuple[str, str]:
    """(outcome, detail) of one fault and its resumes."""
    path = Path(folder) / f"{name}.gcode"
    path.write_text("\n".join(lines) + "\n")
    journal = f"{path}.job.json"
    options = dict(profile=profile, wake_wait=0.2, send_and_wait=send_and_wait)
    try:
        try:
            draw(path, f"sim://{name}?profile={profile}&faults={spec}{CLOCKS[clock]}", timeout=0.5, **options)
            return "finished", ""
        except PlotError:
            pass
        plotter = protocol_sim.plotter(name)
        plotter.firmware.faults.at.clear()
        plotter.firmware.silent = False
        refused = False
        try:
            draw(path, f"sim://{name}", resume=journal, timeout=2.0, **options)
        except PlotError as exc:
            if "position cannot be trusted" not in str(exc):
                return "wrong", f"resume failed: {exc}"
            refused = True
            draw(path, f"sim://{name}", resume=journal, timeout=2.0, operator=Hand(name), **options)
        return ("refused_then_exact" if refused else "exact"), ""
    except PlotError as exc:
        return "wrong", f"resume failed: {exc}"
    except Exception:  # noqa: BLE001 - what the sweep counts
        return "traceback", traceback.format_exc(limit=-3)


_REFERENCES: dict[str, tuple] = {}


def reference(firmware: str):
    """(lines, pen-down strokes of the uninterrupted run, board lines of the job's dwells)."""
    if firmware not in _REFERENCES:
        profile = PROFILES[firmware]
        lines = list(plan_lines(profile))
        name = f"sweep-ref-{firmware}"
        draw(lines, f"sim://{name}?profile={profile}", profile=profile, wake_wait=0.2)
        commands = [line.split(";")[0].strip() for line in lines]
        commands = [c for c in commands if c]
        dwells = np.array([i for i, c in enumerate(commands) if c.startswith("G4")]) + WAKE_LINES + 1
        _REFERENCES[firmware] = (
            lines,
            drawn(name),
            len(commands),
            dwells,
            protocol_sim.plotter(name).machine.clock,
        )
    return _REFERENCES[firmware]


def case(task) -> tuple[str, str, str, int]:
    """Run one (firmware, clock, mode, kind, board line) and judge it: (name, outcome, detail, overruns)."""
    firmware, clock, mode, kind, k, folder = task
    lines, ref, _, dwells, _ = reference(firmware)
    name = f"sweep-{firmware}-{clock}-{mode}-{kind}-{k}".replace(" ", "_")
    if kind == "error" and mode == "counting":
        # With lines in flight, the ones after a refused line run before the stop: a refused
        # move would leave a different path. A glitch on a dwell changes no stroke.
        k = int(dwells[np.argmin(np.abs(dwells - k))])
    outcome, detail = one_run(
        lines, PROFILES[firmware], name, KINDS[kind].format(k=k), clock, mode == "wait", folder
    )
    overruns = []
    if outcome in ("exact", "refused_then_exact", "finished"):
        # Ink a coasting carriage laid past a corner is there to stay: the rest must be exact.
        overruns = [np.array(o) for o in protocol_sim.plotter(name).machine.overruns]
        problems = drawing_differences(drawn(name), [*ref, *overruns])
        if problems:
            found = [_ONCE_MORE.match(p) for p in problems]
            redrawn = all(m is not None and float(m.group(1)) <= REDRAWN_MAX for m in found)
            outcome, detail = (
                ("redrawn" if redrawn else "wrong"),
                f"{len(problems)} differences: {problems[:3]}",
            )
    protocol_sim.forget(name)
    return name, outcome, detail, len(overruns)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--positions", type=int, default=50, help="fault positions spread over the job")
    parser.add_argument("--kinds", default=",".join(KINDS), help="fault kinds, comma-separated")
    parser.add_argument("--firmware", default=",".join(PROFILES), help="grbl, grblhal")
    parser.add_argument(
        "--clock", default="tick", help="tick (the line clock: deterministic), instant, realtime"
    )
    parser.add_argument("--modes", default="counting,wait", help="counting, wait (send-and-wait)")
    parser.add_argument(
        "--jobs", type=int, default=2, help="worker processes (runs mostly wait on the board)"
    )
    args = parser.parse_args()
    counts = {
        "runs": 0,
        "tracebacks": 0,
        "exact": 0,
        "refused_then_exact": 0,
        "finished": 0,
        "redrawn": 0,
        "wrong": 0,
        "with_overrun": 0,
    }
    examples: dict[str, list] = {"tracebacks": [], "wrong": [], "redrawn": []}
    failed: list[str] = []  # every wrong or traceback run, by name (firmware-clock-mode-kind-line)
    with tempfile.TemporaryDirectory() as folder:
        tasks = []
        for firmware in args.firmware.split(","):
            _, _, n, _, seconds = reference(firmware)
            lines = np.linspace(WAKE_LINES + 8, WAKE_LINES + n - 2, args.positions).round().astype(int)
            moments = np.linspace(0.5, seconds - 0.5, args.positions).round(3)
            tasks += [
                (firmware, clock, mode, kind, k.item(), folder)
                for clock in args.clock.split(",")
                for mode in args.modes.split(",")
                for kind in args.kinds.split(",")
                for k in (moments if kind in AT_A_MOMENT else lines)
                if not (kind in AT_A_MOMENT and clock == "instant")
            ]
        with multiprocessing.get_context("fork").Pool(args.jobs, maxtasksperchild=50) as pool:
            for name, outcome, detail, overruns in pool.imap_unordered(case, tasks, chunksize=4):
                key = "tracebacks" if outcome == "traceback" else outcome
                counts["runs"] += 1
                counts[key] += 1
                counts["with_overrun"] += overruns > 0
                if key in examples and len(examples[key]) < 8:
                    examples[key].append({"case": name, "detail": detail[-600:]})
                if key in ("wrong", "tracebacks"):
                    failed.append(name)
    print(
        json.dumps(
            {
                **counts,
                "positions": args.positions,
                "redrawn_max_mm": REDRAWN_MAX,
                "failed": sorted(failed),
                "examples": examples,
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
