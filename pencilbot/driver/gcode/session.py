"""One conversation with a board over its port: what it is told and what it answers.

A :class:`BoardSession` wakes the board, frames and writes lines, keeps count of what is in
flight (bytes and frames, for the receive budget), reads the replies (``ok``, ``error``, resend
requests, alarms, resets, status reports), sends single commands, asks for status, halts (feed
hold, rest, reset) and says where the machine is. :class:`~pencilbot.driver.gcode.stream.Stream` adds
streaming a job through it; its docstring names the states.
"""

from __future__ import annotations

import logging
import re
import time
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from firmware_protocol import ProtocolError
from pencilbot.driver.faults import Interrupted, StreamFault
from pencilbot.driver.port import DEFAULT_TIMEOUT, LineReader, PortLost
from pencilbot.errors import PlotError
from pencilbot.firmware.base import ALARM, BUSY, ERROR, OK, RESEND, RESET, STATUS, Firmware, Reply

log = logging.getLogger(__name__)

WAKING, STREAMING, DRAINING, HALTING, DONE = "waking", "streaming", "draining", "halting", "done"
POLL_INTERVAL = 0.2  # s: status queries at 5 Hz, GRBL's recommended ceiling
_SLOWING_AT_MOST = 60.0  # s a feed hold may take to bring the machine to rest (0.1 m/s at 2 mm/s²)
_QUIET = 0.15  # s of silence after a banner before the board counts as awake
_TALK = 2000  # reads that brought bytes, not the answer: a board that talks on is given up on

#: A command line coming back from the board: an echo (a loopback, a port echoing what it got),
#: never a reply of any firmware's.
_ECHO = re.compile(r"(?:N\d+)?(?:[GM]\d+(?:\.\d+)?|[XYZ][-+]?[\d.]+)(?:[A-Z][-+]?[\d.]+)*(?:\*\d+)?")


@dataclass
class SentLine:
    """A line the board has not answered yet."""

    index: int | None  # job line, or None for a command
    size: int  # bytes it takes in the receive buffer
    number: int = 0  # the line number it was framed with (numbered firmware)
    frame: bytes = b""  # kept for a resend (numbered firmware)
    reply: Reply | None = None  # a command's answer, once it came


