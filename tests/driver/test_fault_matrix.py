"""Every way a plot is interrupted, on every kind of board, ends in exactly the drawing of an
uninterrupted run — or in a refusal until the position is re-established, and then exactly it.

Deterministic: every fault is delivered at an exact line by the virtual plotter (``faults=``:
a refused line, an alarm, a reset, a power cut, a dropped or unplugged cable, silence, noise, the
machine's hold button, and Ctrl-C, SIGTERM and SIGHUP as the signal the sender's process gets
when the board has taken that line: ``interrupt@LINE:SIGNAL``), and the plotter runs on the line
clock (``tick``: simulated time passes per line answered, never with the wall clock), so the
machine is at the same place, mid-move with its planner full, in every run on any machine. No
test starts a thread (the pty's server thread is joined by its context manager).

The drawing is a real plan (skimage's coffee, :mod:`real_plan`): multi-segment strokes, and at
the fault a stroke that runs back over itself (a point passed twice). Faults × board (keeps its
position through resets, or counts from 0, 0 after a power-up and lets the carriage coast on in
a reset or alarm in motion, as a real Arduino GRBL does). The drawings are compared as multisets
of pen-down segments to 1 µm (:mod:`segments`); ink a coasting carriage laid past the end of its
move (the virtual plotter records it) is the only ink allowed beyond the reference.
"""

import itertools
import json
import pathlib
import re

import numpy as np
import pytest
from real_plan import plan_lines
from segments import assert_same_drawing, drawing_differences
from test_stream_sim import HandOnTheMachine, drawn

from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line, track
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from sim import protocol_sim
from sim.faults import Faults
from sim.gcode.plotter import VirtualPlotter
from sim.pty_server import PtyServer

PROFILE = "grbl-servo-a4"
WAKE_LINES = 4  # empty lines the driver's wake-up sends first (the board logs them)
TICK = "tick=0.01"  # the line clock: 10 ms of machine time per line answered
_names = itertools.count()

BOARDS = {"keeps": "power=keep&abort=keep", "restarts": "power=zero&abort=lose"}

PLAN = list(plan_lines(PROFILE))
COMMANDS = [c for c in (clean_line(line) for line in PLAN) if c]


def _board_line(index: int) -> int:
    """The board's 1-based line number of job line ``index`` (after the wake-up's empty lines)."""
    return WAKE_LINES + index + 1


