"""Every way a plot is interrupted, on every kind of board, ends in exactly the drawing of an
uninterrupted run — or in a refusal until the position is re-established, and then exactly it.

Faults × clock (real time at a large speed-up, so moves are still queued when the fault comes;
instant, where that matters) × board (keeps its position through resets, or counts from 0, 0
after a power-up and loses it in a reset or alarm in motion, as a real Arduino GRBL does). The drawings are
compared as multisets of pen-down segments to 1 µm (:mod:`segments`).

The drawing is strokes of one long segment each, with the pen's dwells: a board that loses its
position lets the carriage coast on after a reset in motion (v²/2a), and a coast that stays on
the segment being drawn can be drawn exactly once by the resume; one that ran past a corner
would be ink off the job's path, which no sender can take back.
"""

import _thread
import itertools
import json
import os
import pathlib
import signal
import threading

import numpy as np
import pytest
from test_stream_sim import HandOnTheMachine, drawn

from pencilbot.driver import draw
from pencilbot.driver.modal import clean_line
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from sim import protocol_sim
from sim.firmware import Faults
from sim.protocol_sim import VirtualPlotter
from sim.pty_server import PtyServer
from segments import assert_same_drawing

PROFILE = "grbl-servo-a4"
WAKE_LINES = 4  # empty lines the driver's wake-up sends first (the board logs them)
_names = itertools.count()

BOARDS = {"keeps": "power=keep&abort=keep", "restarts": "power=zero&abort=lose"}
CLOCKS = {"instant": "", "realtime": "&realtime=200"}


