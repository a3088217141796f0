"""Every stop signal at many moments of a real plot, on every family of board and the studio:
is the pen up, does the journal say stopped, is the resume exact?

The cases are ``tests/driver/signal_cases.py`` (the tests run a sample): the frozen coffee plan
on the virtual GRBL (the signal at a moment of its simulated clock, mid-move), EBB firmware 3.0.3
and 2.8.1 (as the board takes a command; half the moments with its FIFO full, half with all it
was sent already run, the stop inside a move of several commands), the HP 7475A (as an
instruction starts, on the poll clock), and ``pencilbot studio`` (served in the worker's main
thread, a plot on its virtual plotter, the signal once the machine runs a share of the job's
lines). A signal a driver does not catch reaches the worker's own handler: counted as not
stopped, never a dead worker.

Prints JSON: per family and signal, ``runs``, ``stopped`` (a message naming the signal and the
resume; for the studio: its folder removed and the plot kept), ``pen_up``, ``journal_stopped``,
``exact``; ``failed``: every run short of all four, with its detail.

Run: ``python bench/signal_sweep.py [--moments 20] [--signals SIGHUP,SIGTERM,SIGINT]
[--families grbl,ebb,ebb-2.8.1,hpgl,studio] [--jobs 2]``
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import signal
import sys
import tempfile
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "driver"))

import signal_cases

from pencilbot.driver.stop_signals import STOP_SIGNALS

FAMILIES = [*signal_cases.FAMILIES, "studio"]


def case(task) -> tuple[str, str, str, dict]:
    family, signame, moment, k = task
    saved = {signum: signal.signal(signum, signal_cases.guard) for signum in STOP_SIGNALS}
    try:
        return family, signame, f"{moment}", _judged(family, signame, moment, k)
    finally:
        for signum, handler in saved.items():
            signal.signal(signum, handler)


def _judged(family: str, signame: str, moment, k: int) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        try:
            if family == "studio":
                outcome = signal_cases.studio_run(signame, moment, Path(folder))
            else:
                outcome = signal_cases.run(
                    family, signame, moment, Path(folder), f"sweep-{family}-{signame}-{k}"
                )
            result = {
                "stopped": outcome.stopped,
                "pen_up": outcome.pen_up,
                "journal_stopped": outcome.journal_stopped,
                "exact": outcome.exact,
                "detail": outcome.detail,
            }
        except Exception:  # noqa: BLE001 - what the sweep counts
            result = {
                "stopped": False,
                "pen_up": False,
                "journal_stopped": False,
                "exact": False,
                "detail": traceback.format_exc(limit=-3),
            }
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--moments", type=int, default=20, help="moments per family and signal")
    parser.add_argument("--signals", default="SIGHUP,SIGTERM,SIGINT", help="signal names, comma-separated")
    parser.add_argument("--families", default=",".join(FAMILIES), help=", ".join(FAMILIES))
    parser.add_argument("--jobs", type=int, default=2, help="worker processes")
    args = parser.parse_args()
    signals = args.signals.split(",")
    tasks = []
    for family in args.families.split(","):
        if family == "studio":
            places = [round(0.05 + 0.9 * k / max(args.moments - 1, 1), 3) for k in range(args.moments)]
        else:
            places = signal_cases.moments(family, args.moments)
        tasks += [(family, s, place, k) for s in signals for k, place in enumerate(places)]
    table: dict = {}
    failed = []
    # The studio starts its planner's process: not from a pool's (daemonic) worker, so here.
    studio = [task for task in tasks if task[0] == "studio"]
    with multiprocessing.get_context("fork").Pool(args.jobs, maxtasksperchild=10) as pool:
        done = [*pool.imap_unordered(case, [task for task in tasks if task[0] != "studio"])]
    for family, signame, moment, result in [*done, *map(case, studio)]:
        row = table.setdefault(family, {}).setdefault(
            signame, {"runs": 0, "stopped": 0, "pen_up": 0, "journal_stopped": 0, "exact": 0}
        )
        row["runs"] += 1
        for key in ("stopped", "pen_up", "journal_stopped", "exact"):
            row[key] += bool(result[key])
        if not all(result[key] for key in ("stopped", "pen_up", "journal_stopped", "exact")):
            failed.append(
                {"case": f"{family}-{signame}@{moment}", **result, "detail": result["detail"][-400:]}
            )
    print(json.dumps({"moments": args.moments, "results": table, "failed": failed}, indent=1))


if __name__ == "__main__":
    main()
