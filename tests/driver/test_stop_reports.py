"""What a stop says and what the pause key does, on the virtual plotter's line clock (every run
the same): a refused line that the board ran past, a check mode that lists many refused lines,
and a pause key pressed twice before the board reported the hold."""

import json
import re

import pytest
from test_stream_sim import accepted, drawing, fresh

from pencilbot.driver import draw
from pencilbot.errors import PlotError
from sim import protocol_sim

PROFILE = "grbl-servo-a4"
WAKE_LINES = 4  # empty lines the driver's wake-up sends first (the board logs them)
TICK = "tick=0.01"


def test_a_refused_line_the_board_ran_past_is_named_and_the_resume_continues_after_it(tmp_path):
    # Character counting, and moves so short the machine keeps up with the lines: the lines
    # after the refused one were in the board's buffer and ran before the stop, so the resume
    # starts after them and the message says the refused line never ran.
    lines = ["G21", "G90", "M3 S30", "G4 P0.15", "G0 X50 Y50", "M3 S90", "G4 P0.2"]
    lines += [f"G1 X{50 + 0.05 * (i % 2):.2f} Y{50 + 0.05 * i:.2f} F3000" for i in range(60)]
    lines += ["M3 S30", "G4 P0.15"]
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    refused = 7 + 30  # 0-based file line: the 31st short move
    url, _name = fresh(f"{TICK}&faults=error@{WAKE_LINES + refused + 1}")
    with pytest.raises(PlotError) as stop:
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.5)
    message = str(stop.value)
    assert f"(line {refused + 1} never ran; the lines the plotter had already taken after it did" in message
    assert json.loads((tmp_path / "plot.gcode.job.json").read_text())["next_line"] > refused + 2
    assert (
        "pen raised" in message and "cannot prove where the pen stopped" not in message
    )  # a hold at rest: proven


def test_a_stop_that_cannot_prove_the_position_says_so(tmp_path):
    lines = drawing()
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    url, _name = fresh(f"{TICK}&faults=reset@{WAKE_LINES + 30}")  # the board restarts mid-job
    with pytest.raises(PlotError) as stop:
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.5)
    assert (
        "The plotter cannot prove where the pen stopped, so the resume re-establishes its position first"
        in str(stop.value)
    )


def test_a_resume_without_anyone_at_the_machine_does_not_ask_for_the_pen(tmp_path):
    # A pen change (answered by the machine's own cycle start), then a stop by Ctrl-C: the
    # journal names the pen; a resume with nobody at the machine just goes on.
    lines = drawing()
    lines.insert(20, "M0 (pen change: insert red)")
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    url, name = fresh(f"{TICK}&operator=auto&faults=interrupt@{WAKE_LINES + 40}")
    with pytest.raises(PlotError, match="stopped by Ctrl-C"):
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.5)
    assert json.loads((tmp_path / "plot.gcode.job.json").read_text())["pen"] == "red"
    protocol_sim.plotter(name).firmware.faults.at.clear()
    draw(path, f"sim://{name}", resume=f"{path}.job.json", wake_wait=0.2, timeout=2.0)
    assert not (tmp_path / "plot.gcode.job.json").exists()  # finished


@pytest.mark.parametrize("count", [10, 11])
def test_check_mode_names_ten_refused_lines_and_counts_the_rest(tmp_path, count):
    lines = drawing(strokes=3)
    bad = list(range(8, 8 + count))
    for at in bad:
        lines.insert(at, "G1 X10 Y10 Q5")  # GRBL: unsupported word
    path = tmp_path / "bad.gcode"
    path.write_text("\n".join(lines) + "\n")
    url, name = fresh()
    with pytest.raises(PlotError) as refused:
        draw(path, url, profile=PROFILE, check=True, wake_wait=0.2)
    named = ", ".join(str(at + 1) for at in bad[:10])
    more = f" and {count - 10} more" if count > 10 else ""
    assert f"rejected lines {named}{more} of " in str(refused.value)
    assert protocol_sim.plotter(name).machine.strokes == []


class DoubleTap:
    """The pause key pressed twice at once (hold, then go on) when the board has taken
    ``at`` lines; then, if the board is still held after answering four more status queries,
    the stop key."""

    def __init__(self, name: str, at: int):
        self.name, self.at, self.tapped = name, at, False
        self.stopped = False
        self.queries = 0

    def poll(self) -> list[str]:
        firmware = protocol_sim.plotter(self.name).firmware
        if not self.tapped and len(firmware.log) >= self.at:
            self.tapped, self.queries = True, firmware.queries
            return ["pause", "pause"]
        if self.tapped and firmware.held and firmware.queries - self.queries >= 4:  # noqa: SLF001 - the board's own hold state
            self.stopped = True
            return ["stop"]
        return []


class DoubleTapAtSpeed(DoubleTap):
    """The pause key pressed twice at once while the machine moves at speed: the cycle start
    reaches the board while the hold still slows it (Hold:1), and GRBL drops it."""

    def poll(self) -> list[str]:
        machine = protocol_sim.plotter(self.name).machine
        if not self.tapped and machine.current_speed() < 20.0:
            return []
        return super().poll()


@pytest.mark.parametrize(
    "tap", [DoubleTap, DoubleTapAtSpeed], ids=["before the hold is reported", "while it slows"]
)
def test_a_second_press_of_the_pause_key_resumes_the_plot(tmp_path, tap):
    # Before the board reports the hold; or while the hold still slows the machine, when GRBL
    # drops the cycle start and the driver sends it again once the board stands.
    lines = drawing()
    url, name = fresh(TICK)
    keys = tap(name, WAKE_LINES + 30)
    draw(lines, url, profile=PROFILE, wake_wait=0.2, timeout=0.5, keys=keys)
    assert keys.tapped and not keys.stopped
    assert [line for line in accepted(name) if not re.match(r"^\$", line)][-len(lines) :] == [
        line.replace(" ", "").split(";")[0] for line in lines
    ]
