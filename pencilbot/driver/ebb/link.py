"""Commands and their replies with an EBB board (AxiDraw, NextDraw, iDraw) over a port, in
whichever reply syntax the board is in (:mod:`firmware_protocol.ebb`)."""

from __future__ import annotations

import time

from firmware_protocol import ebb as protocol
from pencilbot.driver.port import LineReader
from pencilbot.errors import PlotError

#: QC's V+ reading (10-bit counts, 29.5 mV each after the board's divider) below which the motors
#: have no usable power: about 7.4 V at the jack, the level AxiDraw's own software warns at.
LOW_SUPPLY = 250
QC_SINCE = (2, 2, 3)  # QC: firmware 2.2.3 and newer (EBB reference)


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
        self.replies = 0  # answers read
        self.version = ""  # what V answered
        self.noise: list[str] = []  # the first lines that answered nothing sent (another board's talk)
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
        assert text is not None  # set by command() or stop_now()
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
                if len(self.noise) < 4:
                    self.noise.append(line)
                continue  # noise on the line (a glitch, another program's echo): not an answer
            self._got.append(line)
            if "Err:" in line or (line == "OK" and want > 1):
                break  # (an empty data line, as QT's without a nickname, never reaches us)
        lines, self.pending = self._got, None
        self.last_lines = lines
        self.replies += 1
        reply = protocol.read_reply(name, lines, future=self.future)
        if reply.error:
            raise EbbFault(f"the board refused {text[:40]}: {reply.error}")
        return reply

    def answer(self, text: str) -> str:
        """The value a query (QG, QS, QU, QE, QB …) answers with."""
        data = self.command(text).data
        if data is None:
            raise EbbFault(f"the board answered {text} without a value")
        return data

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

    def not_an_ebb(self, port: str, profile_name: str) -> str:
        """What to tell when the first query went unanswered: another kind of board talked, or
        nothing did."""
        heard = [line.strip() for line in self.noise if line.strip()]
        if heard:
            return (
                f"the board on {port} is not an EBB (it answered {heard[0][:40]!r}, not an EBB reply); "
                f"profile {profile_name} is an EBB plotter's: give the EBB's port (pencilbot ports lists them) "
                f"or the profile of the plotter on {port}"
            )
        return (
            f"nothing answered on {port} within {self.timeout:g} s: check that the plotter is powered and "
            f"plugged in, that {port} is its port and that it is an EBB plotter (pencilbot ports lists them)"
        )

    def status(self) -> int:
        """The QG status byte (its power-lost bit, cleared by reading, is kept in :attr:`power_lost`)."""
        value = int(self.answer("QG"), 16)
        self.power_lost = self.power_lost or bool(value & protocol.QG_POWER_LOST)
        return value

    def steps(self) -> tuple[int, int]:
        """Where the motors are, steps from home: the step counters (QS) from their origin."""
        a, b = self.answer("QS").split(",")[:2]
        return int(a) + self.origin[0], int(b) + self.origin[1]

    def wait_idle(self, limit: float) -> None:
        """Until no command runs and the FIFO is empty (QG's low four bits clear)."""
        waited = 0.0  # the pauses between queries, not the clock: a stalled host is not a moving board
        while self.status() & 0x0F:
            if waited > limit:
                raise EbbFault(f"the board was still moving after {limit:.0f} s")
            time.sleep(0.005)
            waited += 0.005


def greet(link: EbbLink) -> str:
    """Start a conversation: end any half command another program left, learn the reply syntax
    the board is in (a board left in future syntax, ``CU,10,1``, answers ``QG,…``), and return
    its version text (``V``)."""
    link.reader.write(b"\r")
    time.sleep(0.05)
    link.reader.discard_input()
    link.status()
    link.future = link.last_lines[0].startswith("QG,")
    link.version = (link.command("V").data or "").strip()
    return link.version


def version_at_least(text: str, wanted: tuple[int, ...]) -> bool:
    """Whether an EBB version string (``... Firmware Version 3.0.3``) is at least ``wanted``."""
    try:
        numbers = tuple(int(n) for n in text.rsplit(" ", 1)[-1].split(".")[: len(wanted)])
    except ValueError:
        return False
    return numbers >= wanted


def supply_volts(link: EbbLink) -> tuple[float, int]:
    """The motor supply at the board's power jack, V, and QC's raw V+ counts (board v2.3 and newer:
    a 1/9.2 divider after a 0.3 V diode drop)."""
    counts = int((link.command("QC").data or "0,0").split(",")[1])
    return counts / 1023 * 3.3 * 9.2 + 0.3, counts


def check_supply(link: EbbLink, version: str) -> None:
    """Refuse to plot on a board whose motors have no power (``QC``), in one line."""
    if not version_at_least(version, QC_SINCE):
        return  # older firmware has no QC: nothing to ask
    volts, counts = supply_volts(link)
    if counts < LOW_SUPPLY:
        raise PlotError(
            f"the plotter's motors have no power: its board reads {volts:.1f} V at the power jack "
            f"(QC; it needs about 9 V or more); plug in and switch on its power supply, then try again. "
            "Nothing was sent"
        )
