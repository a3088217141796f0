"""A stop signal to the studio during a plot (SIGINT, SIGTERM, SIGHUP, SIGQUIT), as a closed
terminal or a ``kill`` sends it: the server ends, the plot stops with the pen up, its G-code and
journal (status stopped) are kept out of the server's removed folder, the way to resume is said,
and the resume draws exactly what an uninterrupted plot draws (``signal_cases.studio_run``;
``bench/signal_sweep.py --studio`` at 20 moments).

The server runs in this process's main thread (only it gets signals); a helper thread starts the
plot through the page's API on the virtual plotter and, once lines are drawn, sends the signal.
A signal the studio does not catch reaches the test's own handler and fails the test.
"""

from __future__ import annotations

import signal
import sys
from pathlib import Path

import pytest

sys.path.insert(
    0, str(Path(__file__).resolve().parents[1] / "driver")
)  # the signal cases, the drawings' yardstick
import signal_cases

from pencilbot.driver.stop_signals import STOP_SIGNALS


@pytest.fixture
def guarded(monkeypatch):
    monkeypatch.setenv("XDG_STATE_HOME", "")  # set by the run; restored after
    saved = {signum: signal.signal(signum, signal_cases.guard) for signum in STOP_SIGNALS}
    yield
    for signum, handler in saved.items():
        signal.signal(signum, handler)


@pytest.mark.parametrize("signame", signal_cases.SIGNALS)
def test_a_signal_to_the_studio_mid_plot_stops_it_resumably(tmp_path, guarded, signame):
    fraction = 0.2 + 0.2 * list(signal_cases.SIGNALS).index(signame)  # a different moment for each
    outcome = signal_cases.studio_run(signame, fraction, tmp_path)
    assert (outcome.stopped, outcome.pen_up, outcome.journal_stopped, outcome.exact) == (
        True,
        True,
        True,
        True,
    ), outcome.detail
