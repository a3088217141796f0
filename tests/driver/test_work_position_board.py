"""A board that reports its work position (GRBL ``$10=0``: ``WPos`` instead of ``MPos``), end to end.

Such a board gives the machine position only as WPos + WCO, and a resume needs it: after the
DTR reset of opening the port, the count restarts at 0, 0 where the pen stood, and only the
machine position says so (the work offset in EEPROM survives). Drawn with a work offset set,
stopped and resumed, the drawing must come out as the uninterrupted one, with no re-zero by hand.
"""

import numpy as np
import pytest
import serial
from test_stream_sim import FAULT_AT, HandOnTheMachine, accepted, assert_same_drawing, drawing, drawn, fresh

from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.errors import PlotError
from sim import protocol_sim

PROFILE = "grbl-servo-a4"
OFFSET = (6.5, -4.25)  # G54, set before the job and kept by the board (EEPROM)


def configure(url: str, report_mask: int) -> None:
    """What a user did at the board before: the status report mask and the G54 work offset."""
    with serial.serial_for_url(url, timeout=1) as port:
        for line in (f"$10={report_mask}", f"G10L2P1X{OFFSET[0]}Y{OFFSET[1]}"):
            port.write(line.encode() + b"\n")
            assert port.read_until(b"ok\r\n").endswith(b"ok\r\n"), line


@pytest.fixture(scope="module")
def reference():
    url, name = fresh()
    configure(url, 0)
    draw(drawing(), f"sim://{name}", profile=PROFILE, wake_wait=0.2)
    return drawn(name)


def test_the_board_reports_work_position_and_the_offset_shifts_the_drawing(reference):
    url, name = fresh()
    configure(url, 0)
    firmware = protocol_sim.plotter(name).firmware
    report = firmware.status_report()
    assert "WPos:" in report and "MPos:" not in report
    draw(drawing(), f"sim://{name}?reset=0", profile=PROFILE, wake_wait=0.2)
    plain_url, plain = fresh()
    draw(drawing(), plain_url, profile=PROFILE, wake_wait=0.2)
    first, shifted = drawn(plain)[0], drawn(name)[0]
    np.testing.assert_allclose(shifted[:, :2] - first[:, :2], [OFFSET] * len(first), atol=1e-9)
    assert_same_drawing(drawn(name), reference)


# 2 and 3: the planner count (Bf:) too, from which the stop finds the line it was running.
@pytest.mark.parametrize("report_mask", [0, 1, 2, 3])
def test_a_stop_and_resume_with_a_work_offset_comes_out_exact(tmp_path, reference, report_mask):
    lines = drawing()
    path = tmp_path / "offset.gcode"
    path.write_text("\n".join(lines) + "\n")
    # A real-time clock, as in the fault tests: the lines behind the refused one are still queued.
    url, name = fresh("realtime=20")
    configure(url, report_mask)
    plotter = protocol_sim.plotter(name)
    plotter.firmware.faults.at[len(plotter.firmware.log) + FAULT_AT] = ("error", 20)
    with pytest.raises(PlotError, match="rejected a line"):
        draw(path, f"sim://{name}?reset=0", profile=PROFILE, wake_wait=0.2, timeout=0.5)
    # Opening the port again resets the board (DTR): its count restarts at 0, 0 where the pen
    # stands, and only WPos + WCO tells the driver so. Nobody needs to jog.
    hand = HandOnTheMachine(plotter)
    draw(path, f"sim://{name}", resume=f"{path}.job.json", wake_wait=0.2, operator=hand)
    assert hand.prompts == []
    assert_same_drawing(drawn(name), reference)
    assert {clean_line(line) for line in lines} <= set(accepted(name))
