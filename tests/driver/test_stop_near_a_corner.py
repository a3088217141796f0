"""Where a stop lies when the point is near a corner of the path: a reported point a digit short
of a move's end is inside that move (its rounding is half a digit per axis), and a carriage that
coasted past a corner after a reset or alarm in motion finished the move its count was on, even
when it stands on the line of the next move. Deterministic: exact points, and faults at exact
lines of a real plan on the virtual plotter's line clock (the cases the fault sweep found).
"""

import itertools

import numpy as np
import pytest
from real_plan import plan_lines
from segments import assert_same_drawing
from test_stream_sim import HandOnTheMachine, drawn

from pencilbot.driver import draw
from pencilbot.driver.gcode.job import load_job
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.driver.gcode.resume import REPORT_ROUNDING, StopLocator, locate_stop
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from sim import protocol_sim

WAKE_LINES = 4  # empty lines the driver's wake-up sends first (the board logs them)
_names = itertools.count()

# A stroke right along y = 0 to the corner (20, 0), then up to (20, 10), then a travel home.
JOB = ["G21", "G90", "M3S30", "G0X10Y0", "M3S90", "G1X20Y0F600", "G1X20Y10", "M3S30", "G0X0Y0"]
SPINDLE = load_profile("grbl-servo-a4").pen_model


def states_of(lines):
    from pencilbot.driver.gcode.modal import track

    return track([clean_line(line) for line in lines], SPINDLE)


@pytest.mark.parametrize(
    "position, expected",
    [
        ((19.999, 0.0), (5, (19.999, 0.0))),  # a digit short of the corner: the last micrometre is to draw
        ((20.0, 0.0005), (6, None)),  # within a report's rounding of the corner: at it
        ((20.0, 0.001), (6, (20.0, 0.001))),  # a digit up the next move: inside it
    ],
)
def test_a_reported_point_a_digit_from_a_corner_is_inside_the_move_not_at_the_corner(position, expected):
    assert REPORT_ROUNDING < 0.001
    assert locate_stop(states_of(JOB), len(JOB) - 1, position) == expected


@pytest.fixture(scope="module")
def locator():
    profile = load_profile("grbl-servo-a4")
    return StopLocator(load_job(JOB, profile), profile)


@pytest.mark.parametrize(
    "here, expected",
    [
        ((21.0, 0.0), (6, None)),  # ran on past the corner: the stroke's first move was drawn
        ((20.0, 0.0), (6, None)),  # came to rest at the corner
        ((18.0, 0.0), (5, (18.0, 0.0))),  # stopped inside the move, past the count
        ((15.0, 3.0), None),  # not straight on from the count: the hand alone must say
    ],
)
def test_a_carriage_that_coasted_on_from_its_count_finished_the_move_if_it_ran_past_the_end(
    locator, here, expected
):
    at = locator.locate(len(JOB) - 1, (15.0, 0.0), answered=-1)  # the count: inside G1X20Y0
    assert at == (5, (15.0, 0.0))
    assert locator.coasted(at, (15.0, 0.0), here, tolerance=0.001) == expected


def _stop_and_resume(profile: str, spec: str, send_and_wait: bool, tmp_path) -> str:
    """Draw the real plan with the fault ``spec``, resume until drawn (re-zeroed by a hand if the
    position is lost); the plotter's name."""
    lines = plan_lines(profile)
    path = tmp_path / "plot.gcode"
    path.write_text("\n".join(lines) + "\n")
    name = f"corner{next(_names)}"
    options = dict(profile=profile, wake_wait=0.2, send_and_wait=send_and_wait)
    with pytest.raises(PlotError, match="Resume with"):
        draw(path, f"sim://{name}?profile={profile}&faults={spec}&tick=0.01", timeout=0.5, **options)
    plotter = protocol_sim.plotter(name)
    plotter.firmware.faults.at.clear()
    journal = f"{path}.job.json"
    try:
        draw(path, f"sim://{name}", resume=journal, timeout=2.0, **options)
    except PlotError as exc:
        assert "position cannot be trusted" in str(exc)
        draw(
            path, f"sim://{name}", resume=journal, timeout=2.0, operator=HandOnTheMachine(plotter), **options
        )
    return name


_REFERENCES = {}


def reference(profile: str):
    if profile not in _REFERENCES:
        name = f"corner-ref-{profile}"
        draw(list(plan_lines(profile)), f"sim://{name}?profile={profile}", profile=profile, wake_wait=0.2)
        _REFERENCES[profile] = drawn(name)
    return _REFERENCES[profile]


