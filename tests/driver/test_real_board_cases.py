"""The four cases real GRBL 1.1h (built for the host, on a pseudo-terminal) showed in issue 21,
each on the virtual plotter over sim:// and over a pty, on a real plan:

* a reset in motion (ALARM:3: the count is kept but cannot be trusted), pen up and pen down;
* the port vanishing while the firmware restarts (a power cut): the board is found again idle
  at 0, 0 with no banner, pen up and pen down.

Before the fix every resume after such a stop ended in ``IndexError: line N is not in this
track``. Now: without a terminal the resume refuses and draws nothing; with a person who
re-zeroes with the jog keys (0.1 mm at the finest, :mod:`hands`) it draws exactly what the
uninterrupted run drew. The board keeps its count true through the reset, as the host build of
real GRBL does (``abort=keep``: there is no carriage to coast), so a hand that is within half
a step of the mark is corrected by the count.
"""

import itertools
import threading

import pytest
from hands import SteppedHand
from real_plan import plan_lines
from segments import assert_same_drawing
from test_stream_sim import drawn

from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from sim import protocol_sim
from sim.faults import Faults
from sim.gcode.plotter import VirtualPlotter
from sim.pty_server import PtyServer

PROFILE = "grbl-servo-a4"
WAKE_LINES = 4  # empty lines the driver's wake-up sends first (the board logs them)
BOARD = "power=zero&abort=keep"  # real GRBL on a pty: counts from 0, 0 after a restart
_names = itertools.count()


def board_lines():
    """Board lines (1-based, after the wake-up) where the faults strike: the pen-down command
    after a travel (the travel queued: pen up), and the fifth move of a long stroke (pen down)."""
    commands = [c for c in (clean_line(line) for line in plan_lines(PROFILE)) if c]
    up = next(
        i for i in range(1, len(commands)) if commands[i - 1].startswith("G0") and i > len(commands) // 3
    )
    starts = [
        i
        for i in range(len(commands) - 8)
        if commands[i].startswith("G4")
        and all(c.startswith("G1") for c in commands[i + 1 : i + 8])
        and i > len(commands) // 2
    ]
    return {"pen up": WAKE_LINES + up + 1, "pen down": WAKE_LINES + starts[0] + 5 + 1}


AT = board_lines()
CASES = [(fault, pen) for fault in ("abort", "unplug") for pen in AT]


@pytest.fixture(scope="module")
def reference():
    name = f"real-ref{next(_names)}"
    draw(list(plan_lines(PROFILE)), f"sim://{name}?{BOARD}", profile=PROFILE, wake_wait=0.2)
    return drawn(name)


def resume_twice(path, port, plotter):
    """Without a terminal: refused, nothing drawn. With a hand on the jog keys: drawn."""
    before = len(plotter.machine.strokes)
    journal = f"{path}.job.json"
    with pytest.raises(PlotError, match="position cannot be trusted"):
        draw(path, port, resume=journal, wake_wait=0.2, timeout=2.0)
    assert len(plotter.machine.strokes) == before
    hand = SteppedHand(plotter)
    draw(path, port, resume=journal, wake_wait=0.2, timeout=2.0, operator=hand)
    assert "within 0.05 mm" in hand.prompts[-1]
    assert set(hand.keys.pressed) >= {"1", "\n"}  # it finished with the 0.1 mm step


@pytest.mark.parametrize("fault, pen", CASES)
def test_over_sim_a_lost_position_is_refused_then_re_zeroed_by_keys_and_drawn_exactly(
    tmp_path, reference, fault, pen
):
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(plan_lines(PROFILE)) + "\n")
    name = f"real{next(_names)}"
    with pytest.raises(PlotError, match="Resume with"):
        draw(
            path,
            f"sim://{name}?{BOARD}&faults={fault}@{AT[pen]}",
            profile=PROFILE,
            wake_wait=0.2,
            timeout=0.5,
        )
    plotter = protocol_sim.plotter(name)
    plotter.firmware.faults.at.clear()
    # A board whose port does not reset it (a pty, a USB adapter without DTR wired).
    resume_twice(path, f"sim://{name}?reset=0", plotter)
    assert_same_drawing(drawn(name), reference)


@pytest.mark.parametrize("fault, pen", CASES)
def test_over_a_pty_a_lost_position_is_refused_then_re_zeroed_by_keys_and_drawn_exactly(
    tmp_path, reference, fault, pen
):
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(plan_lines(PROFILE)) + "\n")
    plotter = VirtualPlotter(
        load_profile(PROFILE), faults=Faults.parse(f"{fault}@{AT[pen]}"), power="zero", abort="keep"
    )
    with PtyServer(plotter, reset_on_open=False) as server:
        with pytest.raises(PlotError, match="Resume with"):
            draw(path, server.path, profile=PROFILE, wake_wait=0.2, timeout=5.0)  # (a bound: no silence here)
        # An unplugged cable: the server plugs the board back in on a new pty, in its own thread;
        # the resume goes to that one (its path is set before the dropped link is cleared).
        replugged = threading.Event()
        server.on_new_path = lambda _: replugged.set()
        assert not plotter.firmware.link_dropped or replugged.wait(10)
        plotter.firmware.faults.at.clear()
        resume_twice(path, server.path, plotter)
    plotter.firmware.finish()
    assert_same_drawing(plotter.machine.strokes, reference)
