"""The virtual plotter reached through pyserial: the sim:// URL handler and a real pseudo-terminal."""

import threading
import time

import numpy as np
import pytest
import serial

import sim
from firmware_protocol import grbl
from pencilbot.errors import ProfileError
from pencilbot.machine.profile import DEFAULT_PROFILE, load_profile
from sim import protocol_sim, wires
from sim.faults import Faults
from sim.gcode.plotter import VirtualPlotter
from sim.protocol_sim import plotter
from sim.pty_server import PtyServer

sim.register()
DPI = 150

SQUARE = [
    "G21",
    "G90",
    "M3 S30",
    "G0 X20 Y20",
    "M3 S90",
    "G1 X60 F3000",
    "G1 Y60",
    "G1 X20",
    "G1 Y20",
    "M3 S30",
    "G0 X0 Y0",
]


SAFETY = 10.0  # s: a bound for a broken board only; no result depends on it


def read_line(port):
    """The next line the board sends (the port's read timeout is a poll slice)."""
    end = time.monotonic() + SAFETY
    buf = b""
    while not buf.endswith(b"\n"):
        assert time.monotonic() < end, f"no reply, got {buf!r}"
        buf += port.read(1)
    return buf.decode().strip()


def read_until_ok(port) -> list[str]:
    """The lines the board sends before its next ``ok``."""
    lines = []
    while (line := read_line(port)) != "ok":
        lines.append(line)
    return lines


def send_and_wait(port, lines):
    """A minimal sender: reset the board, then one line at a time, waiting for each ok. The
    status report asked for after the reset marks the end of the banners (one if the open reset
    the board, whenever it arrived, and the reset's own), so nothing depends on when they come."""
    port.write(grbl.SOFT_RESET + grbl.STATUS_QUERY)
    banners = []
    while not (line := read_line(port)).startswith("<"):
        banners.append(line)
    assert banners[-2:] == ["", "Grbl 1.1h ['$' for help]"]  # the reset's banner, last
    assert set(banners) == {"", "Grbl 1.1h ['$' for help]"}  # and nothing else
    for line in lines:
        port.write(grbl.encode_line(line))
        assert read_line(port) == "ok"


def drawing(plotter_):
    return plotter_.canvas(dpi=DPI).darkness


def check_square(darkness):
    mm = DPI / 25.4  # px per mm
    rows, _cols = darkness.shape

    def px(x, y):
        return int(round(rows - y * mm)), int(round(x * mm))

    for x, y in [(40, 20), (60, 40), (40, 60), (20, 40)]:  # mid-points of the four sides
        r, c = px(x, y)
        assert darkness[r - 1 : r + 2, c - 1 : c + 2].max() > 0.5
    inside = darkness[px(0, 55)[0] : px(0, 25)[0], px(25, 0)[1] : px(55, 0)[1]]
    assert inside.max() < 0.02
    ink = darkness > 0.05
    assert ink.sum() < 4 * 40 * mm * 4  # only the outline is inked
    assert darkness[: px(0, 65)[0]].max() < 0.02 and darkness[:, px(65, 0)[1] :].max() < 0.02


def test_square_through_sim_url_and_through_a_pty_gives_the_same_image():
    with serial.serial_for_url("sim://square-url", timeout=0.05) as port:
        send_and_wait(port, SQUARE)
    via_url = drawing(plotter("square-url"))
    check_square(via_url)

    served = VirtualPlotter(load_profile(DEFAULT_PROFILE))
    with PtyServer(served) as server, serial.Serial(server.path, 115200, timeout=0.05) as port:
        send_and_wait(port, SQUARE)
    via_pty = drawing(served)
    check_square(via_pty)
    np.testing.assert_array_equal(via_url, via_pty)
    assert plotter("square-url").seconds == pytest.approx(served.seconds)


def test_named_plotter_survives_reconnect_and_resets_on_open():
    protocol_sim.forget("again")
    with serial.serial_for_url("sim://again", timeout=0.05) as port:
        send_and_wait(port, ["G0 X5"])
    with serial.serial_for_url("sim://again", timeout=0.05) as port:
        assert port.read(100).startswith(b"\r\nGrbl")  # the board reset on open
        send_and_wait(port, ["G0 X6"])
    assert plotter("again").firmware.accepted_lines() == ["G0 X5", "G0 X6"]
    with serial.serial_for_url("sim://again?reset=0", timeout=0.05) as port:
        assert port.read(10) == b""


def test_drop_fault_raises_like_an_unplugged_port_and_reconnect_works():
    protocol_sim.forget("drops")
    port = serial.serial_for_url("sim://drops?faults=drop@2", timeout=0.05)
    send_and_wait(port, ["G0 X1"])
    port.write(b"G0 X2\n")
    with pytest.raises(serial.SerialException):
        port.read(1)
    with pytest.raises(serial.SerialException):
        port.write(b"G0 X3\n")
    port.close()
    with serial.serial_for_url("sim://drops", timeout=0.05) as again:
        send_and_wait(again, ["G0 X3"])
    assert plotter("drops").firmware.accepted_lines() == ["G0 X1", "G0 X3"]