def _twice() -> int:
    """A move that runs back along the move before it (the stroke passes those points twice)."""
    states = track(COMMANDS, load_profile(PROFILE).pen_model)
    xy = np.stack([states.columns["x"], states.columns["y"]], axis=1)
    for i in range(len(COMMANDS) // 2, len(COMMANDS) - 1):
        if all(COMMANDS[j].startswith("G1") for j in (i - 1, i, i + 1)):
            u, v = xy[i] - xy[i - 1], xy[i + 1] - xy[i]
            if abs(u[0] * v[1] - u[1] * v[0]) < 1e-3 * np.linalg.norm(u) * np.linalg.norm(v) and u @ v < 0:
                return i + 1
    raise AssertionError("the plan has no stroke that runs back over itself")


TWICE = _twice()  # job line of the move back over the last one
DWELL = next(i for i in range(TWICE, len(COMMANDS)) if COMMANDS[i].startswith("G4"))  # its pen-up dwell
AFTER_DWELL = DWELL + 1  # the next travel: the board is idle when it arrives
TRAVEL = AFTER_DWELL + 1  # the pen-down command after it: the travel is queued (pen up)

#: fault → (sim fault, job line it hits)
SIM_FAULTS = {
    "error": ("error", DWELL),  # a line whose loss changes no stroke
    "alarm": ("alarm", TWICE + 2),
    "reset idle": ("abort", AFTER_DWELL),
    "reset in motion": ("abort", TWICE + 2),
    "reset in a travel": ("abort", TRAVEL),
    "power cycle": ("reset", TWICE + 2),
    "drop and reconnect": ("drop", TWICE + 2),
    "unplug": ("unplug", TWICE + 2),
    "silence": ("silent", TWICE + 2),
    "garbage": ("garbage", TWICE + 2),
    "Ctrl-C": ("interrupt", TWICE + 2),
    "Ctrl-C in a travel": ("interrupt", TRAVEL),
    "SIGTERM": ("interrupt:15", TWICE + 2),
    "SIGHUP": ("interrupt:1", TWICE + 2),
}
STOPPED_BY = {"Ctrl-C": "Ctrl-C", "Ctrl-C in a travel": "Ctrl-C", "SIGTERM": "SIGTERM", "SIGHUP": "SIGHUP"}
#: Faults after which no board can say where the pen is (or, on the board that restarts, where
#: it counts from): the resume must refuse until someone re-establishes the position.
LOST_ON_EVERY_BOARD = {"alarm", "reset in motion", "reset in a travel"}
LOST_ON_A_RESTARTING_BOARD = {"power cycle", "drop and reconnect", "unplug", "silence"}
#: The board pauses and someone at the machine answers (cycle start): the job never stops.
PAUSES = {"feed hold": "paused: feed hold on the machine", "M0": "paused: pen change: insert red"}


def spec(fault: str, line: int) -> str:
    kind, _, code = SIM_FAULTS[fault][0].partition(":")
    return f"{kind}@{_board_line(line)}" + (f":{code}" if code else "")


@pytest.fixture(scope="module")
def reference():
    name = f"matrix-ref{next(_names)}"
    draw(PLAN, f"sim://{name}?{TICK}", profile=PROFILE, wake_wait=0.2)
    return drawn(name)


def with_pen_change(after: int) -> list[str]:
    """The plan with a pen change (``M0``) after job line ``after``."""
    where = [i for i, line in enumerate(PLAN) if clean_line(line)][after]
    return [*PLAN[: where + 1], "M0 (pen change: insert red)", *PLAN[where + 1 :]]


#: For other tests of the driver (the keys): the plan, and a line it is drawing mid-stroke.
LINES, MOVING = PLAN, TWICE + 2


def with_overruns(reference, plotter) -> list:
    """The reference, and the ink a coasting carriage laid past the end of its move."""
    return [*reference, *(np.array(o) for o in plotter.machine.overruns)]


def resume_until_drawn(path, name, lost: bool) -> None:
    """Resume with nobody at the machine; if that is refused for a lost position, check that
    nothing was drawn meanwhile, then resume with someone who jogs to the mark."""
    plotter = protocol_sim.plotter(name)
    plotter.firmware.faults.at.clear()  # the glitch is over
    plotter.firmware.silent = False
    before = len(plotter.firmware.log)
    journal = f"{path}.job.json"
    try:
        draw(path, f"sim://{name}", resume=journal, wake_wait=0.2, timeout=2.0)
        refused = None
    except PlotError as exc:
        refused = str(exc)
    assert (refused is not None) == lost, refused
    if refused is not None:
        assert "position cannot be trusted" in refused and "jog the raised pen" in refused
        # A refusal sends no G-code (the wake-up's empty lines, nothing else).
        assert not any(line.text for line in list(plotter.firmware.log)[before:])
        draw(
            path,
            f"sim://{name}",
            resume=journal,
            wake_wait=0.2,
            timeout=2.0,
            operator=HandOnTheMachine(plotter),
        )


CASES = [(fault, board) for fault in [*SIM_FAULTS, *PAUSES] for board in BOARDS]


@pytest.mark.parametrize("fault, board", CASES)
def test_a_fault_ends_in_exactly_the_uninterrupted_drawing(tmp_path, reference, fault, board):
    path = tmp_path / "plot.gcode"
    lines = PLAN
    if fault == "M0":  # a pen change after the stroke that runs back over itself: it changes no stroke
        lines = with_pen_change(DWELL)
    path.write_text("\n".join(lines) + "\n")
    name = f"matrix{next(_names)}"
    url = f"sim://{name}?{BOARDS[board]}&{TICK}"
    if fault in PAUSES:
        if fault == "feed hold":
            url += f"&faults=hold@{_board_line(TWICE + 2)}"
        operator = HandOnTheMachine(None)
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.5, operator=operator)
        assert operator.prompts == [PAUSES[fault]]
        assert_same_drawing(drawn(name), reference)
        return
    url += f"&faults={spec(fault, SIM_FAULTS[fault][1])}"
    try:
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.3)
        stopped = False
    except PlotError as exc:
        stopped = True
        assert "Resume with: pencilbot draw --resume" in str(exc)
        if fault in STOPPED_BY:
            assert f"stopped by {STOPPED_BY[fault]}" in str(exc) and "pen raised" in str(exc)
    assert stopped == (fault != "garbage")  # noise between answers is not a fault
    if stopped:
        lost = fault in LOST_ON_EVERY_BOARD or (board == "restarts" and fault in LOST_ON_A_RESTARTING_BOARD)
        resume_until_drawn(path, name, lost)
    problems = drawing_differences(drawn(name), with_overruns(reference, protocol_sim.plotter(name)))
    if fault == "drop and reconnect":
        # The board ran on a little after the cable went, to a point its stroke passes twice (out
        # and back): nothing tells which pass it was on, and the resume takes the first, so a
        # stretch of the stroke may be drawn twice (never missing).
        problems = [p for p in problems if not re.search(r"^0\.0\d+ mm .* drawn \d times", p)]
    assert not problems, problems
    assert set(COMMANDS) <= set(protocol_sim.plotter(name).firmware.accepted_lines())


