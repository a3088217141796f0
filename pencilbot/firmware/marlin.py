"""Marlin 2: numbered, checksummed lines, ``Resend:``, ``busy:``, ADVANCED_OK buffer counts."""

from __future__ import annotations

import re

import numpy as np

from firmware_protocol import marlin as protocol
from pencilbot.firmware.base import BUSY, ERROR, OK, OTHER, RESEND, RESET, Capabilities, Firmware, Reply

#: ``Error:`` texts that announce a ``Resend`` (a line lost to noise) rather than a refused command.
_TRANSMISSION_ERRORS = ("checksum", "line number", "no line number", "no checksum")
_FRAMED = re.compile(rb"(?m)^N\d+(.*?)(?:\*\d+)?$")
_ODD = np.zeros(256, dtype=bool)  # bytes a framed line may not hold: non-ASCII, '*'
_ODD[128:] = _ODD[ord("*")] = True


class Marlin(Firmware):
    """Marlin 2 over its serial line protocol."""

    name = "marlin"
    title = "Marlin"
    protocol = protocol
    capabilities = Capabilities(line_numbers=True)
    receive_buffer = 128  # Marlin's default RX_BUFFER_SIZE
    line_limit = protocol.MAX_CMD_SIZE - 1  # numbered and checksummed
    planner_blocks = 16  # Marlin's default BLOCK_BUFFER_SIZE
    dwell_units = 1000.0  # G4 P is milliseconds
    rapids_take_feed = True
    errors_then_ok = True
    frame_room = len("N1234567 ") + len("*255")
    wake_bytes = b"\n"
    drain_command = "M400"  # returns once every queued move has run
    home_command = "G28XY"
    motors_off_command = "M18"  # (M84 is the same) the steppers let go until the next move
    motors_on_command = "M17"

    def origin_move(self, feed: float) -> str:
        return f"G0X0Y0F{feed:g}"

    def set_origin(self, x: float, y: float, z: str = "") -> str:
        return f"G92X{x:.4f}Y{y:.4f}{z}"  # Marlin's work offset: the position reads x, y

    def frame(self, command: str, number: int) -> bytes:
        return self.protocol.frame_line(number, command)

    def commands(self, cleaned: bytes) -> bytes:
        """The lines without the ``N…`` / ``*checksum`` a profile with line numbers wrote into the
        file: the sender numbers lines itself, continuing where the board expects."""
        return _FRAMED.sub(rb"\1", cleaned)

    def check_lines(self, job) -> tuple[int, str] | None:
        widest = len(job) + 10  # line numbers grow with resends and set-up commands
        a = np.frombuffer(job.frames, dtype=np.uint8)
        lengths = np.diff(job.offsets) - 1
        room = self.protocol.MAX_CMD_SIZE - len(f"N{widest} *0")  # the shortest checksum
        odd = np.flatnonzero(_ODD[a])
        suspects = np.union1d(
            np.flatnonzero(lengths >= room), np.searchsorted(job.offsets, odd, side="right") - 1
        )
        return self._first_refused(job, suspects.tolist(), number=widest)

    def renumber(self) -> tuple[str, int]:
        return "M110 N0", 0  # the next line is N1

    def parse(self, text: str) -> Reply:
        message = self.protocol.parse_line(text)
        if isinstance(message, protocol.Ok):
            return Reply(OK, text, number=message.line_number, free=message.buffer_free)
        if isinstance(message, protocol.Resend):
            return Reply(RESEND, text, number=message.line_number)
        if isinstance(message, protocol.Error):
            if message.text.lower().startswith(_TRANSMISSION_ERRORS):
                return Reply(OTHER, text)  # the Resend that follows says what to do
            return Reply(ERROR, text, f"Error:{message.text}")
        if isinstance(message, protocol.Start):
            return Reply(RESET, text, "Marlin printed 'start'")
        if isinstance(message, protocol.Busy):
            return Reply(BUSY, text)
        return Reply(OTHER, text)

    def number_lines(self, lines: list[bytes]) -> list[bytes]:
        """``N<n> <command>*<checksum>`` on every command line, starting with ``M110 N0``.

        Comment lines stay as they are; trailing comments go, since Marlin would read a ``*`` after
        ``;`` as comment. Same framing as :meth:`frame`, with the XOR done by numpy over all lines
        at once (a Python loop per byte is seconds for a big plan).
        """
        lines = [b"M110 N0", *lines]
        is_command = [not line.startswith(b";") for line in lines]
        numbered = [
            b"N%d %s" % (n, line.split(b";")[0].rstrip())
            for n, line in enumerate(line for line, cmd in zip(lines, is_command) if cmd)
        ]
        lengths = np.fromiter(map(len, numbered), dtype=np.int64, count=len(numbered))
        blob = np.frombuffer(b"".join(numbered), dtype=np.uint8)
        checksums = np.bitwise_xor.reduceat(blob, np.cumsum(lengths) - lengths).tolist()
        framed = iter([b"%s*%d" % (line, cs) for line, cs in zip(numbered, checksums)])
        return [next(framed) if cmd else line for line, cmd in zip(lines, is_command)]


MARLIN = Marlin()
