"""A stop signal at a moment of a real plot, on each family of board: what the tests sample and
``bench/signal_sweep.py`` sweeps.

The plan is the frozen coffee of :mod:`real_plan` (the HP-GL family: the same plan written as
HP-GL). The signal is sent by the virtual board to this process at an exact place, so every run
strikes the same point: GRBL at a moment of its simulated clock (``interrupt@SECONDSs:SIGNAL``
on the line clock, mid-move with the planner full); an EBB as it takes a command
(``interrupt@COMMAND:SIGNAL``), half the moments on a board with its FIFO full and half on one
that has run all it was sent (the host fell behind: the stop is inside a move that had more
commands to come); HP-GL as an instruction starts, on the poll clock. After the stop: the pen
must be up on the board, the journal must say stopped (by that signal), the message must say how
to resume, and the resume must draw exactly the uninterrupted run's drawing.
"""

from __future__ import annotations

import json
import signal
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
from real_plan import plan_lines
from segments import drawing_differences

import sim
from pencilbot.driver import draw
from pencilbot.driver.stop_signals import STOP_SIGNALS
from pencilbot.errors import PlotError
from sim import protocol_sim

#: family → (profile, sim URL options, drawing tolerance mm)
FAMILIES = {
    "grbl": ("grbl-servo-a4", "tick=0.01", 0.001),
    "ebb": ("axidraw-v3", "", 0.0125),  # a step on the motors' diagonal: a resume starts on the step grid
    "ebb-2.8.1": ("axidraw-v3", "firmware=2.8.1", 0.0125),
    "hpgl": ("hp7475a", "tick=0.1", 0.0125),  # half a plotter unit
}
SIGNALS = {
    name: getattr(signal, name)
    for name in ("SIGINT", "SIGTERM", "SIGHUP", "SIGQUIT")
    if hasattr(signal, name)
}
DRAINED = "realtime=1e6"  # an EBB that runs at once what it takes: its FIFO drained when the signal comes


class SignalNotCaught(Exception):
    """A stop signal reached the test's own handler: the driver did not catch it."""


def guard(signum, _frame):
    raise SignalNotCaught(f"signal {signal.Signals(signum).name} was not caught by the driver")


@dataclass
class Outcome:
    stopped: bool  # the plot stopped (a PlotError naming the signal and the resume)
    pen_up: bool  # the board's pen after the stop
    journal_stopped: bool  # the journal says stopped, by this signal
    exact: bool  # the resume drew the uninterrupted drawing
    detail: str = ""


def _job(family: str, folder: Path) -> Path:
    profile = FAMILIES[family][0]
    if family == "hpgl":
        path = folder / "plot.hpgl"
        path.write_bytes(_hpgl())
    else:
        path = folder / "plot.gcode"
        path.write_text("\n".join(plan_lines(profile)) + "\n")
    return path


@cache
def _hpgl() -> bytes:
    """Coffee's plan (120 paths, as ``test_hpgl_fault_matrix`` plots it) as HP-GL."""
    import tempfile
    from dataclasses import replace

    import skimage.data

    from pencilbot import api
    from pencilbot.export.hpgl import write_hpgl
    from pencilbot.machine.profile import load_profile

    plan = api.plan(skimage.data.coffee()[::4, ::4])
    plan = replace(plan, layers=(replace(plan.layers[0], paths=plan.layers[0].paths[:120]),))
    with tempfile.TemporaryDirectory() as folder:
        target = Path(folder) / "coffee.hpgl"
        write_hpgl(plan, load_profile("hp7475a"), target)
        return target.read_bytes()


def _drawn(family: str, name: str) -> list[np.ndarray]:
    plotter = protocol_sim.plotter(name)
    if family == "hpgl":
        plotter.board.finish()
        return list(plotter.board.strokes)
    plotter.firmware.finish()
    return list(plotter.drawn()) if family.startswith("ebb") else list(plotter.machine.strokes)


def _pen_up(family: str, name: str) -> bool:
    plotter = protocol_sim.plotter(name)
    if family == "hpgl":
        plotter.board.finish()
        return not plotter.board.down
    plotter.firmware.finish()
    return bool(plotter.firmware.pen_up) if family.startswith("ebb") else not plotter.machine.pen_down