@pytest.mark.parametrize("fault", ["power cycle", "reset in motion", "Ctrl-C"])
def test_over_a_pty_a_board_that_restarts_at_zero_is_re_zeroed_and_drawn_exactly(tmp_path, reference, fault):
    # The same file-descriptor path as a USB adapter; opening the pty resets the board (DTR).
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(PLAN) + "\n")
    plotter = VirtualPlotter(
        load_profile(PROFILE),
        tick=0.01,
        faults=Faults.parse(spec(fault, TWICE + 2)),
        power="zero",
        abort="lose",
    )
    journal = f"{path}.job.json"
    with PtyServer(plotter) as server:
        with pytest.raises(PlotError, match="Resume with") as stop:
            draw(path, server.path, profile=PROFILE, wake_wait=0.2, timeout=5.0)  # (no silence: a bound)
        plotter.firmware.faults.at.clear()
        lost = fault != "Ctrl-C"
        assert ("cannot prove where the pen stopped" in str(stop.value)) == lost
        if lost:  # refused, nothing drawn, until re-zeroed
            before = len(drawn_by(plotter))
            with pytest.raises(PlotError, match="position cannot be trusted"):
                draw(path, server.path, resume=journal, wake_wait=0.2, timeout=2.0)
            assert len(drawn_by(plotter)) == before
        draw(
            path, server.path, resume=journal, wake_wait=0.2, timeout=2.0, operator=HandOnTheMachine(plotter)
        )
    assert_same_drawing(drawn_by(plotter), with_overruns(reference, plotter))


def drawn_by(plotter) -> list:
    plotter.firmware.finish()
    return plotter.machine.strokes


def test_a_resume_asks_for_the_pen_the_job_was_drawing_with_first(tmp_path, reference):
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(with_pen_change(DWELL)) + "\n")
    name = f"matrix{next(_names)}"
    # A pen change, then Ctrl-C in the stroke after it (the M0 shifted the lines by one).
    stroke = next(i for i in range(TRAVEL + 1, len(COMMANDS)) if COMMANDS[i].startswith("G1")) + 1
    operator = HandOnTheMachine(None)
    with pytest.raises(PlotError, match="stopped by Ctrl-C"):
        draw(
            path,
            f"sim://{name}?{TICK}&faults=interrupt@{_board_line(stroke + 2)}",
            profile=PROFILE,
            wake_wait=0.2,
            operator=operator,
        )
    assert operator.prompts == ["paused: pen change: insert red"]
    assert json.loads((tmp_path / "plot.gcode.job.json").read_text())["pen"] == "red"
    draw(path, f"sim://{name}", resume=f"{path}.job.json", wake_wait=0.2, operator=operator)
    assert operator.prompts[1] == "pen change: insert red (the pen the job was drawing with)"
    assert_same_drawing(drawn(name), reference)


def test_a_board_with_homing_is_homed_before_the_resume_instead_of_asking(tmp_path):
    import serial

    profile = tmp_path / "homing.toml"
    text = (pathlib.Path(__file__).parents[2] / "configs/plotters/grbl-servo-a4.toml").read_text()
    profile.write_text(
        text.replace('name = "grbl-servo-a4"', 'name = "homing-a4"').replace(
            "invert_y = false", "invert_y = false\nhoming = true"
        )
    )

    def homed(name: str) -> None:
        """Open the board (it powers up in Alarm: HOMING_INIT_LOCK) and home it."""
        with serial.serial_for_url(f"sim://{name}?profile={profile}&{TICK}", timeout=10) as port:
            port.write(b"$H\n")
            assert port.read_until(b"ok\r\n").endswith(b"ok\r\n")  # (the timeout: a broken board only)

    homed("home-ref")
    draw(PLAN, "sim://home-ref?reset=0", profile=str(profile), wake_wait=0.2)
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(PLAN) + "\n")
    homed("home1")
    protocol_sim.plotter("home1").firmware.faults = Faults.parse(f"interrupt@{_board_line(TWICE + 2) + 1}")
    with pytest.raises(PlotError, match="stopped by Ctrl-C"):  # ($H was line 1)
        draw(path, "sim://home1?reset=0", profile=str(profile), wake_wait=0.2)
    # Reopening resets the board: it counts from 0,0 and locks until homed. Nobody is asked.
    draw(path, "sim://home1", resume=f"{path}.job.json", wake_wait=0.2)
    assert "$H" in protocol_sim.plotter("home1").firmware.accepted_lines()[1:]
    assert_same_drawing(drawn("home1"), drawn("home-ref"))


