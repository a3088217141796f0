"""A third firmware, grblHAL, end to end: a drawing streamed to the virtual plotter speaking
grblHAL's dialect, its 1024-byte buffer filled by character counting, and every fault recovered."""

import pytest
from test_stream_sim import accepted, assert_same_drawing, drawing, drawn, fresh, resume

from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.driver.gcode.stream import Stream
from pencilbot.errors import PlotError
from sim import protocol_sim

PROFILE = "grblhal-servo-a3"
FAULT_AT = 40  # board line index (4 empty wake lines come first): file line 36, mid-stroke


@pytest.fixture
def job(tmp_path):
    lines = drawing(strokes=20, profile=PROFILE)
    path = tmp_path / "hal.gcode"
    path.write_text("\n".join(lines) + "\n")
    return path, [clean_line(line) for line in lines]


@pytest.fixture(scope="module")
def reference():
    url, name = fresh(f"profile={PROFILE}")
    draw(drawing(strokes=20, profile=PROFILE), url, profile=PROFILE, wake_wait=0.2)
    return drawn(name)


@pytest.fixture
def in_flight(monkeypatch):
    """The bytes character counting has in flight after each write, as the stream counts them."""
    seen = []
    write = Stream._write

    def counting(stream, entries, data):
        write(stream, entries, data)
        seen.append(stream._in_flight)  # noqa: SLF001

    monkeypatch.setattr(Stream, "_write", counting)
    return seen


def test_a_drawing_streams_in_grblhal_s_dialect_filling_its_big_buffer(job, in_flight):
    path, lines = job
    url, name = fresh(f"profile={PROFILE}&realtime=50&baud=115200")
    result = draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=3.0)
    plotter = protocol_sim.plotter(name)
    assert plotter.firmware.protocol.BANNER.startswith("GrblHAL")
    assert accepted(name) == lines and result.rejected == [] and plotter.firmware.lost_bytes == 0
    assert 128 < max(in_flight) <= 1024  # more than GRBL 1.1 could hold, never more than grblHAL's
    assert not (path.parent / (path.name + ".job.json")).exists()  # finished: nothing to resume


def test_a_grbl_profile_never_sends_a_grblhal_board_more_than_grbl_s_128_bytes(job, in_flight):
    path, _ = job
    url, _ = fresh(f"profile={PROFILE}&realtime=50")
    draw(path, url, profile="grbl-servo-a4", wake_wait=0.2, timeout=3.0)  # its banner is not GRBL's:
    assert max(in_flight) <= 128  # woken by a status report, then streamed with GRBL's budget


@pytest.mark.parametrize("kind", ["error", "alarm", "reset", "silent", "drop"])
def test_every_fault_stops_with_the_resume_command_and_resume_completes_the_drawing(job, reference, kind):
    path, lines = job
    url, name = fresh(f"profile={PROFILE}&faults={kind}@{FAULT_AT}&realtime=20")
    with pytest.raises(PlotError) as info:
        draw(path, url, profile=PROFILE, wake_wait=0.2, timeout=0.5)
    message = str(info.value)
    assert f"Resume with: pencilbot draw --resume {path}.job.json --port" in message and "\n" not in message
    if kind == "reset":
        assert "banner 'GrblHAL 1.1f' arrived mid-job" in message
    resume(path, name)
    assert_same_drawing(drawn(name), reference)
    assert set(lines) <= set(accepted(name))
    assert not (path.parent / (path.name + ".job.json")).exists()  # finished: nothing to resume
