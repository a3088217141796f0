"""Streaming to the virtual GRBL plotter over sim://: exactly-once delivery, faults, resume.

The plotter behind a ``sim://NAME`` port is reachable with ``sim.protocol_sim.plotter(NAME)``:
its firmware logs every line it accepted and its canvas shows what the pen drew.
"""

import _thread
import itertools
import json
import threading

import numpy as np
import pytest
import serial
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from segments import assert_same_drawing

import sim
from pencilbot.configs_io import config_folder
from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from sim import protocol_sim

sim.register()

PROFILE = "grbl-servo-a4"
_names = itertools.count()


def fresh(options: str = "") -> tuple[str, str]:
    """A sim:// URL reaching a new plotter, and its registry name."""
    name = f"drv{next(_names)}"
    return f"sim://{name}" + (f"?{options}" if options else ""), name


def drawing(strokes: int = 12, per_stroke: int = 6, seed: int = 1, profile: str = PROFILE) -> list[str]:
    """A small plot: short random-walk strokes, pen commands from the profile, a comment or two."""
    loaded = load_profile(profile)
    pen = loaded.pen_model
    # Machine coordinates on the bed: a bed homed at the far corner counts X or Y negative.
    sx, sy = (-1.0 if loaded.bed.invert_x else 1.0), (-1.0 if loaded.bed.invert_y else 1.0)
    up, down = list(pen.up_lines), list(pen.down_lines)
    rng = np.random.default_rng(seed)
    lines = ["G21 ; mm", "G90", *up]
    x, y = 60.0, 80.0
    for _ in range(strokes):
        x, y = x + rng.uniform(-8, 8), y + rng.uniform(-8, 8)
        lines += [f"G0 X{sx * x:.3f} Y{sy * y:.3f}", *down]
        for _ in range(per_stroke):
            x, y = x + rng.uniform(-3, 3), y + rng.uniform(-3, 3)
            lines.append(f"G1 X{sx * x:.3f} Y{sy * y:.3f} F3000")
        lines += up
    return lines


@pytest.fixture
def job(tmp_path):
    lines = drawing()
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    return path, [clean_line(line) for line in lines]


def accepted(name: str) -> list[str]:
    """Non-empty lines the plotter answered ``ok`` (wake-up line endings are empty)."""
    return [line for line in protocol_sim.plotter(name).firmware.accepted_lines() if line]


def drawn(name: str) -> list[np.ndarray]:
    """The pen-down polylines the plotter behind ``sim://name`` has drawn (queued motion run)."""
    plotter = protocol_sim.plotter(name)
    plotter.firmware.finish()
    return plotter.machine.strokes


class HandOnTheMachine:
    """Someone at the virtual plotter: answers pauses, and jogs to a mark by looking at where
    the carriage really is (the board's own count may be wrong: that is why it is asked)."""

    jog_step = 0.0  # it jogs by the exact float: no key steps

    def __init__(self, plotter):
        self.plotter = plotter
        self.prompts: list[str] = []

    def pause(self, prompt):
        self.prompts.append(prompt)

    def jog_to_mark(self, prompt, mark, jog):
        self.prompts.append(prompt)
        x, y, _ = self.plotter.machine.carriage_position()
        jog(mark.xy[0] - x, mark.xy[1] - y)


@pytest.fixture(scope="module")
def reference():
    """What an uninterrupted plot of :func:`drawing` looks like."""
    lines = drawing()
    url, name = fresh()
    draw(lines, url, profile=PROFILE, wake_wait=0.2)
    return drawn(name)


@pytest.mark.parametrize("send_and_wait", [False, True])
def test_every_line_is_accepted_exactly_once_in_order(job, send_and_wait):
    path, lines = job
    url, name = fresh()
    result = draw(path, url, profile=PROFILE, send_and_wait=send_and_wait, wake_wait=0.2)
    assert accepted(name) == lines
    assert result.lines_sent == len(lines) and result.rejected == []
    assert not (path.parent / (path.name + ".job.json")).exists()  # finished: nothing to resume


def test_character_counting_never_overflows_a_busy_board(job):
    # Real-time clock (50x): the planner fills, ok waits for room and the 128-byte ring would
    # lose bytes if the driver sent more than the board can hold.
    path, lines = job
    url, name = fresh("realtime=50&baud=115200")
    draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=3.0)
    assert protocol_sim.plotter(name).firmware.lost_bytes == 0
    assert accepted(name) == lines


FAULT_AT = 40  # board line index (4 empty wake lines come first): file line 36, mid-stroke