class BoardSession:
    """One conversation with a board: :class:`~pencilbot.driver.gcode.stream.Stream` streams a job over it.

    Parameters
    ----------
    link : LineReader
        The open port.
    firmware : Firmware
        What the board runs (from the registry).
    receive_buffer : int
        Bytes of the board's serial receive buffer the lines in flight may fill.
    timeout : float
        Seconds without any byte from the board (keep-alives and status reports count) before
        the stream gives up.
    """

    def __init__(
        self, link: LineReader, firmware: Firmware, *, receive_buffer: int, timeout: float = DEFAULT_TIMEOUT
    ):
        self.link, self.firmware = link, firmware
        self.receive_buffer, self.timeout = receive_buffer, timeout
        self.state = WAKING
        self.status: Any = None  # the last status report
        self.machine_state = ""  # what the board is doing, in its words ("Run", "Idle", …)
        self.reports = 0  # status reports received so far
        self.wco = (0.0, 0.0, 0.0)
        self.sent = -1  # the last job line written to the board
        self.rest_status = None  # the report that found the machine at rest in a halt (before the reset)
        self.answered = -1  # the last job line answered
        #: (work X, Y in mm, status, last line answered) of the last report while streaming
        self.seen: tuple[tuple[float, float] | None, Any, int] | None = None
        self.paused: str | None = None  # why the board is holding, while it is
        self._pause_key: int | str | None = None  # which pause was shown (an M0 line, or the hold button)
        self._held_by_us = False  # our pause key holds the board
        self._going_on = False  # our pause key sent cycle start and the board has not gone on yet
        self._fresh_after = 0  # reports up to this one may predate our last hold or cycle start
        self.restarted = False  # the board printed its start-up banner when woken (a reset on open)
        self.number = 0  # the last line number framed (numbered firmware)
        self._unread: deque[str] = deque()  # lines received and not yet handled
        self._sent: deque[SentLine] = deque()
        self._in_flight = 0  # bytes of the lines in self._sent
        self._resend: deque[SentLine] = deque()  # numbered frames the board asked for again
        self._lines_budget: int | None = None  # most lines in flight; None: as many as fit
        self._send_and_wait = False
        self._refusal: Reply | None = None  # an error whose line's ok is still to come
        self._swallow_ok = False  # the ok a board sends after asking for a resend
        self._numbered_acks = False  # the board's oks say which line they acknowledge
        self._answered_at = 0  # reports received when the last line was answered
        self._query_unanswered = False
        self._last_poll = 0.0
        self._on_ack: Callable[[int, str], None] = lambda index, state: None
        self._on_error = "stop"
        self._rejected: list[int] = []

    # --- setup -------------------------------------------------------------------------------

    def wake(self, wait: float = 2.5) -> str:
        """Wake the board, make sure it speaks the firmware, and return what it said it is.

        A board that just reset on port open prints its banner; one that did not (a pty, a
        socket, a reconnected cable) proves itself with a status report, or by answering the
        firmware's renumbering command; only then is a soft reset tried.

        Raises
        ------
        PlotError
            No answer of this firmware: wrong port, wrong baud rate or other firmware.
        """
        self.state = WAKING
        fw = self.firmware
        with self._guard(-1):
            self.link.write(fw.wake_bytes)
            banner = self._await_banner(wait)
            self.restarted = banner is not None
            reason = f"nothing within {2 * wait:g} s"
            if banner is None and fw.capabilities.status_reports:
                try:
                    self.query_status(wait)
                    banner = "(no banner: the board was already running)"
                except StreamFault:
                    if fw.capabilities.soft_reset:
                        self.link.write(fw.soft_reset)
                        banner = self._await_banner(wait)
                        self.restarted = banner is not None
            renumber = fw.renumber()
            if renumber is not None:
                command, self.number = renumber[0], renumber[1] - 1
                try:
                    self.command(command)
                except StreamFault as fault:
                    banner, reason = None, str(fault)
                else:
                    banner = banner or f"{fw.title} (no start message)"
        if banner is None:
            raise PlotError(
                f"no answer from a {fw.title} board on {self.link.port.name} ({reason}): check the "
                f"port, the baud rate (--baud) and that the board runs {fw.title} (a board with "
                "other firmware needs a profile for it)"
            )
        return banner

    def _await_banner(self, wait: float) -> str | None:
        """What a start-up banner seen within ``wait`` s says, once the board has been quiet
        for a moment (both: time spent listening); anything else received is dropped."""
        banner, talk = None, 0
        self.link.restart_silence()
        while talk < _TALK:
            for reply in self._replies():
                if reply.kind == RESET:
                    banner = reply.detail
            if self.link.silent_for() >= (_QUIET if banner is not None else wait):
                break
            talk += self.link.silent_for() == 0
        self.link.discard_input()
        self._unread.clear()
        return banner

    def query_status(self, wait: float | None = None):
        """Ask for a status report and return it (None if the firmware has none); other replies
        are dropped."""
        if not self.firmware.capabilities.status_reports:
            return None
        self.status, talk = None, 0
        with self._guard(-1):
            self._poll(force=True)
            self.link.restart_silence()
            while self.status is None:
                if self.link.silent_for() > (wait or self.timeout) or talk > _TALK:
                    raise StreamFault("timeout", -1, "no answer to a status query")
                for _ in self._replies():
                    pass
                talk += self.link.silent_for() == 0
        return self.status

    def wait_until_still(self):
        """Poll until the machine has finished what it was doing; its status (None without
        status reports)."""
        self.link.restart_silence()
        while True:
            status = self.query_status()
            if status is None or not self.firmware.is_moving(status):
                return status
            time.sleep(POLL_INTERVAL)

    def command(self, line: str, *, index: int = -1) -> Reply:
        """Send one line and wait for its answer: an ``ok`` or ``error`` :class:`Reply`.

        Raises
        ------
        StreamFault
            An alarm, a reset, silence or a lost port (``index`` names the job line concerned).
        """
        entry = self._framed(line, None)
        with self._guard(index):
            self._write([entry], entry.frame)
            self.link.restart_silence()
            while entry.reply is None:
                self._check_alive(index)
                for reply in self._replies():
                    self._handle(reply, index)
                    if entry.reply is not None:
                        break  # what came after the answer is the next caller's
                self._poll()
        return entry.reply

    # --- replies -----------------------------------------------------------------------------

    def _handle(self, reply: Reply, index: int) -> None:
        """What one reply does to the lines in flight; faults name job line ``index``."""
        kind = reply.kind
        if kind == OK:
            if reply.number is None and (self._swallow_ok or self._numbered_acks):
                # The ok after "Resend:" belongs to the lost frame; once the board numbers its
                # acknowledgements, a bare ok is only ever that.
                self._swallow_ok = False
                return
            self._numbered_acks |= reply.number is not None
            if reply.free is not None and not self._send_and_wait:
                self._lines_budget = max(1, reply.free)
            if reply.number is not None:  # numbered acknowledgement: every frame up to it
                while self._sent and self._sent[0].number <= reply.number:
                    self._complete(self._sent.popleft(), reply)
            elif self._sent:
                self._complete(self._sent.popleft(), reply)
            elif self.state in (STREAMING, DRAINING):
                # Every line gets one answer: an ok too many answers a line someone else sent,
                # and one of ours was taken as answered early (its bytes counted free too soon).
                raise StreamFault("unexpected", index, "an ok too many")
            else:
                log.debug("unexpected ok with nothing in flight")
        elif kind == ERROR:
            if self.firmware.errors_then_ok:
                self._refusal = reply  # the line's own ok follows
            elif self._sent:
                self._complete(self._sent.popleft(), reply)
        elif kind == RESEND:
            assert reply.number is not None  # a resend always names its line
            self._rewind(reply.number, index)
        elif kind == ALARM:
            raise StreamFault("alarm", index, reply.detail)
        elif kind == RESET:
            self._forget_in_flight()  # a board that restarts has lost what it had buffered
            raise StreamFault("reset", index, f"{reply.detail} arrived mid-job")
        elif kind == BUSY:
            self.machine_state = "Busy"
        elif self.state in (STREAMING, DRAINING) and _ECHO.fullmatch(reply.text.replace(" ", "").upper()):
            raise StreamFault("unexpected", index, f"it sent back {reply.text.strip()!r}, a command line")
        else:
            log.debug("board: %s", reply.text)

    def _complete(self, entry: SentLine, reply: Reply) -> None:
        """An answered line: free its bytes; a refused job line is a fault or skipped."""
        self._in_flight -= entry.size
        refusal, self._refusal = (self._refusal, None) if reply.kind == OK else (reply, None)
        self._answered_at = self.reports + int(self._query_unanswered)
        if entry.index is None:
            entry.reply = refusal or reply
            return
        if refusal is not None:
            if self._on_error == "stop":
                raise StreamFault("error", entry.index, refusal.detail)
            log.warning("line %d refused: %s", entry.index + 1, refusal.detail)
            self._rejected.append(entry.index)
        if self.status is None:
            self.machine_state = "Run"
        self.answered = max(self.answered, entry.index)
        self._on_ack(entry.index, self.machine_state)

    def _rewind(self, number: int, index: int) -> None:
        """The board lost frame ``number``: it and every later frame go again, in order."""
        later = [e for e in self._sent if e.number >= number]
        if not later and not any(e.number == number for e in self._resend):
            raise StreamFault(
                "error", index, f"{self.firmware.title} asked to resend line N{number}, never sent"
            )
        log.info("%s asked to resend N%d", self.firmware.title, number)
        for entry in later:
            self._sent.remove(entry)
            self._in_flight -= entry.size
        self._resend.extendleft(reversed(later))
        self._swallow_ok = True
        self._lines_budget = 1  # noise on the line: one frame at a time until the board says more

    def _replies(self) -> Iterator[Reply]:
        """The board's replies in one read slice (and any a caller left unread); status reports
        are absorbed."""
        self._unread.extend(self.link.read_lines())
        while self._unread:
            reply = self.firmware.parse(self._unread.popleft())
            if reply.kind == STATUS:
                self.status = reply.status
                self.machine_state = reply.status.state
                self.reports += 1
                self._query_unanswered = False
                if reply.status.wco is not None:
                    self.wco = reply.status.wco
                if (
                    self.state in (STREAMING, DRAINING, HALTING)
                    and self.firmware.is_moving(reply.status)
                    and self.work_position() is not None
                ):
                    # (Moving: mid-move, so the position names one line; at rest it may not.
                    # Halting: the machine still slows along its path from there.)
                    self.seen = (self.work_position(), reply.status, self.answered)
                continue
            yield reply

    # --- sending -----------------------------------------------------------------------------

    def _framed(self, line: str, index: int | None) -> SentLine:
        """``line`` framed for the firmware (numbered if it numbers lines)."""
        if self.firmware.capabilities.line_numbers:
            self.number += 1
        frame = self.firmware.frame(line, self.number)
        return SentLine(index, len(frame), self.number, frame)

    def _write(self, entries: list[SentLine], data: bytes | memoryview) -> None:
        # In flight before the write: a Ctrl-C or signal that lands inside it (the bytes gone
        # out) must still find their answers expected, or what the board ran looks unanswered.
        self._sent.extend(entries)
        self._in_flight += sum(e.size for e in entries)
        self.link.write(data)

    def _poll(self, force: bool = False) -> None:
        if not self.firmware.capabilities.status_reports:
            return
        now = time.monotonic()
        if force or now - self._last_poll >= POLL_INTERVAL:
            self._last_poll = now
            self.link.write(self.firmware.status_query)
            self._query_unanswered = True

    def _check_alive(self, index: int) -> None:
        if self.link.silent_for() > self.timeout:  # listened that long: not a host's stall
            raise StreamFault("timeout", index, f"nothing received for {self.timeout:g} s")

    def _oldest(self, nxt: int) -> int:
        """The job line a fault concerns: the oldest unanswered one, else the next to send."""
        for entry in self._sent:
            if entry.index is not None:
                return entry.index
        return nxt

    @contextmanager
    def _guard(self, index):
        """Turn a lost port and Ctrl-C into faults at ``index`` (a number or a callable)."""
        try:
            yield
        except PortLost as exc:
            raise StreamFault("port", index() if callable(index) else index, str(exc)) from None
        except KeyboardInterrupt as exc:
            by = exc.by if isinstance(exc, Interrupted) else "Ctrl-C"
            raise StreamFault("interrupt", index() if callable(index) else index, by) from None
        except ProtocolError as exc:  # a command the firmware cannot take (a profile's own)
            raise PlotError(str(exc)) from None

    # --- stopping ----------------------------------------------------------------------------

    def halt(self, wait: float | None = None) -> bool:
        """Feed hold, let the machine decelerate, then reset to drop queued moves (as far as the
        firmware can). Returns whether the machine was at rest before the reset: then its
        position is exact even if the board alarms for a reset with moves queued."""
        fw = self.firmware
        if not fw.capabilities.feed_hold:
            return False  # the queue finishes what it holds
        self.state = HALTING
        wait = min(self.timeout, 5.0) if wait is None else wait
        at_rest = False
        with self._guard(-1):
            # Where it is the moment the hold begins (a report asked for in the same write is
            # made first): it slows on along its path from there, so where it comes to rest is
            # at or past that point (a stroke that runs back over itself passes a point twice).
            self.link.write(fw.status_query + fw.feed_hold)
            self._query_unanswered, self._last_poll = True, time.monotonic()
            start = since = self.link.listening  # (waits of listening: a host's stall is no board's)
            reports, self.status = self.reports, None
            while (heard := self.link.listening) - since < wait and heard - start < _SLOWING_AT_MOST:
                self._poll()
                if self.reports > reports and self.status is not None and fw.is_moving(self.status):
                    # Still slowing (a slow acceleration takes seconds): wait on while it says so.
                    reports, since = self.reports, self.link.listening
                for reply in self._replies():
                    # The board keeps parsing what it had received: those lines reach the
                    # planner (and may run before the reset), so an ok counts as acknowledged.
                    if reply.kind in (OK, ERROR) and self._sent:
                        entry = self._sent.popleft()
                        self._in_flight -= entry.size
                        if reply.kind == OK and entry.index is not None:
                            self._on_ack(entry.index, self.machine_state)
                if at_rest := self.status is not None and fw.is_at_rest(self.status):
                    break
        self.rest_status = self.status if at_rest else None
        self.reset(wait)
        return at_rest

    def reset(self, wait: float | None = None) -> bool:
        """Soft reset: flush the board's buffers and motion; True once its banner came. Also the
        way out of a critical alarm (hard or soft limit), after which GRBL reads nothing."""
        fw = self.firmware
        self._forget_in_flight()
        if not fw.capabilities.soft_reset:
            return False
        with self._guard(-1):
            self.link.write(fw.soft_reset)
            return self._await_banner(min(self.timeout, 5.0) if wait is None else wait) is not None

    def _forget_in_flight(self) -> None:
        self._sent.clear()
        self._resend.clear()
        self._in_flight = 0
        self._refusal, self._swallow_ok = None, False

    def machine_position(self) -> tuple[float, float] | None:
        """The last reported machine position X, Y (mm), from MPos or WPos + WCO; None if unknown."""
        status = self.status
        if status is None:
            return None
        if status.mpos is not None:
            return status.mpos[0], status.mpos[1]
        if status.wpos is not None:
            return status.wpos[0] + self.wco[0], status.wpos[1] + self.wco[1]
        return None

    def jog(self, dx: float, dy: float, feed: float) -> Reply:
        """Jog by ``dx``, ``dy`` mm at ``feed`` mm/min (the firmware's jog) and wait until it stands."""
        reply = self.command(self.firmware.jog(dx, dy, feed))
        self.wait_until_still()
        return reply

    def work_position(self) -> tuple[float, float] | None:
        """The last reported work position X, Y (mm), from WPos or MPos − WCO; None if unknown."""
        status = self.status
        if status is None:
            return None
        if status.wpos is not None:
            return status.wpos[0], status.wpos[1]
        if status.mpos is not None:
            return status.mpos[0] - self.wco[0], status.mpos[1] - self.wco[1]
        return None
