"""Character counting at the exact edge of GRBL's 128-byte receive buffer, on the virtual plotter.

A board in feed hold reads nothing (GRBL's protocol loop sits in its suspend loop), so every byte
in flight waits in the receive ring, and a byte more than it holds is lost. Streaming to a held
board therefore shows exactly how many bytes the sender let out: all 128 when the lines fit them
exactly, and not one more when the next line would need 129.
"""

import pytest

import sim
from pencilbot.driver.gcode.job import load_job
from pencilbot.driver.gcode.stream import Stream
from pencilbot.driver.port import LineReader, open_port
from pencilbot.machine.profile import load_profile
from sim import protocol_sim

sim.register()

PROFILE = "grbl-servo-a4"
_names = iter(range(10**6))


def lines_of(sizes: list[int]) -> list[str]:
    """Travel moves whose frames (``\\n`` included) are ``sizes`` bytes long."""
    lines = []
    for i, size in enumerate(sizes):
        base = f"G0X{10 + i % 50}Y"
        lines.append(base + "1" + "0" * (size - len(base) - 2))  # Y10…0: on the bed, padded
    return lines


def stream_to_held_board(lines: list[str]):
    """Stream ``lines`` to a plotter held before the first byte; at the first pause, look at
    what it holds. Returns (bytes in its ring, bytes lost, lines sent) at that moment, and the
    lines it accepted in the end (after cycle start)."""
    profile = load_profile(PROFILE)
    job = load_job(lines, profile)
    name = f"edge{next(_names)}"
    port = open_port(f"sim://{name}")
    seen = []
    try:
        stream = Stream(
            LineReader(port), profile.firmware, receive_buffer=profile.receive_buffer, timeout=5.0
        )
        stream.wake(0.2)
        stream.link.write(profile.firmware.feed_hold)  # the machine's hold button, before the job
        firmware = protocol_sim.plotter(name).firmware

        def on_pause(reason):
            seen.append((len(firmware._ring), firmware.lost_bytes, stream.sent))  # noqa: SLF001
            # A lost byte merges two lines into one with one ok: the stream would wait forever.
            assert firmware.lost_bytes == 0, f"the sender overflowed the board's receive buffer: {seen[0]}"
            return True  # cycle start: the board reads on

        stream.stream(job, 0, lambda index, state: None, on_pause=on_pause)
    finally:
        port.close()
    return seen[0], [line for line in firmware.accepted_lines() if line]


def test_lines_that_fill_the_buffer_exactly_all_go_before_the_first_ok():
    sizes = [16] * 8 + [16]  # 8 × 16 = 128 bytes: the whole buffer; the 9th must wait
    lines = lines_of(sizes)
    assert sum(sizes[:8]) == load_profile(PROFILE).receive_buffer
    (ring, lost, sent), accepted = stream_to_held_board(lines)
    assert (ring, lost, sent) == (128, 0, 7)
    assert accepted == lines


@pytest.mark.parametrize("short", ["G0", "G90"])
def test_a_line_that_would_need_one_byte_more_than_the_buffer_waits_for_an_ok(short):
    # 129 − len("G0\n") = 126 bytes in flight (or 125 before "G90\n"): the short line is
    # the first that does not fit, by exactly one byte.
    before = 128 + 1 - (len(short) + 1)
    lines = lines_of([16] * 7 + [before - 7 * 16]) + [short] + lines_of([16])
    assert sum(len(line) + 1 for line in lines[:8]) == before
    (ring, lost, sent), accepted = stream_to_held_board(lines)
    assert lost == 0, "the sender overflowed the board's receive buffer"
    assert (ring, sent) == (before, 7)
    assert accepted == lines
