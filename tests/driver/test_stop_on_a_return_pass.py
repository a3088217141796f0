"""A stop while the pen runs back over the stroke it just drew: the carriage stands on a point
both passes cross, and only the order of what the board reported tells them apart.

GRBL's feed hold slows the machine along its path (``Hold:1``) before it stands (``Hold:0``), and
the driver asks where it is in the same write as the hold, so where it stands is at or past that
point. Before, the locator took the first pass through the point after an older report, and the
resume drew the rest of the way out and the whole way back again.

Deterministic: Ctrl-C at a moment of the virtual plotter's simulated clock (``interrupt@Ts``) on
the line clock, so the carriage is at the same point of the stroke in every run.
"""

import json

import pytest
from segments import assert_same_drawing
from test_stream_sim import HandOnTheMachine, drawn

from pencilbot.driver import draw
from pencilbot.errors import PlotError
from sim import protocol_sim

PROFILE = "grbl-servo-a4"
# Out along y = 10 to x = 40 at 50 mm/s, back over it to x = 15, then a zigzag up (lines enough
# to keep the planner full), pen up and home.
ZIGZAG = [f"G1X{15 + (i % 2) * 0.8:.3f}Y{12 + i * 0.5:.3f}" for i in range(40)]
JOB = [
    "G21",
    "G90",
    "M3S30",
    "G4P0.15",
    "G0X10Y10",
    "M3S90",
    "G4P0.2",
    "G1X40Y10F3000",
    "G1X15Y10",
    *ZIGZAG,
    "M3S30",
    "G4P0.15",
    "G0X0Y0",
]
BACK = JOB.index("G1X15Y10") + 1  # file line of the move back
#: Simulated seconds at which the carriage is on the way out (0.9, 1.1), about at the turn
#: (1.2) and on the way back, over what it drew on the way out (1.3 .. 1.6).
MOMENTS = [0.9, 1.1, 1.2, 1.3, 1.45, 1.6]


@pytest.fixture(scope="module")
def reference():
    draw(JOB, "sim://return-ref?tick=0.01", profile=PROFILE, wake_wait=0.2)
    return drawn("return-ref")


@pytest.mark.parametrize("send_and_wait", [False, True], ids=["counting", "send-and-wait"])
@pytest.mark.parametrize("moment", MOMENTS)
def test_ctrl_c_on_the_way_back_over_a_stroke_resumes_on_the_way_back(
    tmp_path, reference, moment, send_and_wait
):
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(JOB) + "\n")
    name = f"return-{moment}-{send_and_wait}"
    with pytest.raises(PlotError, match="stopped by Ctrl-C .*pen raised"):
        draw(
            path,
            f"sim://{name}?tick=0.01&faults=interrupt@{moment}s",
            profile=PROFILE,
            wake_wait=0.2,
            timeout=0.3,
            send_and_wait=send_and_wait,
        )
    journal = json.loads((tmp_path / "plot.gcode.job.json").read_text())
    if moment >= 1.3:  # stood inside the move back, where the way out passed too
        assert journal["next_line"] == BACK and 15 < journal["stop_xy"][0] < 40, journal
    draw(
        path,
        f"sim://{name}",
        resume=f"{path}.job.json",
        wake_wait=0.2,
        send_and_wait=send_and_wait,
        operator=HandOnTheMachine(protocol_sim.plotter(name)),
    )
    assert_same_drawing(drawn(name), reference)


def test_a_moment_fault_strikes_mid_move_at_the_same_point_in_every_run():
    points = set()
    for run in range(2):
        name = f"return-same-{run}"
        with pytest.raises(PlotError):
            draw(
                JOB,
                f"sim://{name}?tick=0.01&faults=interrupt@1.45s",
                profile=PROFILE,
                wake_wait=0.2,
                timeout=0.3,
            )
        points.add(protocol_sim.plotter(name).machine.machine_position())
    assert len(points) == 1
