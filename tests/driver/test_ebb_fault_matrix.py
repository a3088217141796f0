"""Every way a plot is interrupted on an EBB plotter (AxiDraw V3) ends in exactly the drawing of
an uninterrupted run — or in a refusal until the position is re-established, and then exactly it.

As :mod:`test_fault_matrix` does for GRBL: a real plan (coffee, :mod:`real_plan`), each fault
delivered by the virtual EBB (firmware 3.0.3 and 2.8.1) at an exact command (``faults=``: a lost answer, the cable pulled
with the board's power, a power cut, and Ctrl-C, SIGTERM or SIGHUP as the signal the sender gets once
the board took that command); the board runs instantly and only as far as the sender's
commands and queries take it, and the driver's status queries come by the motion it sent, not
by the clock, so every run strikes the same command at the same place. The drawings are
compared as multisets of pen-down segments (:mod:`segments`) to a quarter of the issue's
0.05 mm: a resume starts on the motor-step grid, a step (1/80 mm along a motor's diagonal) from
the straight line the uninterrupted move drew.
"""

from __future__ import annotations

import itertools

import hands
import numpy as np
import pytest
from real_plan import plan_lines
from segments import drawing_differences

import sim
from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.errors import PlotError
from sim import protocol_sim

PROFILE = "axidraw-v3"
TOLERANCE = 0.0125  # mm: a quarter of the 0.05
PLAN = list(plan_lines(PROFILE))
_names = itertools.count()

#: fault → (sim fault, the resume is refused until someone re-zeroes)
FAULTS = {
    "lost reply": ("silent", False),
    "unplug": ("unplug", True),
    "power cycle": ("reset", True),
    "Ctrl-C": ("interrupt", False),
    "SIGTERM": ("interrupt:15", False),
    "SIGHUP": ("interrupt:1", False),  # the terminal closed: as Ctrl-C (it left the pen down before)
}
STOPPED_BY = {
    "Ctrl-C": "stopped by Ctrl-C",
    "SIGTERM": "stopped by SIGTERM",
    "SIGHUP": "stopped by SIGHUP",
    "lost reply": "did not answer",
    "unplug": "did not report where the pen stopped",
    "power cycle": "position is lost",
}


def drawn(name: str) -> list[np.ndarray]:
    plotter = protocol_sim.plotter(name)
    plotter.firmware.finish()
    return list(plotter.drawn())


#: The firmware versions the matrix runs on: 3.0.3, and 2.8.1 (its five-field ``ES``, no ``QU``,
#: a one-deep FIFO).
FIRMWARES = ("3.0.3", "2.8.1")


@pytest.fixture(scope="module", params=FIRMWARES)
def reference(request):
    """The uninterrupted drawing on that firmware, the command the faults strike (an LM in the
    middle of the job, drawing: the last SP before it lowered the pen), and the firmware."""
    sim.register()
    firmware = request.param
    name = f"ebb-matrix-ref-{firmware}"
    draw(PLAN, f"sim://{name}?profile={PROFILE}&firmware={firmware}", profile=PROFILE)
    log = protocol_sim.plotter(name).firmware.log
    strike = next(
        k
        for k in range(len(log) // 2, len(log))
        if log[k].startswith("LM")
        and next(c for c in reversed(log[:k]) if c.startswith("SP,")).startswith("SP,0")
    )
    yield drawn(name), strike + 1, firmware  # the board counts commands from 1
    protocol_sim.forget(name)


class Hand(hands.Hand):
    """Jogs to the mark by looking at where the carriage really is (the board's count is lost:
    that is why it is asked)."""

    def sighted(self, mark):
        return protocol_sim.plotter(self.name).position(), mark.xy


@pytest.mark.parametrize("fault", FAULTS)
def test_a_fault_ends_in_exactly_the_uninterrupted_drawing(tmp_path, reference, fault):
    strokes, strike, firmware = reference
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(PLAN) + "\n")
    name = f"ebb-matrix{next(_names)}"
    kind, lost = FAULTS[fault]
    kind, _, code = kind.partition(":")
    with pytest.raises(PlotError) as stopped:
        draw(
            path,
            f"sim://{name}?profile={PROFILE}&firmware={firmware}&faults={kind}@{strike}"
            + (f":{code}" if code else ""),
            profile=PROFILE,
            timeout=0.5,
        )
    assert STOPPED_BY[fault] in str(stopped.value) and "Resume with: pencilbot draw --resume" in str(
        stopped.value
    )
    plotter = protocol_sim.plotter(name)
    plotter.firmware.faults.clear()  # the glitch is over
    journal = f"{path}.job.json"
    if lost:
        before, log = len(drawn(name)), len(plotter.firmware.log)
        with pytest.raises(PlotError, match="position is lost.*nothing was sent.*jog the raised pen"):
            draw(path, f"sim://{name}", resume=journal)
        assert len(drawn(name)) == before  # the refusal drew nothing, and moved nothing:
        assert not any(c[:2] in ("LM", "SM", "XM", "HM", "SP") for c in plotter.firmware.log[log:])
        hand = Hand(name)
        draw(path, f"sim://{name}", resume=journal, operator=hand)
        assert len(hand.prompts) == 1 and "Jog the raised pen" in hand.prompts[0]
    else:
        draw(path, f"sim://{name}", resume=journal)
    assert drawing_differences(drawn(name), strokes, TOLERANCE) == []


def test_a_pen_change_pauses_and_the_drawing_is_the_same(tmp_path, reference):
    strokes, _, firmware = reference
    at = len(PLAN) // 2
    while not clean_line(PLAN[at]).startswith("M280P0S60"):  # after a pen lift: it changes no stroke
        at += 1
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join([*PLAN[: at + 1], "M0 (pen change: insert red)", *PLAN[at + 1 :]]) + "\n")
    name = f"ebb-matrix{next(_names)}"
    hand = Hand(name)
    draw(path, f"sim://{name}?profile={PROFILE}&firmware={firmware}", profile=PROFILE, operator=hand)
    assert hand.prompts == ["paused: pen change: insert red"]
    assert drawing_differences(drawn(name), strokes, TOLERANCE) == []
