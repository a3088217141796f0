"""Stream G-code to a Marlin board: numbered, checksummed lines, one in flight, ``Resend:`` honoured.

Marlin's reply grammar and framing live in :mod:`firmware_protocol.marlin`. A line Marlin could
not trust (bad checksum or number) is answered with ``Error:…`` and ``Resend: N``; the sender
sends line N again. ``busy:`` keep-alives mean a long move is running; they reset the timeout.
"""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Callable, Sequence

from firmware_protocol import ProtocolError, marlin
from pencilbot.driver.faults import BadLine, StreamFault
from pencilbot.driver.port import LineReader, PortLost
from pencilbot.errors import PlotError

log = logging.getLogger(__name__)

#: Marlin ``Error:`` texts that announce a ``Resend`` rather than a failed command.
_TRANSMISSION_ERRORS = ("checksum", "line number", "no line number", "no checksum")


_FRAMED = re.compile(r"N\d+(.*?)(?:\*\d+)?")


def command_of(line: str) -> str:
    """A cleaned line without the ``N…`` / ``*checksum`` a profile with line numbers wrote into
    the file: the session numbers lines itself, continuing where the board expects."""
    framed = _FRAMED.fullmatch(line)
    return framed.group(1) if framed else line


def check_lines(lines: Sequence[str]) -> None:
    """Raise :class:`BadLine` for the first line Marlin cannot take once numbered."""
    widest = len(lines) + 10  # line numbers grow with resends and set-up commands
    for index, line in enumerate(lines):
        try:
            marlin.frame_line(widest, command_of(line))
        except ProtocolError as exc:
            raise BadLine(index, str(exc)) from None


class MarlinSession:
    """One conversation with a Marlin board.

    Parameters
    ----------
    reader : LineReader
        The open port.
    timeout : float
        Seconds without any byte from the board (``busy:`` included) before giving up.
    """

    def __init__(self, reader: LineReader, *, timeout: float = 10.0):
        self.reader = reader
        self.timeout = timeout
        self.number = 0  # number of the last framed line
        self.state = ""

    def wake(self, wait: float = 2.5) -> str:
        """Wait for Marlin's ``start`` (boards reset on port open), then reset line numbering."""
        self.reader.write(b"\n")
        deadline = time.monotonic() + wait
        started = False
        while time.monotonic() < deadline and not started:
            started = any(isinstance(marlin.parse_line(t), marlin.Start) for t in self.reader.read_lines())
        self.reader.discard_input()
        self.number = 0
        try:
            self._send_and_wait(marlin.reset_line_numbers(0), {0: marlin.reset_line_numbers(0)}, -1)
        except StreamFault as fault:
            raise PlotError(
                f"no answer from a Marlin board on {self.reader.port.name} ({fault}): check the port, "
                "the baud rate (--baud) and that the board runs Marlin (a GRBL board needs a grbl profile)"
            ) from None
        return "Marlin" if started else "Marlin (no start message)"

    def query_status(self, wait: float | None = None):
        """Marlin has no realtime status; nothing to ask."""
        return None

    def work_position(self):
        """Unknown: Marlin has no realtime position report."""
        return None

    def halt(self, wait: float = 5.0) -> bool:
        """Marlin has no feed hold over the line protocol; the queue finishes what it holds."""
        return False

    def command(self, line: str, *, index: int = -1):
        """Send one numbered line and wait for its ``ok`` (``Error`` returned if not a resend)."""
        self.number += 1
        frame = marlin.frame_line(self.number, line)
        return self._send_and_wait(frame, {self.number: frame}, index)

    def _send_and_wait(self, frame: bytes, frames: dict[int, bytes], index: int):
        self.reader.write(frame)
        self.reader.last_rx = time.monotonic()
        failure = None
        swallow_ok = False  # Marlin follows "Resend: N" with an ok that belongs to the bad line
        while True:
            if time.monotonic() - self.reader.last_rx > self.timeout:
                raise StreamFault("timeout", index, f"nothing received for {self.timeout:g} s")
            for text in self.reader.read_lines():
                message = marlin.parse_line(text)
                if isinstance(message, marlin.Ok):
                    if swallow_ok:
                        swallow_ok = False
                        continue
                    return failure or message
                if isinstance(message, marlin.Resend):
                    again = frames.get(message.line_number)
                    if again is None:
                        raise StreamFault("error", index, f"Marlin asked to resend line N{message.line_number}, never sent")
                    log.info("Marlin asked to resend N%d", message.line_number)
                    self.reader.write(again)
                    failure, swallow_ok = None, True
                elif isinstance(message, marlin.Error):
                    if not message.text.lower().startswith(_TRANSMISSION_ERRORS):
                        failure = message
                elif isinstance(message, marlin.Start):
                    raise StreamFault("reset", index, "Marlin printed 'start' mid-job")
                elif isinstance(message, marlin.Busy):
                    self.state = "Busy"
                else:
                    log.debug("board: %s", text)

    def stream(
        self,
        lines: Sequence[str],
        start: int,
        on_ack: Callable[[int, str], None],
        *,
        send_and_wait: bool = True,
        on_error: str = "stop",
    ) -> list[int]:
        """Send ``lines[start:]`` one at a time; see :meth:`GrblSession.stream` for the contract."""
        rejected: list[int] = []
        index = start
        try:
            for index in range(start, len(lines)):
                reply = self.command(command_of(lines[index]), index=index)
                if isinstance(reply, marlin.Error):
                    if on_error == "stop":
                        raise StreamFault("error", index, f"Error:{reply.text}")
                    log.warning("line %d rejected: Error:%s", index + 1, reply.text)
                    rejected.append(index)
                self.state = "Run"
                on_ack(index, self.state)
            self.command("M400", index=len(lines) - 1)  # wait for the last moves to finish
            self.state = "Idle"
        except PortLost as exc:
            raise StreamFault("port", index, str(exc)) from None
        except KeyboardInterrupt:
            raise StreamFault("interrupt", index) from None
        return rejected
