"""Commands and their replies with an EBB board (AxiDraw, NextDraw, iDraw) over a port, in
whichever reply syntax the board is in (:mod:`firmware_protocol.ebb`)."""

from __future__ import annotations

import time

from firmware_protocol import ebb as protocol
from pencilbot.driver.port import LineReader


class EbbFault(Exception):
    """The board refused a command, went silent or the port was lost."""


class EbbLink:
    """Commands and their replies over a port, in whichever syntax the board is in."""

    def __init__(self, reader: LineReader, timeout: float):
        self.reader, self.timeout = reader, timeout
        self.future = False
        self.power_lost = False
        self.watch_power = False  # CU,60 set: QG's bit 6 means something
        self.fifo_depth = 1  # the board's motion FIFO (1 at boot; CU,4 deepens it on firmware 3.x)
        #: Motor steps from home where the counters read 0 (not home after a guided re-zero).
        self.origin: tuple[int, int] = (0, 0)
        self.pending: str | None = None  # the command whose answer is still to be read
        self._got: list[str] = []
        self._lines: list[str] = []

    def command(self, text: str, wait: float | None = None) -> protocol.Reply:
        """Send one command and read its whole reply (a motion command's comes once the FIFO
        has room: ``wait`` bounds that, default the link's timeout)."""
        self.pending, self._got = text, []  # kept if an interrupt cuts the wait short
        self.reader.write(text.encode("ascii") + b"\r")
        return self._receive(wait)

    def _receive(self, wait: float | None) -> protocol.Reply:
        text = self.pending
        name = text.split(",")[0].upper()
        want = protocol.reply_lines(name, future=self.future)
        limit = wait if wait is not None else self.timeout
        self.reader.restart_silence()
        while len(self._got) < want:
            if not self._lines:
                self._lines = self.reader.read_lines()
                if not self._lines:
                    if self.reader.silent_for() > limit:  # time spent listening, not a host's stall
                        self.pending = None  # its answer is lost: later answers are other commands'
                        raise EbbFault(f"the board did not answer {text[:24]} within {self.timeout:g} s")
                    continue
            line = self._lines.pop(0)
            if not protocol.plausible(name, line, future=self.future):
                continue  # noise on the line (a glitch, another program's echo): not an answer
            self._got.append(line)
            if "Err:" in line:
                break
        lines, self.pending = self._got, None
        self.last_lines = lines
        reply = protocol.read_reply(name, lines, future=self.future)
        if reply.error:
            raise EbbFault(f"the board refused {text[:40]}: {reply.error}")
        return reply

    def stop_now(self, wait: float) -> None:
        """ES at once, even while a command is still waiting for its answer (the board reads ES
        right after it): that answer first, then ES's."""
        cut_short = self.pending
        self.reader.write(b"ES\r")
        if cut_short is not None:
            try:
                self._receive(wait)
            except EbbFault:
                self.pending = None  # refused or silent: ES's own answer follows all the same
        self.pending, self._got = "ES", []
        self._receive(None)

    def status(self) -> int:
        """The QG status byte (its power-lost bit, cleared by reading, is kept in :attr:`power_lost`)."""
        value = int(self.command("QG").data, 16)
        self.power_lost = self.power_lost or bool(value & protocol.QG_POWER_LOST)
        return value

    def steps(self) -> tuple[int, int]:
        """Where the motors are, steps from home: the step counters (QS) from their origin."""
        a, b = self.command("QS").data.split(",")[:2]
        return int(a) + self.origin[0], int(b) + self.origin[1]

    def wait_idle(self, limit: float) -> None:
        """Until no command runs and the FIFO is empty (QG's low four bits clear)."""
        waited = 0.0  # the pauses between queries, not the clock: a stalled host is not a moving board
        while self.status() & 0x0F:
            if waited > limit:
                raise EbbFault(f"the board was still moving after {limit:.0f} s")
            time.sleep(0.005)
            waited += 0.005