def matrix_drawing() -> list[str]:
    """Ten strokes, each one straight 12-20 mm segment, with the profile's pen commands and dwells."""
    rng = np.random.default_rng(7)
    lines = ["G21", "G90", "M3 S30", "G4 P0.15"]
    for i in range(10):
        x, y = 30 + 15 * (i % 5), 40 + 40 * (i // 5)
        angle, length = rng.uniform(0, 2 * np.pi), rng.uniform(12, 20)
        lines += [f"G0 X{x:.3f} Y{y:.3f}", "M3 S90", "G4 P0.2",
                  f"G1 X{x + length * np.cos(angle):.3f} Y{y + length * np.sin(angle):.3f} F3000",
                  "M3 S30", "G4 P0.15"]
    return lines


LINES = matrix_drawing()
CLEAN = [clean_line(line) for line in LINES]
MID = 4 + 6 * 5 + 3  # the G1 of the sixth stroke (0-based job index: 4 header lines, 6 a stroke)
MOVING = MID + 1  # the pen-up after it: arrives while that move is queued or under way
DWELL_BEFORE_TRAVEL = MID + 2  # its pen-up dwell (G4 P0.15): a line whose loss changes no stroke
AFTER_DWELL = MID + 3  # the next travel: the board is idle when it arrives

#: fault → (sim fault kind, job line it hits)
SIM_FAULTS = {
    "error": ("error", DWELL_BEFORE_TRAVEL),
    "alarm": ("alarm", MOVING),
    "reset idle": ("abort", AFTER_DWELL),
    "reset in motion": ("abort", MOVING),
    "power cycle": ("reset", MOVING),
    "drop and reconnect": ("drop", MOVING),
    "silence": ("silent", MOVING),
    "garbage": ("garbage", MOVING),
}
#: Faults after which no board can say where the pen is (or, on the board that restarts, where
#: it counts from): the resume must refuse until someone re-establishes the position.
LOST_ON_EVERY_BOARD = {"alarm", "reset in motion"}
LOST_ON_A_RESTARTING_BOARD = {"power cycle", "drop and reconnect", "silence"}


@pytest.fixture(scope="module")
def reference():
    name = f"matrix-ref{next(_names)}"
    draw(LINES, f"sim://{name}", profile=PROFILE, wake_wait=0.2)
    return drawn(name)


def interrupt_at(name, board_line: int, times: int = 1, signum: int | None = None) -> None:
    """Press Ctrl-C ``times`` (0.05 s apart; or send ``signum`` to this process) once the board
    (``sim://name``, or a :class:`VirtualPlotter`) has received ``board_line`` lines."""

    def received() -> int:
        try:
            return len((protocol_sim.plotter(name) if isinstance(name, str) else name).firmware.log)
        except KeyError:
            return 0

    def press():
        while received() < board_line:
            threading.Event().wait(0.002)
        for _ in range(times):
            if finished.is_set():
                return  # too late: the job ended (an interrupt now would hit the test run)
            if signum is None:
                _thread.interrupt_main()
            else:
                os.kill(os.getpid(), signum)
            threading.Event().wait(0.05)

    finished = threading.Event()
    threading.Thread(target=press, daemon=True).start()
    return finished


def resume_until_drawn(path, name, lost: bool) -> None:
    """Resume with nobody at the machine; if that is refused for a lost position, check that
    nothing was drawn meanwhile, then resume with someone who jogs to the mark."""
    plotter = protocol_sim.plotter(name)
    plotter.firmware.faults.at.clear()  # the glitch is over
    plotter.firmware.silent = False
    before = len(drawn(name))
    journal = f"{path}.job.json"
    try:
        draw(path, f"sim://{name}", resume=journal, wake_wait=0.2, timeout=2.0)
        refused = None
    except PlotError as exc:
        refused = str(exc)
    assert (refused is not None) == lost, refused
    if refused is not None:
        assert "position cannot be trusted" in refused and "jog the raised pen" in refused
        assert len(drawn(name)) == before  # a refusal draws nothing
        draw(path, f"sim://{name}", resume=journal, wake_wait=0.2, timeout=2.0, operator=HandOnTheMachine(plotter))


#: Someone stops the plot: Ctrl-C (twice: the second lands in the stop sequence), a kill, a
#: closed terminal.
STOPS = {"ctrl-c": (None, 1), "ctrl-c twice": (None, 2), "SIGTERM": (signal.SIGTERM, 1), "SIGHUP": (signal.SIGHUP, 1)}
#: The board pauses and someone at the machine answers (cycle start): the job never stops.
PAUSES = {"feed hold": "paused: feed hold on the machine", "M0": "paused: pen change: insert red"}


#: Every fault on both boards in real time (moves still queued when it strikes); on the instant
#: clock (the board has run all it took), those whose outcome depends on what was queued, on
#: the board that loses its position.
INSTANT = ("error", "alarm", "reset in motion", "power cycle", "drop and reconnect")
CASES = [(fault, "realtime", board) for fault in [*SIM_FAULTS, *STOPS, *PAUSES] for board in BOARDS] + [
    (fault, "instant", "restarts") for fault in INSTANT]


@pytest.mark.parametrize("fault, clock, board", CASES)
def test_a_fault_ends_in_exactly_the_uninterrupted_drawing(tmp_path, reference, fault, clock, board):
    path = tmp_path / "plot.gcode"
    lines = LINES
    if fault == "M0":  # a pen change after the sixth stroke: it changes no stroke
        lines = [*LINES[: DWELL_BEFORE_TRAVEL + 1], "M0 (pen change: insert red)", *LINES[DWELL_BEFORE_TRAVEL + 1:]]
    path.write_text("\n".join(lines) + "\n")
    name = f"matrix{next(_names)}"
    url = f"sim://{name}?{BOARDS[board]}{CLOCKS[clock]}"
    if fault in PAUSES:
        if fault == "feed hold":
            url += f"&faults=hold@{WAKE_LINES + MOVING + 1}"
        operator = HandOnTheMachine(None)
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.5, operator=operator)
        assert operator.prompts == [PAUSES[fault]]
        assert_same_drawing(drawn(name), reference)
        return
    finished = threading.Event()
    if fault in STOPS:
        signum, times = STOPS[fault]
        finished = interrupt_at(name, WAKE_LINES + MOVING + 1, times, signum)
    else:
        kind, line = SIM_FAULTS[fault]
        url += f"&faults={kind}@{WAKE_LINES + line + 1}"
    try:
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.3)
        finished.set()
        stopped = False
    except PlotError as exc:
        finished.set()
        stopped = True
        assert "Resume with: pencilbot draw --resume" in str(exc)
        if fault in STOPS:
            assert f"stopped by {STOPS[fault][0] and STOPS[fault][0].name or 'Ctrl-C'}" in str(exc)
            assert "pen raised" in str(exc)
    assert stopped == (fault != "garbage")  # noise between answers is not a fault
    if stopped:
        lost = fault in LOST_ON_EVERY_BOARD or (board == "restarts" and fault in LOST_ON_A_RESTARTING_BOARD)
        resume_until_drawn(path, name, lost)
    assert_same_drawing(drawn(name), reference)
    assert set(CLEAN) <= set(protocol_sim.plotter(name).firmware.accepted_lines())


