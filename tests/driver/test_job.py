"""Job preparation: lines encoded once into one buffer, line numbers and times as arrays, modal
state recomputed from checkpoints equal to tracking every line."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pencilbot.driver.gcode import job as job_module
from pencilbot.driver.gcode.job import load_job
from pencilbot.driver.gcode.modal import ModalState, advance, clean_line, track
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile

GRBL = load_profile("grbl-servo-a4")
MARLIN = load_profile("marlin-servo-a4")

command = st.one_of(
    st.builds(
        lambda g, x, y: f"G{g} X{x:.3f} Y{y:.3f}",
        st.sampled_from([0, 1]),
        st.floats(0, 200),
        st.floats(0, 200),
    ),
    st.sampled_from(["M3 S30", "M3 S90", "G4 P0.2", "G1 F2400", "G91", "G90", "G21", "X5", "g0 y7"]),
)
raw_line = st.one_of(
    command,
    command.map(lambda c: f"{c} ; a comment"),
    command.map(lambda c: f"(note) {c}"),
    st.sampled_from(["", "   ", "; only a comment", "(just this)"]),
)


def same(a: ModalState, b: ModalState) -> bool:
    """Equal states, numbers to float rounding (a job tracked in pieces adds in another order)."""
    pairs = [(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__]
    return all(x == y if x is None or y is None else x == pytest.approx(y, abs=1e-9) for x, y in pairs)


@pytest.fixture
def small_blocks(monkeypatch):
    """Tiny read blocks and checkpoints, so a short job crosses many of both."""
    monkeypatch.setattr(job_module, "_READ_BLOCK", 64)
    monkeypatch.setattr(job_module, "CHECKPOINT", 7)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(raw_line, min_size=1, max_size=80), st.sampled_from(["\n", "\r\n"]))
def test_lines_numbers_and_states_match_a_line_by_line_reading(small_blocks, raw, newline):
    program = newline.join(raw).encode()  # no final newline: the last line still counts
    cleaned = [clean_line(line) for line in raw]
    if not any(cleaned):
        with pytest.raises(PlotError, match="holds no G-code commands"):
            load_job(program, GRBL)
        return
    job = load_job(program, GRBL)
    kept = [(n, c) for n, c in enumerate(cleaned, start=1) if c]
    assert [job.line(i) for i in range(len(job))] == [c for _, c in kept]
    assert job.numbers.tolist() == [n for n, _ in kept] and job.total_lines == len(
        program.decode().splitlines()
    )
    assert bytes(job.frames) == "".join(f"{c}\n" for _, c in kept).encode()
    state, pen = ModalState(), GRBL.pen_model
    whole = track([c for _, c in kept], pen, travel_feed=GRBL.motion.travel_feed)
    for i, (_, line) in enumerate(kept):
        state = advance(state, line, pen)
        assert same(job.state_after(i), whole[i]) and same(job.state_after(i), state)
    np.testing.assert_allclose(job.seconds, np.cumsum(whole.seconds), rtol=1e-6, atol=1e-6)
    assert job.index_of(kept[-1][0]) == len(job) - 1 and job.index_of(kept[-1][0] + 1) == len(job)


def test_a_file_is_read_in_blocks_and_checked_before_anything_is_sent(tmp_path, small_blocks):
    path = tmp_path / "job.gcode"
    long_line = (
        "G1 X1." + "0" * 20 + " Y1." + "0" * 20 + " Z0." + "0" * 20 + " F1000." + "0" * 17
    )  # numbers <= 24
    path.write_text("G21\n" * 30 + long_line + "\n")
    size = len(long_line.replace(" ", ""))
    with pytest.raises(PlotError, match=rf"line 31 of {path}: G-code line is {size} characters long"):
        load_job(path, GRBL)
    path.write_bytes(b"G21\nG0 X1\xc2\xb2 Y1\n")
    with pytest.raises(PlotError, match=r"line 2 of .*non-ASCII"):
        load_job(path, GRBL)
    path.write_bytes(b"G21\n\x00\x01\x02\n")
    with pytest.raises(PlotError, match="not G-code text"):
        load_job(path, GRBL)
    with pytest.raises(PlotError, match="no such file"):
        load_job(tmp_path / "none.gcode", GRBL)


def test_marlin_line_numbers_in_the_file_are_dropped_for_the_sender_s_own():
    job = load_job(["N10 G21*33", "N11 G1 X5 F3000*77", "M400"], MARLIN)
    assert [job.line(i) for i in range(len(job))] == ["G21", "G1X5F3000", "M400"]
    assert MARLIN.firmware.check_lines(job) is None
    long_line = "M117 " + "x" * 89  # fits 96 unnumbered, not once numbered and checksummed
    with pytest.raises(PlotError, match="line 2 of <lines>: .*too long for Marlin once numbered"):
        load_job(["G21", long_line], MARLIN)


def test_a_big_job_holds_a_few_dozen_bytes_per_line():
    program = b"".join(b"G1 X%d.125 Y%d.5\n" % (i % 200, i % 300) for i in range(200_000))
    job = load_job(program, GRBL)
    held = job.frames.__sizeof__() + job.offsets.nbytes + job.numbers.nbytes + job.seconds.nbytes
    assert len(job) == 200_000 and held / len(job) < 40
    assert len(job.checkpoints) == 200_000 // job_module.CHECKPOINT + 1
    assert job.state_after(123_456) == track([job.line(i) for i in range(123_457)], GRBL.pen_model).last
