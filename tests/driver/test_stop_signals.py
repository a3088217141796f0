"""Every stop signal, on every family of board, stops a plot safely: the pen up, the journal
written as stopped by that signal, the way to resume said, and the resume exact
(:mod:`signal_cases`; ``bench/signal_sweep.py`` runs every signal at 20 moments of each).

A signal the driver does not catch reaches this module's own handler (installed around every
test, whatever the process was started with: a shell's ``trap '' INT``, ``nohup``) and fails the
test instead of ending pytest.
"""

from __future__ import annotations

import itertools
import signal

import pytest
import signal_cases
from signal_cases import FAMILIES, SIGNALS, SignalNotCaught, guard, moments, run

import sim
from pencilbot.driver import draw
from pencilbot.driver.stop_signals import STOP_SIGNALS
from sim import protocol_sim

_names = itertools.count()


@pytest.fixture(autouse=True)
def guarded():
    sim.register()
    saved = {signum: signal.signal(signum, guard) for signum in STOP_SIGNALS}
    yield
    for signum, handler in saved.items():
        signal.signal(signum, handler)


def test_the_table_holds_every_stop_signal():
    assert set(SIGNALS.values()) <= set(STOP_SIGNALS) and len(STOP_SIGNALS) == 4


@pytest.mark.parametrize("family", FAMILIES)
@pytest.mark.parametrize("signame", SIGNALS)
def test_a_signal_stops_with_the_pen_up_and_the_resume_is_exact(tmp_path, family, signame):
    # A different moment for each signal: four places of the job per family.
    moment = moments(family, len(SIGNALS))[list(SIGNALS).index(signame)]
    outcome = run(family, signame, moment, tmp_path, f"signals{next(_names)}")
    assert (outcome.stopped, outcome.pen_up, outcome.journal_stopped, outcome.exact) == (
        True,
        True,
        True,
        True,
    ), outcome.detail


@pytest.mark.parametrize("firmware", ["ebb", "ebb-2.8.1"])
@pytest.mark.parametrize("which", range(3))
def test_an_ebb_stop_inside_a_move_resumes_at_the_rest_of_that_move(tmp_path, firmware, which):
    # The board has run all it was sent (the host fell behind), the last command the first part
    # of a longer move: the resume draws the rest of that move, not a chord to the next corner.
    at = signal_cases.inside_a_move(firmware, 3)[which]
    outcome = run(firmware, "SIGINT", f"{at}&{signal_cases.DRAINED}", tmp_path, f"signals{next(_names)}")
    assert outcome.exact, outcome.detail


def test_under_nohup_a_closed_terminal_does_not_stop_the_plot(tmp_path):
    strokes = signal_cases.reference("ebb")[0]
    signal.signal(signal.SIGHUP, signal.SIG_IGN)  # as nohup starts a process
    name = f"signals{next(_names)}"
    at = signal_cases.inside_a_move("ebb", 1)[0]
    draw(
        list(signal_cases.plan_lines("axidraw-v3")),
        f"sim://{name}?profile=axidraw-v3&faults=interrupt@{at}:1",
        profile="axidraw-v3",
    )
    assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN  # left as it was
    assert signal_cases.drawing_differences(signal_cases._drawn("ebb", name), strokes, 0.0125) == []
    protocol_sim.forget(name)


def test_the_guard_sees_a_signal_nobody_catches():
    with pytest.raises(SignalNotCaught):
        signal.raise_signal(signal.SIGHUP)