@pytest.mark.parametrize("fault", ["power cycle", "reset in motion", "ctrl-c"])
def test_over_a_pty_a_board_that_restarts_at_zero_is_re_zeroed_and_drawn_exactly(tmp_path, reference, fault):
    # The same file-descriptor path as a USB adapter; opening the pty resets the board (DTR).
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(LINES) + "\n")
    spec = "" if fault == "ctrl-c" else f"{SIM_FAULTS[fault][0]}@{WAKE_LINES + MOVING + 1}"
    # (A power cut loses the position wherever it strikes: the board counts from 0,0 again.)
    plotter = VirtualPlotter(load_profile(PROFILE), realtime=200, faults=Faults.parse(spec), power="zero",
                             abort="lose")
    journal = f"{path}.job.json"
    with PtyServer(plotter) as server:
        if fault == "ctrl-c":
            interrupt_at(plotter, WAKE_LINES + MOVING + 1)
        with pytest.raises(PlotError, match="Resume with") as stop:
            draw(path, server.path, profile=PROFILE, wake_wait=0.2, timeout=0.5)
        plotter.firmware.faults.at.clear()
        # (On a loaded machine the pty's clock may let the move finish before the reset comes:
        # then nothing was lost, and the stop says so.)
        if "cannot prove where the pen stopped" in str(stop.value):  # refused, nothing drawn, until re-zeroed
            assert fault != "ctrl-c"
            before = len(drawn_by(plotter))
            with pytest.raises(PlotError, match="position cannot be trusted"):
                draw(path, server.path, resume=journal, wake_wait=0.2, timeout=2.0)
            assert len(drawn_by(plotter)) == before
        draw(path, server.path, resume=journal, wake_wait=0.2, timeout=2.0, operator=HandOnTheMachine(plotter))
    assert fault == "ctrl-c" or "cannot prove" in str(stop.value) or fault == "reset in motion"
    assert fault != "power cycle" or "cannot prove" in str(stop.value)
    assert_same_drawing(drawn_by(plotter), reference)


def drawn_by(plotter) -> list:
    plotter.firmware.finish()
    return plotter.machine.strokes


def test_a_resume_asks_for_the_pen_the_job_was_drawing_with_first(tmp_path, reference):
    path = tmp_path / "plot.gcode"
    at = DWELL_BEFORE_TRAVEL + 1
    path.write_text("\n".join([*LINES[:at], "M0 (pen change: insert red)", *LINES[at:]]) + "\n")
    name = f"matrix{next(_names)}"
    # A pen change, then Ctrl-C after it (the eighth stroke's G1: the M0 shifted it by one).
    finished = interrupt_at(name, WAKE_LINES + MOVING + 1 + 12 + 1)
    operator = HandOnTheMachine(None)
    with pytest.raises(PlotError, match="stopped by Ctrl-C"):
        draw(path, f"sim://{name}?realtime=200", profile=PROFILE, wake_wait=0.2, operator=operator)
    finished.set()
    assert operator.prompts == ["paused: pen change: insert red"]
    assert json.loads((tmp_path / "plot.gcode.job.json").read_text())["pen"] == "red"
    draw(path, f"sim://{name}", resume=f"{path}.job.json", wake_wait=0.2, operator=operator)
    assert operator.prompts[1] == "pen change: insert red (the pen the job was drawing with)"
    assert_same_drawing(drawn(name), reference)


def test_a_board_with_homing_is_homed_before_the_resume_instead_of_asking(tmp_path):
    import serial

    profile = tmp_path / "homing.toml"
    text = (pathlib.Path(__file__).parents[2] / "configs/plotters/grbl-servo-a4.toml").read_text()
    profile.write_text(text.replace('name = "grbl-servo-a4"', 'name = "homing-a4"').replace(
        "invert_y = false", "invert_y = false\nhoming = true"))

    def homed(name: str) -> None:
        """Open the board (it powers up in Alarm: HOMING_INIT_LOCK) and home it."""
        with serial.serial_for_url(f"sim://{name}?profile={profile}&realtime=200", timeout=0.05) as port:
            port.write(b"$H\n")
            deadline = threading.Event()
            while b"ok" not in port.read(200) and not deadline.wait(0.01):
                pass

    homed("home-ref")
    draw(LINES, "sim://home-ref?reset=0", profile=str(profile), wake_wait=0.2)
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(LINES) + "\n")
    homed("home1")
    finished = interrupt_at("home1", WAKE_LINES + MOVING + 1 + 1)  # ($H was line 1)
    with pytest.raises(PlotError, match="stopped by Ctrl-C"):
        draw(path, "sim://home1?reset=0", profile=str(profile), wake_wait=0.2)
    finished.set()
    # Reopening resets the board: it counts from 0,0 and locks until homed. Nobody is asked.
    draw(path, "sim://home1", resume=f"{path}.job.json", wake_wait=0.2)
    assert "$H" in protocol_sim.plotter("home1").firmware.accepted_lines()[1:]
    assert_same_drawing(drawn("home1"), drawn("home-ref"))