@pytest.mark.parametrize(
    "kind, words, pen_up",
    [
        ("error", "rejected a line (error:20", True),
        ("alarm", "raised an alarm (ALARM:1 Hard limit", True),
        ("reset", "reset in the middle of the job", True),
        ("silent", "stopped answering", False),  # a hung board cannot lift its pen
        ("drop", "serial port vanished", False),
    ],
)
def test_fault_stops_with_one_message_naming_line_and_resume_command(job, kind, words, pen_up):
    path, _lines = job
    url, name = fresh(f"faults={kind}@{FAULT_AT}")
    with pytest.raises(PlotError) as info:
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.5, send_and_wait=True)
    message = str(info.value)
    assert words in message
    assert f"at line {FAULT_AT - 4} of {path}" in message
    assert f"Resume with: pencilbot draw --resume {path}.job.json --port" in message
    assert "\n" not in message
    machine = protocol_sim.plotter(name).machine
    if pen_up:
        assert "pen raised" in message or "pen up" in message
        assert not machine.pen_down
    journal = json.loads((path.parent / (path.name + ".job.json")).read_text())
    assert journal["status"] == "stopped" and journal["next_line"] <= FAULT_AT - 4


def resume(path, name):
    """Clear the glitch and resume the stopped job of ``path`` on the same plotter."""
    plotter = protocol_sim.plotter(name)
    plotter.firmware.faults.at.clear()  # the glitch is over
    plotter.firmware.silent = False
    return draw(
        path, f"sim://{name}", resume=f"{path}.job.json", wake_wait=0.2, operator=HandOnTheMachine(plotter)
    )


@pytest.mark.parametrize("kind", ["error", "alarm", "reset", "silent", "drop"])
@pytest.mark.parametrize("send_and_wait", [False, True])
def test_resume_after_fault_completes_the_same_drawing(job, reference, kind, send_and_wait):
    # Character counting runs on a real-time clock (20x): as on hardware, the lines behind a
    # failing one are still queued when the driver holds and resets. (On an instant clock they
    # would already have run, and a rejected move's successor would draw from the wrong place.)
    path, lines = job
    url, name = fresh(f"faults={kind}@{FAULT_AT}" + ("" if send_and_wait else "&realtime=20"))
    with pytest.raises(PlotError):
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.5, send_and_wait=send_and_wait)
    resume(path, name)
    assert_same_drawing(drawn(name), reference)
    assert not (path.parent / (path.name + ".job.json")).exists()  # finished: nothing to resume
    assert set(lines) <= set(accepted(name))


def test_ctrl_c_holds_lifts_the_pen_and_says_how_to_resume(job, reference):
    path, _lines = job
    url, name = fresh("realtime=20")
    stop_at = 30

    def press_ctrl_c():
        while True:
            try:
                if len(protocol_sim.plotter(name).firmware.log) >= stop_at:
                    break
            except KeyError:
                pass
            threading.Event().wait(0.005)
        _thread.interrupt_main()  # what a Ctrl-C in the terminal does to the main thread

    threading.Thread(target=press_ctrl_c, daemon=True).start()
    with pytest.raises(
        PlotError, match=r"stopped by Ctrl-C at line \d+ .*pen raised.*Resume with: pencilbot draw --resume"
    ):
        draw(path, url, profile=PROFILE, wake_wait=0.2)
    assert not protocol_sim.plotter(name).machine.pen_down
    resume(path, name)
    assert_same_drawing(drawn(name), reference)


def test_start_line_restores_state_and_sends_only_the_rest(job):
    path, lines = job
    url, name = fresh()
    start = 20  # file line 20 lies inside a stroke: the pen must travel up, then go down
    draw(path, url, profile=PROFILE, start_line=start, wake_wait=0.2)
    got = accepted(name)
    assert got[-(len(lines) - start + 1) :] == lines[start - 1 :]
    preamble = got[: len(got) - (len(lines) - start + 1)]
    assert preamble[:4] == ["G21", "G90", "M3S30", "G4P0.15"]  # the pen is up before it travels
    assert preamble[-3:-1] == ["M3S90", "G4P0.2"]  # and down before it draws


def test_check_mode_refuses_a_bad_file_before_drawing(tmp_path):
    lines = drawing(strokes=3)
    lines.insert(10, "G1 X10 Y10 Q5")  # GRBL: unsupported word
    path = tmp_path / "bad.gcode"
    path.write_text("\n".join(lines) + "\n")
    url, name = fresh()
    with pytest.raises(PlotError, match=r"check mode \(\$C\) rejected lines 11 of .*nothing was drawn"):
        draw(path, url, profile=PROFILE, check=True, wake_wait=0.2)
    assert protocol_sim.plotter(name).machine.strokes == []


def test_check_mode_then_draw(job):
    path, lines = job
    url, name = fresh()
    draw(path, url, profile=PROFILE, check=True, wake_wait=0.2)
    assert accepted(name)[-len(lines) :] == lines
    assert protocol_sim.plotter(name).machine.strokes


def test_check_mode_with_a_marlin_profile_is_refused_not_skipped(job):
    path, _ = job
    with pytest.raises(PlotError, match=r"--check .*\$C check mode.*marlin"):
        draw(path, "sim://", profile="marlin-servo-a4", check=True, wake_wait=0.2, timeout=1)