def loop_drawing() -> list[str]:
    """Closed squares: each stroke ends where it began, so the start point is on two moves."""
    lines = ["G21", "G90", "M3 S30", "G4 P0.15"]
    for i in range(4):
        x, y = 40 + 30 * i, 60.0
        lines += [
            f"G0 X{x} Y{y}",
            "M3 S90",
            "G4 P0.2",
            f"G1 X{x + 10} Y{y} F3000",
            f"G1 X{x + 10} Y{y + 10}",
            f"G1 X{x} Y{y + 10}",
            f"G1 X{x} Y{y}",
            "M3 S30",
            "G4 P0.15",
        ]
    return lines


@pytest.mark.parametrize("clock", {"instant": "", "tick": f"&{TICK}"}.items())
def test_a_stop_where_a_closed_stroke_begins_resumes_at_its_start_not_after_its_end(tmp_path, clock):
    clock, options = clock
    # A reset when idle at the third square's start: that point also ends the square's last
    # move, which the driver had already sent (but the board had not yet parsed).
    lines = loop_drawing()
    draw(lines, f"sim://loop-ref-{clock}?reset=1{options}", profile=PROFILE, wake_wait=0.2)
    path = tmp_path / "loops.gcode"
    path.write_text("\n".join(lines) + "\n")
    first_move = 4 + 9 * 2 + 3  # the third square's first G1 arrives when the board is idle there
    name = f"loop-{clock}"
    with pytest.raises(PlotError, match="reset in the middle"):
        draw(
            path,
            f"sim://{name}?faults=abort@{WAKE_LINES + first_move + 1}{options}",
            profile=PROFILE,
            wake_wait=0.2,
        )
    draw(path, f"sim://{name}", resume=f"{path}.job.json", wake_wait=0.2)
    assert_same_drawing(drawn(name), drawn(f"loop-ref-{clock}"))


def test_a_z_pen_gets_its_height_back_with_the_origin_or_the_resume_refuses(tmp_path):
    from test_stream_sim import drawing

    profile = "grbl-z-a3"
    lines = drawing(profile=profile)
    draw(lines, f"sim://z-ref?profile={profile}", profile=profile, wake_wait=0.2)
    path = tmp_path / "z.gcode"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(PlotError, match="stopped by Ctrl-C.*pen raised"):
        draw(
            path,
            f"sim://z1?profile={profile}&{TICK}&faults=interrupt@{WAKE_LINES + 30}",
            profile=profile,
            wake_wait=0.2,
        )
    # The port's reset zeroed X, Y and Z where the raised pen stood: all three come back.
    draw(path, "sim://z1", resume=f"{path}.job.json", wake_wait=0.2)
    assert_same_drawing(drawn("z1"), drawn("z-ref"))

    path2 = tmp_path / "z2.gcode"
    path2.write_text("\n".join(lines) + "\n")
    with pytest.raises(PlotError, match="Resume with"):
        draw(
            path2, f"sim://z2?profile={profile}&faults=reset@30", profile=profile, wake_wait=0.2, timeout=0.5
        )
    plotter = protocol_sim.plotter("z2")
    plotter.firmware.faults.at.clear()
    with pytest.raises(PlotError, match="with a Z pen its height is lost too.*--start-line"):
        draw(path2, "sim://z2", resume=f"{path2}.job.json", wake_wait=0.2, operator=HandOnTheMachine(plotter))


class CtrlCAtThePause(HandOnTheMachine):
    """Presses Ctrl-C instead of cycle start when the board pauses."""

    def pause(self, prompt):
        raise KeyboardInterrupt


def test_the_planner_count_tells_which_pass_through_a_point_the_machine_stopped_on(tmp_path):
    # The hold button is pressed with a whole closed square planned and none of it run: the
    # machine stands at the square's start, which its last move ends at too. The board's
    # planner count (Bf:, with $10=3) says four moves were still to run: the square's.
    import serial

    lines = loop_drawing()
    draw(lines, "sim://bf-ref", profile=PROFILE, wake_wait=0.2)
    pen_up = 4 + 9 * 2 + 7  # after the third square's last G1
    with serial.serial_for_url(f"sim://bf1?faults=hold@{1 + WAKE_LINES + pen_up + 1}", timeout=10) as port:
        port.write(b"$10=3\n")  # report the buffer state (kept in EEPROM); the board's line 1
        assert port.read_until(b"ok\r\n").endswith(b"ok\r\n")
    path = tmp_path / "loops.gcode"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(PlotError, match="stopped by Ctrl-C"):
        draw(path, "sim://bf1", profile=PROFILE, wake_wait=0.2, operator=CtrlCAtThePause(None))
    assert json.loads((tmp_path / "loops.gcode.job.json").read_text())["next_line"] == 4 + 9 * 2 + 3 + 1
    draw(path, "sim://bf1", resume=f"{path}.job.json", wake_wait=0.2)
    assert_same_drawing(drawn("bf1"), drawn("bf-ref"))
