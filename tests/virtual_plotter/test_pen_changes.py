"""A colour job on the virtual plotter: M0 pauses hold as on GRBL unless the virtual operator is
asked to load pens at once, and every stroke knows how many pauses came before it."""

import time

import pytest
import serial

import sim
from firmware_protocol import grbl
from sim import protocol_sim

sim.register()

JOB = [
    "G21",
    "G90",
    "M3 S30",
    "M0",
    "G0 X10 Y10",
    "M3 S90",
    "G1 X20 F3000",
    "M3 S30",
    "M0",
    "G0 X30 Y10",
    "M3 S90",
    "G1 X40",
    "M3 S30",
    "G0 X50 Y10",
    "M3 S90",
    "G1 X60",
    "M3 S30",
    "M0",
    "G0 X70 Y10",
    "M3 S90",
    "G1 X80",
    "M3 S30",
]


def replies(port, count: int, deadline: float = 10.0) -> list[str]:
    """The next ``count`` non-empty reply lines (fewer if none come within ``deadline`` s: a bound
    for a broken board only; the in-process board answers as a line arrives)."""
    end, lines, buf = time.monotonic() + deadline, [], b""
    while len(lines) < count and time.monotonic() < end:
        buf += port.read(1)
        if buf.endswith(b"\n"):
            if buf.strip():
                lines.append(buf.decode().strip())
            buf = b""
    return lines


def open_board(url: str):
    port = serial.serial_for_url(url, timeout=0.02)
    port.reset_input_buffer()  # (the in-process board has said all it says on open)
    port.write(grbl.SOFT_RESET)
    assert replies(port, 1)[0].startswith("Grbl")
    return port


def test_the_operator_loads_each_pen_and_strokes_count_the_pauses_before_them():
    name = "pen-changes-auto"
    with open_board(f"sim://{name}?operator=auto") as port:
        for line in JOB:  # send and wait: every line, M0 too, is answered
            port.write(grbl.encode_line(line))
            assert replies(port, 1) == ["ok"], line
    machine = protocol_sim.plotter(name).machine
    protocol_sim.plotter(name).firmware.finish()
    assert machine.pauses == 3
    assert [round(s[0][0]) for s in machine.strokes] == [10, 30, 50, 70]
    assert machine.stroke_pauses == [1, 2, 2, 3]
    protocol_sim.forget(name)


def test_without_the_operator_an_m0_holds_until_cycle_start():
    name = "pen-changes-held"
    with open_board(f"sim://{name}") as port:
        for line in JOB[:3]:
            port.write(grbl.encode_line(line))
            assert replies(port, 1) == ["ok"]
        port.write(grbl.encode_line("M0"))
        assert replies(port, 1, deadline=0.3) == []  # held: no ok yet
        port.write(b"?")
        assert replies(port, 1)[0].startswith("<Hold")
        port.write(b"~")
        assert replies(port, 1) == ["ok"]
    protocol_sim.forget(name)


def test_an_unknown_operator_is_refused():
    with pytest.raises(serial.SerialException, match="operator='robot': use none or auto"):
        serial.serial_for_url("sim://x?operator=robot")
