"""Every way a plot is interrupted on an HP-GL plotter (HP 7475A) ends in exactly the drawing of
an uninterrupted run — or in a refusal until someone shows where the drawing stopped, and then
exactly it.

As :mod:`test_fault_matrix` does for GRBL: a real plan (coffee), each fault delivered by the
virtual 7475A as it starts an exact instruction (``faults=``: a lost answer, the RS-232 cable
pulled, a power cycle, and Ctrl-C, SIGTERM or SIGHUP as the signal the sender gets), on the poll clock
(``tick``: plotter time passes only per ``ESC.B`` answered), so the buffer holds the same
instructions at the fault in every run, whatever the host's speed. The drawings are compared as
multisets of pen-down segments (:mod:`segments`) to half a plotter unit: a resume from a point
inside a move puts it on the unit grid.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import hands
import pytest
import skimage.data
from segments import drawing_differences

import sim
from pencilbot import api
from pencilbot.driver import draw
from pencilbot.errors import PlotError
from pencilbot.export.hpgl import write_hpgl
from pencilbot.machine.profile import load_profile
from sim import protocol_sim

PROFILE = "hp7475a"
UNIT = load_profile(PROFILE).paper.unit_mm  # mm per plotter unit
TICK = "tick=0.1"  # plotter seconds per ESC.B: the buffer (1024 bytes) stays full while streaming
_names = itertools.count()

#: fault → (sim fault, how the first run ends (None: it does not stop), the resume is refused
#: until someone shows where the drawing stopped)
FAULTS = {
    "lost reply": ("silent", None, False),
    "unplug": ("unplug", "the port was lost", False),
    "power cycle": ("reset", "lost its place", True),
    # As the last line starts, everything sent: the pen homes where the program parks; the
    # status byte (OS) tells the loss.
    "power cycle at the last line": ("reset", "lost its place", True),
    "Ctrl-C": ("interrupt", "stopped by Ctrl-C; stopped after instruction", False),
    "SIGTERM": ("interrupt:15", "stopped by SIGTERM; stopped after instruction", False),
    "SIGHUP": ("interrupt:1", "stopped by SIGHUP; stopped after instruction", False),
}


@pytest.fixture(scope="module")
def job(tmp_path_factory):
    """Coffee's plan as HP-GL, what an uninterrupted run draws, and the instruction the faults
    strike: a pen-down move after the middle of the job."""
    sim.register()
    plan = api.plan(skimage.data.coffee()[::4, ::4])
    layer = plan.layers[0]
    plan = replace(plan, layers=(replace(layer, paths=layer.paths[:120]),))
    target = tmp_path_factory.mktemp("hpgl") / "coffee.hpgl"
    write_hpgl(plan, load_profile(PROFILE), target)
    draw(target, f"sim://hpgl-matrix-ref?profile={PROFILE}", profile=PROFILE)
    board = protocol_sim.plotter("hpgl-matrix-ref").board
    log = board.log
    strike = next(
        k for k in range(len(log) // 2, len(log)) if log[k].startswith("PD") and log[k - 1].startswith("PD")
    )
    last = max(k for k in range(len(log)) if log[k].startswith("PD") and log[k - 1].startswith("PD"))
    yield target.read_bytes(), board.strokes, strike + 1, last + 1  # the plotter counts instructions from 1
    protocol_sim.forget("hpgl-matrix-ref")


class Hand(hands.Hand):
    """Jogs the raised pen to the end of the last line on the sheet (looking at the sheet: the
    plotter's drawing)."""

    def sighted(self, mark):
        board = protocol_sim.plotter(self.name).board
        board.finish()
        return (board.x * UNIT, board.y * UNIT), board.strokes[-1][-1]


@pytest.mark.parametrize("fault", FAULTS)
def test_a_fault_ends_in_exactly_the_uninterrupted_drawing(tmp_path, job, fault):
    data, reference, strike, last = job
    strike = last if fault.endswith("at the last line") else strike
    path = tmp_path / "plot.hpgl"
    path.write_bytes(data)
    name = f"hpgl-matrix{next(_names)}"
    kind, stops, lost = FAULTS[fault]
    kind, _, code = kind.partition(":")
    url = f"sim://{name}?profile={PROFILE}&{TICK}&faults={kind}@{strike}" + (f":{code}" if code else "")
    if stops is None:
        draw(path, url, profile=PROFILE, timeout=1.0)
    else:
        with pytest.raises(PlotError, match=stops):
            draw(path, url, profile=PROFILE, timeout=1.0)
        board = protocol_sim.plotter(name).board
        board.faults.at.clear()  # the glitch is over
        if lost:
            board.finish()
            before = len(board.log)
            with pytest.raises(PlotError, match="cannot resume .* exactly.*Run the resume in a terminal"):
                draw(path, f"sim://{name}", resume=str(path))
            assert not any(i.startswith("PD") for i in board.log[before:])  # the refusal drew nothing
            hand = Hand(name)
            draw(path, f"sim://{name}", resume=str(path), operator=hand)
            assert len(hand.prompts) == 1 and "end of the last line" in hand.prompts[0]
        else:
            draw(path, f"sim://{name}", resume=str(path))
    board = protocol_sim.plotter(name).board
    board.finish()
    assert drawing_differences(board.strokes, reference, UNIT / 2) == []
    assert board.overflows == 0


def test_the_fault_strikes_with_instructions_waiting_in_the_buffer(job):
    # The poll clock keeps the buffer full: the stop's abort has work to throw away.
    data, _, strike, _ = job
    name = f"hpgl-matrix{next(_names)}"
    with pytest.raises(PlotError, match="stopped by Ctrl-C"):
        draw(data, f"sim://{name}?profile={PROFILE}&{TICK}&faults=interrupt@{strike}", profile=PROFILE)
    assert protocol_sim.plotter(name).board.discarded > 512
