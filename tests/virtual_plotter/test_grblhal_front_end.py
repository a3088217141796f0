"""The virtual plotter as a grblHAL board: its banner, build info, buffer and line limits."""

from firmware_protocol import grblhal
from pencilbot.machine.profile import load_profile
from sim.gcode.firmware import Firmware
from sim.gcode.machine import Machine

GRBLHAL = load_profile("grblhal-servo-a3")


def board(instant=True):
    fw = Firmware(Machine(GRBLHAL, instant=instant))
    assert fw.take_output().decode() == f"\r\n{grblhal.BANNER}\r\n"
    return fw


def exchange(fw, data: bytes) -> str:
    fw.receive(data)
    return fw.take_output().decode()


def test_banner_build_info_and_help_are_grblhal_s():
    fw = board()
    report = exchange(fw, b"$I\n").split("\r\n")
    assert report[0] == f"[VER:{grblhal.VERSION}.{grblhal.BUILD_DATE}:]" and report[-2:] == ["ok", ""]
    assert (
        report[1].startswith("[OPT:VNMS")
        and report[1].endswith(",35,1024,3,0]")
        and "[FIRMWARE:grblHAL]" in report
    )
    assert "$B" in exchange(fw, b"$\n")
    assert fw.machine.planner.capacity == 35
    fw.receive(b"\x18")
    assert fw.take_output().decode().endswith(f"{grblhal.BANNER}\r\n")


def test_lines_up_to_256_characters_run_and_longer_ones_overflow():
    fw = board()
    line = b"G1X10F1000" + b"Y10" * 80  # repeated word: error 25, but only after the buffer took it
    assert (
        exchange(
            fw, b"G1X10.1234567890123456789012345678901234567890123456789012345678901234567890123F1000\n"
        )
        == "ok\r\n"
    )
    assert exchange(fw, line + b"\n") == "error:25\r\n"
    assert exchange(fw, b"G1X1" + b"0" * 260 + b"\n") == "error:11\r\n"


def test_the_receive_ring_holds_1024_bytes():
    fw = board(instant=False)
    exchange(fw, b"$10=3\n")  # status reports show the buffers
    exchange(fw, b"G1 X50 F600\nG1 X0 F600\n" * 18)  # 36 moves fill the 35-block planner
    flood = b"G1 X10 Y10 F600\n" * 80  # 1280 bytes while the board is not reading
    fw.receive(flood)
    assert fw.lost_bytes == len(flood) - grblhal.RX_BUFFER_SIZE
    assert "|Bf:0,0|" in exchange(fw, b"?")  # no planner block free, the ring full
