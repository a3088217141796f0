"""Stream G-code to a GRBL 1.1 board: character counting or send-and-wait, status polling, stop.

Character counting keeps the board's 128-byte receive buffer as full as possible: a line is sent
as soon as the bytes of all unacknowledged lines plus its own fit in the budget, so the planner
never starves. Send-and-wait sends one line per ``ok``. Every board message is parsed by
:mod:`firmware_protocol.grbl`; this module only decides what to send when.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Sequence

from firmware_protocol import ProtocolError, grbl
from pencilbot.driver.faults import BadLine, StreamFault
from pencilbot.driver.port import LineReader, PortLost
from pencilbot.errors import PlotError

log = logging.getLogger(__name__)

POLL_INTERVAL = 0.2  # s: status queries at 5 Hz, GRBL's recommended ceiling
HOLD_STATES = ("Idle", "Alarm", "Check", "Sleep")


def encode_lines(lines: Sequence[str]) -> list[bytes]:
    """Each line framed for GRBL; :class:`BadLine` names the first one GRBL cannot take."""
    encoded = []
    for index, line in enumerate(lines):
        try:
            encoded.append(grbl.encode_line(line))
        except ProtocolError as exc:
            raise BadLine(index, str(exc)) from None
    return encoded


class GrblSession:
    """One conversation with a GRBL board over a :class:`LineReader`.

    Parameters
    ----------
    reader : LineReader
        The open port.
    budget : int
        Receive-buffer bytes the sender may fill (the profile's ``receive_buffer``).
    timeout : float
        Seconds without any byte from the board (status polls included) before giving up.
    """

    def __init__(self, reader: LineReader, *, budget: int = grbl.RX_BUFFER_SIZE, timeout: float = 10.0):
        self.reader = reader
        self.budget = budget
        self.timeout = timeout
        self.status: grbl.Status | None = None
        self._pending: deque[tuple[int, int]] = deque()
        self._on_ack: Callable[[int, str], None] = lambda index, state: None
        self.wco: tuple[float, ...] = (0.0, 0.0, 0.0)
        self._last_poll = 0.0
        self.reports = 0  # status reports received so far
        self._query_unanswered = False  # a "?" was sent and no report has come since

    # --- messages ------------------------------------------------------------------------

    def _messages(self):
        """Parsed board messages received in one read slice; status reports are absorbed."""
        for text in self.reader.read_lines():
            message = grbl.parse_line(text)
            if isinstance(message, grbl.Status):
                self.status = message
                self.reports += 1
                self._query_unanswered = False
                if message.wco is not None:
                    self.wco = message.wco
                continue
            if isinstance(message, (grbl.Unknown, grbl.Feedback, grbl.Setting)):
                log.debug("board: %s", text)
            yield message

    def _poll(self, force: bool = False) -> None:
        now = time.monotonic()
        if force or now - self._last_poll >= POLL_INTERVAL:
            self._last_poll = now
            self.reader.write(grbl.STATUS_QUERY)
            self._query_unanswered = True

    def _check_alive(self, index: int) -> None:
        if time.monotonic() - self.reader.last_rx > self.timeout:
            raise StreamFault("timeout", index, f"nothing received for {self.timeout:g} s")

    @property
    def state(self) -> str:
        """Last reported machine state (``"Idle"``, ``"Run"``, ``"Hold"``, …) or ``""``."""
        return self.status.state if self.status else ""

    def work_position(self) -> tuple[float, float] | None:
        """Last reported work position X, Y (mm), from WPos or MPos − WCO."""
        if self.status is None:
            return None
        if self.status.wpos is not None:
            return self.status.wpos[0], self.status.wpos[1]
        if self.status.mpos is not None:
            return self.status.mpos[0] - self.wco[0], self.status.mpos[1] - self.wco[1]
        return None

    # --- setup ---------------------------------------------------------------------------

    def wake(self, wait: float = 2.5) -> str:
        """Wake the board, make sure it speaks GRBL, and return its version.

        Sends line endings (a board that just reset on port open ignores the first bytes) and
        waits for the banner. A board that did not reset (a pty, a socket, a reconnected cable)
        sends none: a status report proves it is GRBL without disturbing it, and only if that
        fails too does a soft reset ask for the banner. The ``ok`` replies to the line endings
        are read and dropped here so they never count as answers to job lines.

        Raises
        ------
        PlotError
            No GRBL answer: wrong port, wrong baud rate or not a GRBL board.
        """
        self.reader.write(b"\r\n\r\n")
        version = self._await_banner(wait)
        if version is None:
            try:
                self.query_status(wait)
                return "(no banner: the board was already running)"
            except StreamFault:
                self.reader.write(grbl.SOFT_RESET)
                version = self._await_banner(wait)
        if version is None:
            raise PlotError(
                f"no answer from a GRBL board on {self.reader.port.name} within {2 * wait:g} s: check the "
                "port, the baud rate (--baud) and that the board runs GRBL (a Marlin board needs a marlin profile)"
            )
        return version

    def wait_until_still(self) -> grbl.Status:
        """Poll until the machine has finished what it was doing (not Run/Jog/Home)."""
        self.reader.last_rx = time.monotonic()
        while True:
            status = self.query_status()
            if status.state not in ("Run", "Jog", "Home"):
                return status
            time.sleep(POLL_INTERVAL)

    def _await_banner(self, wait: float, quiet: float = 0.15) -> str | None:
        """The version of a banner seen within ``wait`` s, once nothing more arrived for ``quiet`` s."""
        deadline = time.monotonic() + wait
        version = None
        while time.monotonic() < deadline:
            for message in self._messages():
                if isinstance(message, grbl.Welcome):
                    version = message.version
            if version is not None and time.monotonic() - self.reader.last_rx >= quiet:
                break
        self.reader.discard_input()
        return version

    def query_status(self, wait: float | None = None) -> grbl.Status:
        """Ask for a status report and return it (other messages are dropped)."""
        self.status = None
        self._poll(force=True)
        deadline = time.monotonic() + (wait or self.timeout)
        while self.status is None:
            if time.monotonic() > deadline:
                raise StreamFault("timeout", -1, "no answer to a status query")
            for _ in self._messages():
                pass
        return self.status

    def command(self, line: str, *, index: int = -1) -> grbl.Ok | grbl.Error:
        """Send one line and wait for its ``ok`` or ``error:N``.

        Raises
        ------
        StreamFault
            On an alarm, a reset banner, a timeout or a lost port.
        """
        self.reader.write(grbl.encode_line(line))
        self.reader.last_rx = time.monotonic()
        while True:
            self._check_alive(index)
            for message in self._messages():
                if isinstance(message, (grbl.Ok, grbl.Error)):
                    return message
                self._fault_for(message, index)
            self._poll()

    def _fault_for(self, message, index: int) -> None:
        if isinstance(message, grbl.Alarm):
            raise StreamFault("alarm", index, f"ALARM:{message.code} {message.text}: {message.explanation}")
        if isinstance(message, grbl.Welcome):
            raise StreamFault("reset", index, f"banner 'Grbl {message.version}' arrived mid-job")

    # --- streaming -----------------------------------------------------------------------

    def stream(
        self,
        lines: Sequence[str],
        start: int,
        on_ack: Callable[[int, str], None],
        *,
        send_and_wait: bool = False,
        on_error: str = "stop",
    ) -> list[int]:
        """Send ``lines[start:]`` and wait until the machine is idle.

        Parameters
        ----------
        lines : sequence of str
            Cleaned G-code lines (each fits GRBL's line buffer).
        start : int
            First index to send.
        on_ack : callable
            Called as ``on_ack(index, state)`` for every answered line, in order.
        send_and_wait : bool
            One line in flight instead of filling the receive buffer.
        on_error : {"stop", "continue"}
            What an ``error:N`` does: raise a fault, or log it and go on.

        Returns
        -------
        list of int
            Indices of lines the board rejected (only with ``on_error="continue"``).

        Raises
        ------
        StreamFault
            ``error`` (with ``on_error="stop"``), ``alarm``, ``reset``, ``timeout``, ``port``
            or ``interrupt``; ``index`` is the line concerned.
        """
        encoded = encode_lines(lines)
        pending: deque[tuple[int, int]] = deque()  # (index, bytes) sent and not yet answered
        # Kept for halt(): lines still in flight when a fault stops the stream are answered late.
        self._pending, self._on_ack = pending, on_ack
        in_flight = 0
        rejected: list[int] = []
        nxt = start
        self.reader.last_rx = time.monotonic()
        answered_at = self.reports  # "finished" needs a status report newer than the last ok
        try:
            while True:
                chunk = []
                while nxt < len(lines) and not (send_and_wait and pending):
                    size = len(encoded[nxt])
                    if in_flight + size > self.budget:
                        break
                    chunk.append(encoded[nxt])
                    pending.append((nxt, size))
                    in_flight += size
                    nxt += 1
                if chunk:
                    self.reader.write(b"".join(chunk))
                self._poll()
                for message in self._messages():
                    if isinstance(message, (grbl.Ok, grbl.Error)):
                        if not pending:
                            log.debug("unexpected %s with nothing in flight", message)
                            continue
                        index, size = pending.popleft()
                        in_flight -= size
                        # A "?" that reached the board while it parsed this line is answered
                        # right after the ok but before GRBL starts the cycle: that report can
                        # say Idle with the line's move still queued. Only the next one counts.
                        answered_at = self.reports + int(self._query_unanswered)
                        if isinstance(message, grbl.Error):
                            detail = f"error:{message.code} {message.text}: {message.explanation}"
                            if on_error == "stop":
                                raise StreamFault("error", index, detail)
                            log.warning("line %d rejected: %s", index + 1, detail)
                            rejected.append(index)
                        on_ack(index, self.state)
                    else:
                        self._fault_for(message, pending[0][0] if pending else nxt)
                self._check_alive(pending[0][0] if pending else nxt)
                if not pending and nxt >= len(lines) and self.reports > answered_at and self.state in ("Idle", "Check"):
                    break
        except PortLost as exc:
            raise StreamFault("port", pending[0][0] if pending else nxt, str(exc)) from None
        except KeyboardInterrupt:
            raise StreamFault("interrupt", pending[0][0] if pending else nxt) from None
        return rejected

    # --- stopping ------------------------------------------------------------------------

    def halt(self, wait: float | None = None) -> bool:
        """Feed hold, let the machine decelerate, then soft-reset to drop queued moves.

        Returns whether the machine was at rest (hold complete or idle) before the reset: then
        its position is exact even if the board raises ``ALARM:3`` for a reset with moves queued.
        """
        wait = min(self.timeout, 5.0) if wait is None else wait
        self.reader.write(grbl.FEED_HOLD)
        deadline = time.monotonic() + wait
        self.status = None
        at_rest = False
        while time.monotonic() < deadline and not at_rest:
            self._poll()
            for message in self._messages():
                # The board keeps parsing what it had received: those lines reach the planner
                # (and may run before the reset), so they count as acknowledged.
                if isinstance(message, (grbl.Ok, grbl.Error)) and self._pending:
                    index, _ = self._pending.popleft()
                    if isinstance(message, grbl.Ok):
                        self._on_ack(index, self.state)
            st = self.status
            at_rest = st is not None and (st.state in HOLD_STATES or (st.state == "Hold" and st.substate == 0))
        self.reset(wait)
        return at_rest

    def reset(self, wait: float | None = None) -> bool:
        """Soft reset (0x18): flush the board's buffers and planner; True once the banner came.

        Also the way out of a critical alarm (hard/soft limit), after which GRBL reads nothing.
        """
        self.reader.write(grbl.SOFT_RESET)
        return self._await_banner(min(self.timeout, 5.0) if wait is None else wait) is not None