def test_resume_of_a_changed_file_keeps_the_job_s_profile_in_the_advice(job):
    path, _ = job
    url, _ = fresh("faults=error@30")
    mine = path.parent / "mine.toml"  # not the default profile, with a bed the drawing is on
    mine.write_text((config_folder("plotters") / f"{PROFILE}.toml").read_text().replace(PROFILE, "mine"))
    with pytest.raises(PlotError):
        draw(path, url, profile=str(mine), wake_wait=0.2)
    with open(path, "a") as f:
        f.write("G0 X0 Y0\n")
    with pytest.raises(PlotError, match=rf"changed since.*--profile {mine} --start-line \d+"):
        draw(path, url, resume=f"{path}.job.json", wake_wait=0.2)


def test_check_mode_names_the_line_that_leaves_the_bed(tmp_path):
    lines = drawing(strokes=3)
    lines.insert(12, "G1 X900 Y10 F3000")  # soft limits still alarm in check mode
    path = tmp_path / "far.gcode"
    path.write_text("\n".join(lines) + "\n")
    url, name = fresh(f"limits=bed&profile={PROFILE}")  # a board with homing and soft limits: the shipped bed
    mine = tmp_path / "wide.toml"  # a profile whose bed takes the move, on a board whose limits do not
    mine.write_text(
        (config_folder("plotters") / f"{PROFILE}.toml").read_text().replace("width = 220.0", "width = 1000.0")
    )
    with pytest.raises(
        PlotError,
        match=r"check mode \(\$C\) stopped at line 13 of .*'G1X900Y10F3000'.*ALARM:2.*nothing was drawn",
    ):
        draw(path, url, profile=str(mine), check=True, wake_wait=0.2)
    assert protocol_sim.plotter(name).machine.strokes == []


def test_a_finished_job_leaves_no_journal_so_a_resume_sends_nothing(job):
    path, _lines = job
    url, name = fresh()
    draw(path, url, profile=PROFILE, wake_wait=0.2)
    sent = len(protocol_sim.plotter(name).firmware.log)
    with pytest.raises(PlotError, match=r"no job journal at .*plot.gcode.job.json"):
        draw(path, f"sim://{name}", resume=f"{path}.job.json", wake_wait=0.2)
    assert len(protocol_sim.plotter(name).firmware.log) == sent


def test_a_board_left_in_feed_hold_is_refused_instead_of_waited_on_forever(job):
    path, _ = job
    url, name = fresh()
    with serial.serial_for_url(url) as port:
        port.write(b"!")  # another sender paused the board; it has no auto-reset
    outcome = []

    def run():
        try:
            draw(path, f"sim://{name}?reset=0", profile=PROFILE, wake_wait=0.2)
            outcome.append("drawn")
        except PlotError as exc:
            outcome.append(str(exc))

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(30)  # without the check the stream waits on the held board for good
    assert outcome and "is paused (Hold" in outcome[0] and "resume" in outcome[0]
    assert accepted(name) == []


def test_alarm_lock_at_start_needs_unlock(job, tmp_path):
    path, lines = job
    url, name = fresh("faults=alarm@5")
    with pytest.raises(PlotError):
        draw(path, url, profile=PROFILE, wake_wait=0.2)
    # (A board without auto-reset: a power-up would forget the alarm, with the position.)
    with pytest.raises(PlotError, match="alarm lock.*--unlock"):
        draw(path, f"sim://{name}?reset=0", profile=PROFILE, wake_wait=0.2)
    draw(path, f"sim://{name}?reset=0", profile=PROFILE, wake_wait=0.2, unlock=True)
    assert accepted(name)[-len(lines) :] == lines


def test_on_error_continue_reports_rejected_lines(tmp_path):
    lines = drawing(strokes=3)
    lines.insert(10, "G1 X10 Y10 Q5")
    path = tmp_path / "bad.gcode"
    path.write_text("\n".join(lines) + "\n")
    url, name = fresh()
    result = draw(path, url, profile=PROFILE, on_error="continue", wake_wait=0.2)
    assert result.rejected == [11]
    assert accepted(name) == [clean_line(l) for i, l in enumerate(lines) if i != 10]


move = st.builds(
    lambda x, y, d, g: f"G{g} X{x:.{d}f} Y{y:.{d}f}" + (" F3000" if g == 1 else ""),
    st.floats(5, 200),
    st.floats(5, 300),
    st.integers(0, 5),
    st.sampled_from([0, 1]),
)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.one_of(move, st.sampled_from(["M3 S90", "M3 S30", "G4 P0.01"])), min_size=5, max_size=60))
def test_any_job_arrives_exactly_once_on_a_busy_board(tmp_path, job_lines):
    lines = ["G21", "G90", *job_lines]
    url, name = fresh("realtime=100")
    draw(lines, url, profile=PROFILE, wake_wait=0.2, timeout=3.0)  # lost bytes would stall it
    assert protocol_sim.plotter(name).firmware.lost_bytes == 0
    assert accepted(name) == [clean_line(line) for line in lines]