@pytest.mark.parametrize("kind", ["alarm", "abort"])
def test_a_reset_or_alarm_that_lets_the_carriage_coast_past_a_corner_redraws_nothing_and_misses_nothing(
    tmp_path, kind
):
    # Board line 339 of the real plan arrives while the machine runs a stroke's move to a corner
    # whose next move goes on almost straight: the carriage coasts past the corner to a point
    # within a micrometre of the next move's line. (Before: the resume took that point as inside
    # the next move, and its first 0.04 mm were never drawn.)
    profile = "grbl-servo-a4"
    name = _stop_and_resume(profile, f"{kind}@339", False, tmp_path)
    plotter = protocol_sim.plotter(name)
    assert plotter.machine.overruns  # it did coast past the corner
    assert_same_drawing(drawn(name), [*reference(profile), *(np.array(o) for o in plotter.machine.overruns)])


def test_a_stop_a_micrometre_short_of_a_corner_draws_that_micrometre_on_resume(tmp_path):
    # grblHAL, send-and-wait, Ctrl-C at board line 188: the machine stands 1.2 µm short of a
    # corner and reports a point 1 µm from it. (Before: taken as at the corner; 1.2 µm missing.)
    profile = "grblhal-servo-a3"
    name = _stop_and_resume(profile, "interrupt@188", True, tmp_path)
    assert_same_drawing(drawn(name), reference(profile))


@pytest.mark.parametrize(
    "back, expected",
    [
        ("G1X10Y1", 6),  # a sharp corner: the point lies on the move back, 4 µm from the corner
        (
            "G1X10Y-1",
            5,
        ),  # straight back over itself: nothing tells the passes apart; the first (nothing missing)
    ],
)
def test_a_point_near_a_sharp_corner_is_on_the_move_it_lies_nearer_to(back, expected):
    lines = ["G21", "G90", "M3S30", "G0X10Y-1", "M3S90", "G1X20Y0F600", back, "M3S30", "G0X0Y0"]
    states = states_of(lines)
    end, start = complex(states[6].x, states[6].y), complex(20.0, 0.0)
    p = start + 0.004 * (end - start) / abs(end - start)  # on the move back, 4 µm from the corner
    # Within a report's tolerance of both moves, and the board ran lines in order from line 5.
    index, (x, y) = locate_stop(states, len(lines) - 1, (p.real, p.imag), floor=5)
    assert index == expected
    assert abs(complex(x, y) - p) < 1e-9


def test_near_a_corner_of_the_job_s_first_move_the_search_reads_nothing_before_it():
    # The job begins with a move (from 0, 0): looking back from the move after it, latest
    # first, the first move's start is the origin, not a line before the job.
    states = states_of(["G1X20Y0F600", "G1X10Y1"])
    p = complex(20.0, 0.0) + 0.004 * complex(-10.0, 1.0) / abs(complex(-10.0, 1.0))
    assert locate_stop(states, 1, (p.real, p.imag))[0] == 1


def test_a_carriage_that_coasted_on_the_job_s_first_move_ran_from_the_origin():
    profile = load_profile("grbl-servo-a4")
    locator = StopLocator(load_job(["G1X20Y0F600", "G1X20Y10"], profile), profile)
    at = locator.locate(1, (5.0, 0.0), answered=-1)
    assert at == (0, (5.0, 0.0))
    assert locator.coasted(at, (5.0, 0.0), (25.0, 0.0), tolerance=0.001) == (1, None)
    assert locator.coasted(at, (5.0, 0.0), (12.0, 0.0), tolerance=0.001) == (0, (12.0, 0.0))


@pytest.mark.parametrize("window, expected", [(3, (5, (15.0, 0.0))), (2, None)])
def test_a_given_window_searches_that_many_lines_before_the_last_and_no_more(locator, window, expected):
    assert locator.locate(len(JOB) - 1, (15.0, 0.0), answered=-1, window=window) == expected


def test_an_empty_planner_at_rest_means_every_answered_line_ran():
    # A stroke out to (20, 0) and straight back to where it began: (10, 0) is both the start of
    # the first pass and the end of the second. At rest with every planner block free, the board
    # ran all it answered, so the stop is after the second pass; an earlier status report's
    # line (before the stroke) would take the first pass and draw the stroke twice more.
    from firmware_protocol.grbl import Status

    profile = load_profile("grbl-servo-a4")
    job = ["G21", "G90", "M3S30", "G0X10Y0", "M3S90", "G1X20Y0F600", "G1X10Y0", "M3S30"]
    locator = StopLocator(load_job(job, profile), profile)
    last = acked = len(job) - 1
    empty = Status("Hold", substate=0, buffer=(profile.firmware.planner_blocks, 128))
    floor = locator.planner_floor(empty, acked)
    assert floor == acked
    assert locator.locate(last, (10.0, 0.0), floor=floor, answered=acked) == (len(job), None)
    assert locator.locate(last, (10.0, 0.0), floor=3, answered=acked)[0] == 4  # the stroke again
    one_left = Status("Hold", substate=0, buffer=(profile.firmware.planner_blocks - 1, 128))
    assert locator.planner_floor(one_left, acked) == 6  # the last move still planned: running
