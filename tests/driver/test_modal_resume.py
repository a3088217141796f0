"""Modal-state tracking and resume preambles: a resumed job leaves the machine exactly as the full job would."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.driver.gcode.modal import ModalState, advance, clean_line, state_before, track
from pencilbot.driver.gcode.resume import locate_stop, resume_preamble
from pencilbot.machine.pen import PenModel

SPINDLE = PenModel("spindle", up=0, down=1000, up_lines=("M5",), down_lines=("M3S1000",))
ZPEN = PenModel("z", up=5, down=0, up_lines=("G0Z5",), down_lines=("G1Z0F600",))
SERVO = PenModel("servo", up=90, down=30, up_lines=("M280P0S90",), down_lines=("M280P0S30",))


def run(lines, pen, state=None):
    state = state or ModalState()
    for line in lines:
        state = advance(state, clean_line(line), pen)
    return state


@pytest.mark.parametrize(
    "raw, cleaned",
    [("G1 X1.5 Y-2 ; draw", "G1X1.5Y-2"), ("(pen up) M5", "M5"), ("  ", ""), ("g0 x1 (c) y2", "G0X1Y2")],
)
def test_clean_line_strips_comments_and_spaces(raw, cleaned):
    assert clean_line(raw) == cleaned


def test_tracks_units_distance_feed_and_position():
    s = run(["G20", "G91", "G1 X1 Y2 F10", "X1", "G90", "G0 X5"], SPINDLE)
    assert (s.inches, s.relative, s.feed, s.motion) == (True, False, 10.0, 0)
    assert (s.x, s.y) == (5.0, 2.0)


@pytest.mark.parametrize(
    "pen, down, up",
    [
        (SPINDLE, ["M3 S1000"], ["M5"]),
        (SPINDLE, ["M3 S900"], ["S10"]),
        (ZPEN, ["G1 Z0.5"], ["G0 Z4"]),
        (SERVO, ["M280 P0 S35"], ["M280 P0 S80"]),
    ],
)
def test_pen_state_follows_the_pen_model(pen, down, up):
    assert run(down, pen).pen_down
    assert not run(down + up, pen).pen_down


def test_z_pen_heights_are_mm_in_an_inch_job():
    job = ["G20", "G90", "G0 Z0.157", "G0 X1 Y1", "G1 Z0 F20", "G1 X2 Y2"]  # 0.157 in = 4 mm: up
    assert not state_before([clean_line(line) for line in job], 4, ZPEN).pen_down
    assert state_before([clean_line(line) for line in job], 5, ZPEN).pen_down


@pytest.mark.parametrize("index", [4, 5])
def test_preamble_sends_the_profile_s_pen_commands_in_mm_in_an_inch_job(index):
    job = [clean_line(line) for line in ["G20", "G90", "G0 Z0.157", "G0 X1 Y1", "G1 Z0 F20", "G1 X2 Y2"]]
    before = state_before(job, index, ZPEN)
    state = ModalState(z=5.0)
    for line in resume_preamble(before, ZPEN):
        if line in ZPEN.up_lines + ZPEN.down_lines:
            assert not state.inches, line
        state = advance(state, line, ZPEN)
    assert (state.inches, state.x, state.y, state.pen_down) == (True, 1.0, 1.0, before.pen_down)


def test_dwell_units_follow_the_firmware():
    assert track(["G4P0.5"], SPINDLE, dwell_units=1).seconds[0] == 0.5  # GRBL: seconds
    assert track(["G4P500"], SPINDLE, dwell_units=1000).seconds[0] == 0.5  # Marlin: milliseconds
    assert track(["G4S2"], SPINDLE, dwell_units=1000).seconds[0] == 2.0


def test_move_time_is_distance_over_feed():
    start = ModalState(feed=600.0, motion=1)
    assert track(["G1X30Y40"], SPINDLE, start=start, travel_feed=6000).seconds[0] == pytest.approx(
        5.0
    )  # 50 mm at 10 mm/s
    assert track(["G0X30Y40"], SPINDLE, start=start, travel_feed=6000).seconds[0] == pytest.approx(0.5)
    assert track(["G20", "G1X1"], SPINDLE, start=start).seconds[1] == pytest.approx(0.1)  # 1 in at 600 in/min


job_words = st.lists(
    st.one_of(
        st.builds(
            lambda a, v: f"{a}{v}", st.sampled_from("XYZFS"), st.floats(-300, 300).map(lambda v: round(v, 4))
        ),
        st.sampled_from(["G0", "G1", "G4", "G20", "G21", "G90", "G91", "G92", "M3", "M5", "M280", "P0.2"]),
    ),
    min_size=1,
    max_size=5,
).map("".join)


@settings(max_examples=150, deadline=None)
@given(st.lists(job_words, min_size=1, max_size=30))
def test_whole_block_tracking_equals_line_by_line(lines):
    for pen in (SPINDLE, ZPEN, SERVO):
        block = track(lines, pen)
        state = ModalState()
        for i, line in enumerate(lines):
            state = advance(state, line, pen)
            assert _same(block[i], state), (lines[: i + 1], pen.kind)


def _same(a: ModalState, b: ModalState) -> bool:
    return all(
        (x is None and y is None) or (x is not None and y is not None and x == pytest.approx(y))
        for x, y in ((getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)
    )


def test_numbers_are_read_from_their_digits():
    state = track(["G1X-12.5Y.25Z+3F1500", "G91", "X0.125", "X1.2.3", "Y"], SPINDLE).last
    assert (state.x, state.y, state.z, state.feed, state.relative) == (-12.375, 0.25, 3.0, 1500.0, True)


coord = st.floats(-200, 200, allow_nan=False).map(lambda v: round(v, 3))
job_line = st.one_of(
    st.builds(lambda x, y: f"G1 X{x} Y{y}", coord, coord),
    st.builds(lambda x, y: f"G0 X{x} Y{y}", coord, coord),
    st.builds(lambda x: f"X{x}", coord),
    st.builds(lambda f: f"G1 F{f}", st.integers(100, 5000)),
    st.sampled_from(["M3 S1000", "M5", "G4 P0.1", "G90", "G91", "G21", "G20"]),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(job_line, min_size=1, max_size=25), st.data())
def test_preamble_then_rest_ends_like_the_whole_job(job, data):
    cleaned = [clean_line(l) for l in job]
    k = data.draw(st.integers(0, len(cleaned)))
    full = run(cleaned, SPINDLE)
    before = state_before(cleaned, k, SPINDLE)
    # The machine after a reset: wherever it stopped, pen state unknown, default modes.
    woken = ModalState(x=-7.0, y=3.0, spindle_on=True, s=1000.0)
    after_preamble = run(resume_preamble(before, SPINDLE), SPINDLE, woken)
    fields = ("inches", "relative", "feed", "motion", "x", "y", "pen_down")
    assert {f: getattr(after_preamble, f) for f in fields} == pytest.approx(
        {f: getattr(before, f) for f in fields}
    )
    resumed = run(cleaned[k:], SPINDLE, after_preamble)
    assert {f: getattr(resumed, f) for f in fields} == pytest.approx({f: getattr(full, f) for f in fields})


def test_preamble_travels_with_the_pen_up():
    before = state_before(["G21", "G90", "M3S1000", "G1X10Y10F500"], 4, SPINDLE)
    lines = resume_preamble(before, SPINDLE, stop_xy=(4.0, 4.0))
    state = ModalState(spindle_on=True, s=1000.0)
    for line in lines:
        nxt = advance(state, line, SPINDLE)
        if (nxt.x, nxt.y) != (state.x, state.y):
            assert not state.pen_down and not nxt.pen_down, line
        state = nxt
    assert (state.x, state.y, state.pen_down) == (4.0, 4.0, True)


def job_states(lines):
    states, s = [], ModalState()
    for line in lines:
        s = advance(s, clean_line(line), SPINDLE)
        states.append(s)
    return states


JOB = ["G21", "G90", "M3S30", "G0X10Y0", "M3S90", "G1X20Y0F600", "G1X20Y10", "M3S30", "G0X0Y0"]


@pytest.mark.parametrize(
    "position, expected",
    [
        ((20.0, 10.0), (8, None)),  # start of the last travel: the acked pen-up before it ran
        ((20.0, 4.0), (6, (20.0, 4.0))),  # inside G1X20Y10: resend it from the stop point
        ((15.0, 0.0), (5, (15.0, 0.0))),
        ((0.0, 0.0), (9, None)),  # everything ran
        ((50.0, 50.0), None),  # not on the job's last moves (power-cycled, moved by hand)
        (None, None),  # position unknown
    ],
)
def test_locate_stop_finds_the_move_in_progress(position, expected):
    assert locate_stop(job_states(JOB), len(JOB) - 1, position) == expected


def test_locate_stop_never_looks_past_acknowledged_lines():
    # Acked up to G1X20Y0 (index 5): a position on a later move is not trusted.
    assert locate_stop(job_states(JOB), 5, (20.0, 5.0)) is None


# A stroke drawn left to right along y = 0 (pen down), then a pen-up travel that crosses it at
# (10, 0) on its way back: the latest move through the stop point is the travel.
CROSSING = ["G21", "G90", "M5", "G0X0Y0", "M3S1000", "G1X20Y0F600", "M5", "G0X10Y-5", "G0X10Y5"]


@pytest.mark.parametrize("pen_down, expected", [(True, (5, (10.0, 0.0))), (False, (8, (10.0, 0.0)))])
def test_locate_stop_takes_the_move_drawn_with_the_pen_as_the_board_said(pen_down, expected):
    # Stopped at (10, 0): with the pen down, inside the stroke (resend its rest from there), not
    # inside the travel that crosses it; with the pen up, inside the travel.
    states = job_states(CROSSING)
    assert states[5].pen_down and not states[8].pen_down
    assert locate_stop(states, len(CROSSING) - 1, (10.0, 0.0), pen_down=pen_down) == expected
    assert locate_stop(job_states(CROSSING), len(CROSSING) - 1, (10.0, 0.0)) == (
        8,
        (10.0, 0.0),
    )  # not known: the latest


# --- the search window: what the firmware can hold in flight, never read past -----------------


def test_a_stop_point_before_the_kept_window_is_not_found_and_nothing_is_read_outside_it():
    from pencilbot.driver.gcode.modal import track

    lines = [clean_line(line) for line in JOB]
    whole = track(lines, SPINDLE)
    window = track(lines[4:], SPINDLE, start=whole[3], first=4)  # the states after lines 4..
    # On line 3's move (G0X10Y0, before what was kept): not found, where the old search indexed
    # the line before the window and raised IndexError.
    assert locate_stop(window, len(JOB) - 1, (5.0, 0.0), window=100) is None
    assert locate_stop(window, len(JOB) - 1, (15.0, 0.0), window=100) == (5, (15.0, 0.0))


def test_the_window_follows_the_receive_buffer_and_the_planner_depth():
    from pencilbot.driver.gcode.job import load_job
    from pencilbot.driver.gcode.resume import flight_start
    from pencilbot.machine.profile import load_profile

    moves = [f"G1X{i % 50}.5Y{i // 50}.25F3000" for i in range(400)]
    grbl, grblhal = load_profile("grbl-servo-a4"), load_profile("grblhal-servo-a3")
    assert (grbl.firmware.planner_blocks, grblhal.firmware.planner_blocks) == (15, 35)
    for profile in (grbl, grblhal):
        job = load_job(["G21", "G90", *moves], profile)
        last = len(job) - 1
        first = flight_start(job, last, profile.receive_buffer, profile.firmware.moves_in_flight())
        unread = sum(
            1 for i in range(last + 1) if job.offsets[last + 1] - job.offsets[i] <= profile.receive_buffer
        )
        # Every line whose bytes can wait in the receive buffer, then the planner's moves.
        assert last - first + 1 == unread + profile.firmware.moves_in_flight()
    assert grblhal.receive_buffer > 5 * grbl.receive_buffer  # so its window is much longer


def test_a_reported_stop_a_few_micrometres_before_a_moves_end_resumes_inside_that_move():
    # GRBL reports 3 decimals: 4 µm before the end is inside the move, not after it.
    states = job_states(JOB)
    assert locate_stop(states, len(JOB) - 1, (19.996, 0.0)) == (5, (19.996, 0.0))
    # A reported point off the move by rounding is taken on the move.
    index, xy = locate_stop(states, len(JOB) - 1, (15.0, 0.0004))
    assert index == 5 and xy == pytest.approx((15.0, 0.0))


def test_a_carriage_that_ran_on_past_a_corner_resumes_at_the_next_line_only_within_its_coast():
    states = job_states(JOB)
    # 0.3 mm past the end of G1X20Y0 (index 5), along it: that move was finished.
    assert locate_stop(states, 6, (20.3, 0.0), coast=1.0, tolerance=0.075) == (6, None)
    assert locate_stop(states, 6, (20.3, 0.0), coast=0.2, tolerance=0.075) is None


def test_positions_are_near_only_when_both_coordinates_agree():
    from pencilbot.driver.position import NEAR, near

    assert near((12.0, 34.0), (12.0, 34.0)) and near((12.0, 34.0), (12.0 + NEAR / 2, 34.0 - NEAR / 2))
    assert not near((12.0, 34.0), (34.0, 12.0))
    assert not near((0.0, 0.0), (5.0, 0.0)) and not near((0.0, 0.0), (0.0, 5.0))
    assert not near(None, (0.0, 0.0)) and not near((0.0, 0.0), None)