def loop_drawing() -> list[str]:
    """Closed squares: each stroke ends where it began, so the start point is on two moves."""
    lines = ["G21", "G90", "M3 S30", "G4 P0.15"]
    for i in range(4):
        x, y = 40 + 30 * i, 60.0
        lines += [f"G0 X{x} Y{y}", "M3 S90", "G4 P0.2", f"G1 X{x + 10} Y{y} F3000", f"G1 X{x + 10} Y{y + 10}",
                  f"G1 X{x} Y{y + 10}", f"G1 X{x} Y{y}", "M3 S30", "G4 P0.15"]
    return lines


@pytest.mark.parametrize("clock", CLOCKS)
def test_a_stop_where_a_closed_stroke_begins_resumes_at_its_start_not_after_its_end(tmp_path, clock):
    # A reset when idle at the third square's start: that point also ends the square's last
    # move, which the driver had already sent (but the board had not yet parsed).
    lines = loop_drawing()
    draw(lines, f"sim://loop-ref-{clock}", profile=PROFILE, wake_wait=0.2)
    path = tmp_path / "loops.gcode"
    path.write_text("\n".join(lines) + "\n")
    first_move = 4 + 9 * 2 + 3  # the third square's first G1 arrives when the board is idle there
    name = f"loop-{clock}"
    with pytest.raises(PlotError, match="reset in the middle"):
        draw(path, f"sim://{name}?faults=abort@{WAKE_LINES + first_move + 1}{CLOCKS[clock]}", profile=PROFILE,
             wake_wait=0.2)
    draw(path, f"sim://{name}", resume=f"{path}.job.json", wake_wait=0.2)
    assert_same_drawing(drawn(name), drawn(f"loop-ref-{clock}"))


def test_a_z_pen_gets_its_height_back_with_the_origin_or_the_resume_refuses(tmp_path):
    from test_stream_sim import drawing

    profile = "grbl-z-a3"
    lines = drawing(profile=profile)
    draw(lines, f"sim://z-ref?profile={profile}", profile=profile, wake_wait=0.2)
    path = tmp_path / "z.gcode"
    path.write_text("\n".join(lines) + "\n")
    finished = interrupt_at("z1", WAKE_LINES + 30)
    with pytest.raises(PlotError, match="stopped by Ctrl-C.*pen raised"):
        draw(path, f"sim://z1?profile={profile}&realtime=200", profile=profile, wake_wait=0.2)
    finished.set()
    # The port's reset zeroed X, Y and Z where the raised pen stood: all three come back.
    draw(path, "sim://z1", resume=f"{path}.job.json", wake_wait=0.2)
    assert_same_drawing(drawn("z1"), drawn("z-ref"))

    path2 = tmp_path / "z2.gcode"
    path2.write_text("\n".join(lines) + "\n")
    with pytest.raises(PlotError, match="Resume with"):
        draw(path2, f"sim://z2?profile={profile}&faults=reset@30", profile=profile, wake_wait=0.2, timeout=0.5)
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
    with serial.serial_for_url(f"sim://bf1?faults=hold@{1 + WAKE_LINES + pen_up + 1}", timeout=0.05) as port:
        port.write(b"$10=3\n")  # report the buffer state (kept in EEPROM); the board's line 1
        threading.Event().wait(0.05)
    path = tmp_path / "loops.gcode"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(PlotError, match="stopped by Ctrl-C"):
        draw(path, "sim://bf1", profile=PROFILE, wake_wait=0.2, operator=CtrlCAtThePause(None))
    assert json.loads((tmp_path / "loops.gcode.job.json").read_text())["next_line"] == 4 + 9 * 2 + 3 + 1
    draw(path, "sim://bf1", resume=f"{path}.job.json", wake_wait=0.2)
    assert_same_drawing(drawn("bf1"), drawn("bf-ref"))