@cache
def _uninterrupted(family: str) -> tuple[list[np.ndarray], tuple[str, ...], float]:
    """The uninterrupted run: its drawing, the board's log, its simulated seconds (GRBL)."""
    import tempfile

    sim.register()
    profile, options, _ = FAMILIES[family]
    name = f"signal-ref-{family}"
    with tempfile.TemporaryDirectory() as folder:
        path = _job(family, Path(folder))
        draw(path, f"sim://{name}?profile={profile}" + (f"&{options}" if options else ""), profile=profile)
    plotter = protocol_sim.plotter(name)
    strokes = _drawn(family, name)
    log = plotter.board.log if family == "hpgl" else plotter.firmware.log
    seconds = plotter.machine.clock if family == "grbl" else 0.0
    protocol_sim.forget(name)
    return strokes, tuple(log), seconds


def reference(family: str) -> tuple[list[np.ndarray], list[str]]:
    """The uninterrupted drawing, and the places where a signal can strike (fault specs without
    the signal) in the job's order (see the module text)."""
    strokes, log, seconds = _uninterrupted(family)
    if family == "grbl":
        return strokes, [f"{t:.3f}s" for t in np.linspace(0.5, seconds - 0.5, 200)]
    kinds = ("PD", "PU") if family == "hpgl" else ("LM", "SP")
    return strokes, [str(k + 1) for k in range(len(log) // 20, len(log) - 2) if log[k].startswith(kinds)]


def moments(family: str, n: int = 20) -> list[str]:
    """``n`` fault places spread over the job (an EBB's alternate: FIFO full, FIFO drained)."""
    places = reference(family)[1]
    chosen = [places[int(i)] for i in np.linspace(0, len(places) - 1, n).round()]
    if family.startswith("ebb"):
        chosen = [p if k % 2 == 0 else f"{p}&{DRAINED}" for k, p in enumerate(chosen)]
    return chosen


def inside_a_move(family: str, n: int) -> list[int]:
    """EBB commands (1-based, as the board counts them) that are the first of a pen-down move
    made of several commands (accelerate, cruise, decelerate), ``n`` of them spread over the job."""
    from pencilbot.driver.ebb import moves as ebb_moves
    from pencilbot.driver.gcode.job import load_job
    from pencilbot.machine.profile import load_profile

    profile = load_profile("axidraw-v3")
    job = load_job(list(plan_lines(profile.name)), profile)
    xy, down, rows = ebb_moves.rows(job)
    work = [
        w
        for w in ebb_moves.plan_from(job, xy, down, rows, profile, 0, (0, 0), None, ebb_moves.job_dwells(job))
        if not isinstance(w, int)
    ]
    log = _uninterrupted(family)[1]
    at, k = [], 0  # the board's log holds the job's commands in order, among set-up and queries
    for i, text in enumerate(log):
        if k < len(work) and text == work[k].command:
            if (
                k + 1 < len(work)
                and work[k].down
                and text.startswith("LM")
                and work[k + 1].line == work[k].line
            ):
                at.append(i + 1)
            k += 1
    return [at[int(i)] for i in np.linspace(0, len(at) - 1, n).round()]


def run(family: str, signame: str, moment: str, folder: Path, name: str) -> Outcome:
    """Plot with ``signame`` striking at ``moment``; check the stop; resume; compare."""
    profile, options, tolerance = FAMILIES[family]
    place, _, extra = moment.partition("&")
    path = _job(family, folder)
    url = f"sim://{name}?profile={profile}" + "".join(f"&{o}" for o in (options, extra) if o)
    url += f"&faults=interrupt@{place}:{SIGNALS[signame]}"
    said = STOP_SIGNALS[SIGNALS[signame]]
    try:
        try:
            draw(path, url, profile=profile, timeout=2.0)
            return Outcome(False, _pen_up(family, name), False, False, "the plot did not stop")
        except PlotError as exc:
            message = str(exc)
        stopped = f"stopped by {said}" in message and ("Resume with" in message or "resume" in message)
        pen_up = _pen_up(family, name)
        journal = Path(f"{path}.job.json")
        record = json.loads(journal.read_text()) if journal.is_file() else {}
        journal_stopped = record.get("status") == "stopped" and said in record.get("message", "")
        plotter = protocol_sim.plotter(name)
        faults = (plotter.board if family == "hpgl" else plotter.firmware).faults
        getattr(faults, "at", faults).clear()  # the person has stopped pressing keys
        draw(path, f"sim://{name}", resume=str(journal), timeout=2.0)
        problems = drawing_differences(_drawn(family, name), reference(family)[0], tolerance)
        return Outcome(
            stopped,
            pen_up,
            journal_stopped,
            not problems,
            "" if stopped else message[:300] if not problems else f"{problems[:2]}",
        )
    except PlotError as exc:
        return Outcome(True, _pen_up(family, name), False, False, f"resume failed: {str(exc)[:300]}")
    finally:
        protocol_sim.forget(name)


class _FullPlan:
    """Stands for the studio planner's full stage: the library's plan of a small photo."""

    def __init__(self, plan):
        self.plan, self.generation, self.sketch_png = plan, 0, b""


@cache
def _studio_plan():
    from PIL import Image

    from pencilbot import api

    with __import__("tempfile").TemporaryDirectory() as folder:
        photo = Path(folder) / "bars.png"
        Image.fromarray(np.repeat(np.linspace(0, 255, 40, dtype=np.uint8)[None, :], 30, axis=0)).save(photo)
        return api.plan(photo, page="100x70", pen_width=1.0)


def studio_run(signame: str, fraction: float, folder: Path) -> Outcome:
    """``pencilbot studio`` served in this (main) thread, a plot on its virtual plotter, and
    ``signame`` sent to this process once the machine runs ``fraction`` of the job's lines.
    After the stop: the server's folder gone, the plot kept (its journal stopped, the way to
    resume said), the pen up; the resume exact. (Run in the main thread: only it gets signals.)"""
    import os
    import threading
    import urllib.request

    from pencilbot.driver.journal import load_journal
    from pencilbot.studio.server import prepare

    sim.register()
    profile = FAMILIES["grbl"][0]
    board = f"studio-{profile}"  # the studio's virtual plotter of this profile
    protocol_sim.forget(board)  # another test's drawing may be on it
    protocol_sim.forget("studio-ref")
    os.environ["XDG_STATE_HOME"] = str(folder / "state")  # where the kept plot goes
    running = prepare(None, listen_port=0, profile=profile, sim_speed=20.0)
    running.studio.results["full"] = _FullPlan(_studio_plan())
    seen: dict = {}

    def plot_then_signal():
        try:
            for _ in range(600):  # uvicorn listening (a 10 s bound)
                if running.server.started:
                    break
                threading.Event().wait(1 / 60)
            request = urllib.request.Request(
                running.url.rstrip("/") + "/api/plot",
                method="POST",
                data=json.dumps({"port": "sim://", "profile": profile}).encode(),
                headers={"X-Studio": "1", "Content-Type": "application/json"},
            )
            urllib.request.urlopen(request, timeout=60).close()
            session = running.studio.plotters.get("sim://")
            seen["gcode"] = session.gcode.read_text()
            lines = max(int(fraction * len(seen["gcode"].splitlines())), 1)
            while (session.record.get("running") or 0) < lines and session.active:
                running.studio.wait_change(running.studio.version, 5.0)  # woken by each progress record
            seen["active"] = session.active
        finally:
            os.kill(os.getpid(), SIGNALS[signame])

    helper = threading.Thread(target=plot_then_signal)
    helper.start()
    server_folder = running.studio.folder
    said = running.serve()
    helper.join()
    try:
        if not seen.get("active"):
            return Outcome(False, True, False, False, "the plot ended before the signal")
        kept = (
            len(said) == 1
            and "stopped with the pen up" in said[0]
            and "Resume with: pencilbot draw --resume" in said[0]
        )
        plotter = protocol_sim.plotter(board)
        plotter.firmware.finish()
        pen_up = not plotter.machine.pen_down
        if not kept:
            return Outcome(False, pen_up, False, False, f"said: {said}")
        journal_file = Path(said[0].split("--resume ", 1)[1].split(" --port")[0])
        journal = load_journal(journal_file)
        journal_stopped = journal.status == "stopped" and Path(journal.gcode).read_text() == seen["gcode"]
        draw(journal.gcode, f"sim://{board}", resume=str(journal_file))
        plotter.firmware.finish()
        draw(journal.gcode, f"sim://studio-ref?profile={profile}", profile=profile)
        reference_plotter = protocol_sim.plotter("studio-ref")
        reference_plotter.firmware.finish()
        problems = drawing_differences(
            list(plotter.machine.strokes), list(reference_plotter.machine.strokes), FAMILIES["grbl"][2]
        )
        return Outcome(not server_folder.exists(), pen_up, journal_stopped, not problems, f"{problems[:2]}")
    finally:
        protocol_sim.forget(board)
        protocol_sim.forget("studio-ref")