def test_baud_emulation_limits_bytes_per_second():
    # The wire on its own clock: 9600 baud is 960 bytes a second (10 bits a byte).
    wire = wires.Wire(9600)  # the emulated line itself
    wire.put(b"x" * 100, now=10.0)
    assert wire.take(now=10.0) == b""
    assert wire.take(now=10.05) == b"x" * 48  # 50 ms: 48 bytes
    assert wire.take(now=10.05) == b""
    assert len(wire.take(now=11.0)) == 52  # the rest, never more than was sent
    instant = wires.Wire(0)
    instant.put(b"abc", now=0.0)
    assert instant.take(now=0.0) == b"abc"
    # and through a port: what the sim:// port delivers at 9600 baud is all of the banner, in order
    with serial.serial_for_url("sim://?baud=9600", timeout=0.05) as port:
        assert read_line(port) == "" and read_line(port) == "Grbl 1.1h ['$' for help]"


def test_realtime_mode_takes_wall_time_scaled():
    # 100 mm at 3000 mm/min is 2 s of machine time; at realtime=0.05 it takes 40 s of wall time.
    # The carriage is seen moving, never ahead of 0.05 x the wall time that passed (a bound that
    # a loaded host only loosens), and a reset ends the move.
    with serial.serial_for_url("sim://?realtime=0.05", timeout=0.05) as port:
        send_and_wait(port, [])
        start = time.monotonic()
        port.write(grbl.encode_line("G1 X100 F3000"))
        assert read_line(port) == "ok"
        end, x = start + SAFETY, 0.0
        while x == 0.0:
            assert time.monotonic() < end, "the carriage never moved"
            port.write(b"?")
            report = grbl.parse_line(read_line(port))
            x = report.mpos[0]
            elapsed = time.monotonic() - start
            assert report.state == "Run"
            assert x <= 0.05 * elapsed * 3000 / 60 + 1e-3  # never faster than 0.05 x real time
        assert x < 100.0


@pytest.mark.parametrize(
    "url, error",
    [
        ("sim://?colour=red", serial.SerialException),
        ("sim://?baud=fast", serial.SerialException),
        ("sim://?faults=melt@3", serial.SerialException),
        ("sim://?realtime=-1", serial.SerialException),
        ("sim://?realtime=nan", serial.SerialException),
        ("sim://?power=off", serial.SerialException),
        ("sim://?abort=maybe", serial.SerialException),
        ("sim://?limits=none", serial.SerialException),
        ("sim://?profile=no-such-plotter", ProfileError),
    ],
)
def test_bad_urls_say_what_is_wrong(url, error):
    with pytest.raises(error):
        serial.serial_for_url(url)


def test_url_options_choose_a_real_board_by_default_or_a_forgiving_one():
    protocol_sim.forget("real")
    with serial.serial_for_url("sim://real", timeout=0.05) as port:  # power=zero&abort=lose&limits=profile
        send_and_wait(port, ["G0 X50"])
        port.write(b"$$\n")
        listing = read_until_ok(port)
    assert "$20=0" in listing and "$22=0" in listing  # GRBL's factory settings
    with serial.serial_for_url("sim://real", timeout=0.05) as port:  # reopening resets (DTR)...
        port.write(b"?")
        assert read_line(port) == ""
        assert grbl.parse_line(read_line(port)) == grbl.Welcome("1.1h")
        assert grbl.parse_line(read_line(port)).mpos == (0.0, 0.0, 0.0)  # ...and the count restarts
    assert plotter("real").machine.carriage_position()[0] == 50.0
    with serial.serial_for_url("sim://?power=keep&abort=keep&limits=bed", timeout=0.05) as port:
        port.write(b"$$\n$I\n")
        text = "\n".join(read_until_ok(port) + read_until_ok(port))
    assert "$20=1" in text and "$22=1" in text and "[OPT:VL," in text  # soft limits, no init lock


def test_pty_open_resets_the_board_like_an_arduino_and_a_drop_comes_back_on_a_new_pty():
    board = VirtualPlotter(load_profile(DEFAULT_PROFILE), power="zero", faults=Faults.parse("drop@2"))
    paths, replugged = [], threading.Event()
    with PtyServer(board, on_new_path=lambda path: (paths.append(path), replugged.set())) as server:
        with serial.Serial(server.path, 115200, timeout=0.05) as port:
            send_and_wait(port, ["G0 X40"])
            port.write(b"?")
            assert b"MPos:40.000" in read_line(port).encode()  # instant clock: the move has run
        with serial.Serial(server.path, 115200, timeout=0.05) as port:
            port.write(b"?")  # reaches the board after the reset of the open, whenever that runs
            assert read_line(port) == "" and read_line(port) == "Grbl 1.1h ['$' for help]"
            assert b"MPos:0.000,0.000,0.000" in read_line(port).encode()  # the open reset the count
            port.write(b"G0 X1\n")  # line 2 of the board's log: the cable is pulled
            with pytest.raises(serial.SerialException):
                end = time.monotonic() + SAFETY
                while time.monotonic() < end:
                    port.read(10)
        assert replugged.wait(SAFETY)
        assert paths[0] != "" and server.path == paths[0]
        with serial.Serial(server.path, 115200, timeout=0.05) as port:
            send_and_wait(port, ["G0 X5"])
    assert board.firmware.accepted_lines() == ["G0 X40", "G0 X5"]
    board.firmware.finish()
    assert board.machine.carriage_position()[0] == 45.0  # 40 before the first reopen, then 5 more
