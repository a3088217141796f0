"""A host that stalls (a loaded machine, a suspended process) is not a silent board: the driver
counts as silence only the time it spent listening, so a stall between reads, however long,
never stops a plot with "the plotter stopped answering" — and a board that really is silent is
still caught.

The stalls are made on the driver's own clock (no test waits on the wall clock for them): after
every read, the clock the driver reads jumps STALL seconds, as if the process had been
descheduled that long before it went on.
"""

from __future__ import annotations

import itertools
import time

import pytest
from real_plan import plan_lines
from segments import drawing_differences

import sim
from pencilbot.driver import draw, port
from pencilbot.driver.ebb import link as ebb_link
from pencilbot.driver.gcode import session
from pencilbot.errors import PlotError
from sim import protocol_sim

STALL = 30.0  # s the host is away after each read: far past any timeout below
_names = itertools.count()


class StalledClock:
    """``time`` as the driver's modules see it: the real clock plus the stalls so far."""

    def __init__(self):
        self.away = 0.0

    def monotonic(self) -> float:
        return time.monotonic() + self.away

    def __getattr__(self, name):
        return getattr(time, name)


@pytest.fixture
def stalls(monkeypatch):
    clock = StalledClock()
    for module in (port, session, ebb_link):  # the modules that read the clock
        monkeypatch.setattr(module, "time", clock)
    read_lines = port.LineReader.read_lines

    def read_then_stall(self):
        lines = read_lines(self)
        clock.away += STALL
        return lines

    monkeypatch.setattr(port.LineReader, "read_lines", read_then_stall)
    sim.register()
    return clock


def _drawn(name: str, ebb: bool):
    plotter = protocol_sim.plotter(name)
    plotter.firmware.finish()
    strokes = list(plotter.drawn()) if ebb else list(plotter.machine.strokes)
    protocol_sim.forget(name)
    return strokes


@pytest.mark.parametrize("profile, options", [("grbl-servo-a4", "tick=0.01"), ("axidraw-v3", "")])
def test_a_stalled_host_finishes_the_plot(stalls, profile, options):
    lines = list(plan_lines(profile))[:400]
    ebb = profile == "axidraw-v3"
    reference = f"stall-ref{next(_names)}"
    draw(lines, f"sim://{reference}?profile={profile}&{options}", profile=profile)
    stalls.away = 0.0
    name = f"stall{next(_names)}"
    draw(lines, f"sim://{name}?profile={profile}&{options}", profile=profile, timeout=2.0)
    assert stalls.away > 10 * STALL  # the host was away far longer than the timeout, many times
    assert drawing_differences(_drawn(name, ebb), _drawn(reference, ebb), 0.001) == []


@pytest.mark.parametrize("profile, options", [("grbl-servo-a4", "tick=0.01"), ("axidraw-v3", "")])
def test_a_silent_board_is_still_caught(stalls, profile, options):
    name = f"stall{next(_names)}"
    with pytest.raises(PlotError, match="stopped answering|did not answer"):
        draw(
            list(plan_lines(profile))[:400],
            f"sim://{name}?profile={profile}&{options}&faults=silent@60",
            profile=profile,
            timeout=1.0,
        )
    protocol_sim.forget(name)
