"""One streaming core for every firmware: named states, a receive budget, faults handled once.

A :class:`Stream` talks to one board over a :class:`~pencilbot.driver.port.LineReader` (the
conversation itself: :class:`~pencilbot.driver.gcode.session.BoardSession`); what the board's bytes
mean, how lines are framed and what the board can do come from its firmware module
(:mod:`pencilbot.firmware`), so nothing here knows a firmware by name. Its states:

``waking``
    The port is open; the board is woken and proved to speak the firmware (banner, status
    report, or a renumbering command answered).
``streaming``
    Job lines go out as long as the lines in flight fit the budget: their bytes within the
    board's receive buffer (character counting), their count within a line budget. A line
    budget of one is send-and-wait; a firmware that reports free command slots (Marlin's
    ADVANCED_OK) widens it to what the board says it can take.
``draining``
    Every line is sent; the stream waits for the last answers and for the machine to finish
    (an idle status report newer than the last ``ok``, or the firmware's drain command).
``halting``
    After a fault: feed hold, let the machine come to rest, reset (as the firmware allows).
``done``
    The job ran to its end.

Everything that can stop a stream (a refused line, an alarm, a reset, silence, a lost port, a reply
nobody asked for (an ok too many, a line sent back: another program on the port), Ctrl-C)
becomes one :class:`~pencilbot.driver.faults.StreamFault` naming the job line; the caller turns
it into a message.
A board in Hold (an ``M0`` of the job, the machine's button, the pause key) is served beside
``streaming``: the reason is shown once, cycle start goes when someone answers, and the wait
never times out (a held board still answers status queries).
"""

from __future__ import annotations

from collections.abc import Callable

from pencilbot.driver.faults import StreamFault
from pencilbot.driver.gcode.job import Job
from pencilbot.driver.gcode.session import DONE, DRAINING, STREAMING, BoardSession, SentLine


class Stream(BoardSession):
    """One conversation with a board that streams a job through it (the states: see the module);
    made as a :class:`~pencilbot.driver.gcode.session.BoardSession` is."""

    # --- streaming ---------------------------------------------------------------------------

    def stream(
        self,
        job: Job,
        start: int,
        on_ack: Callable[[int, str], None],
        *,
        send_and_wait: bool = False,
        on_error: str = "stop",
        on_pause: Callable[[str], bool] | None = None,
        keys=None,
        on_hold: Callable[[str], None] | None = None,
    ) -> list[int]:
        """Send job lines ``start …`` and wait until the machine has run them.

        Parameters
        ----------
        job : Job
        start : int
            First index to send.
        on_ack : callable
            ``on_ack(index, machine_state)`` for every answered line, in order.
        send_and_wait : bool
            One line in flight instead of filling the receive buffer.
        on_error : {"stop", "continue"}
            A refused line raises a fault, or is logged and skipped.
        on_pause : callable, optional
            ``on_pause(reason)`` when the board holds by itself (an ``M0`` in the job: the
            reason is the comment beside it; the machine's feed-hold button); it returns True to
            send cycle start. Without it, or when it returns False, the stream waits (never
            timing out: the board still answers) until the machine's own cycle start.
        keys : KeyReader, optional
            Requests from the keyboard: ``"pause"`` (feed hold, again: cycle start), ``"stop"``.
        on_hold : callable, optional
            ``on_hold(reason)`` once when the board holds at a ``"pause"`` key (a front end
            shows it paused; the same key resumes it).

        Returns
        -------
        list of int
            Indices of lines the board refused (only with ``on_error="continue"``).

        Raises
        ------
        StreamFault
            ``error`` (with ``on_error="stop"``), ``alarm``, ``reset``, ``timeout``, ``port``
            or ``interrupt``; ``index`` is the line concerned.
        """
        fw = self.firmware
        self._begin_streaming(on_ack, on_error, send_and_wait)
        drain = None
        last_asked = False
        nxt = start
        self.link.restart_silence()
        with self._guard(lambda: self._oldest(nxt)):
            while self.state != DONE:
                if self.state == STREAMING:
                    nxt = self._fill(job, nxt)
                    if nxt >= len(job) and not self._resend:
                        self.state = DRAINING
                if self.state == DRAINING and fw.drain_command and drain is None and not self._sent:
                    drain = self._framed(fw.drain_command, None)
                    self._write([drain], drain.frame)
                # The last line answered: ask at once whether the machine is done (a job that
                # ends idle ends now, not at the next 5 Hz poll).
                self._poll(force=self.state == DRAINING and not self._sent and not last_asked)
                last_asked = last_asked or (self.state == DRAINING and not self._sent)
                for reply in self._replies():
                    self._handle(reply, self._oldest(nxt))
                if keys is not None:
                    self._serve_keys(keys, self._oldest(nxt))
                self._serve_pause(job, on_pause, on_hold)
                self._check_alive(self._oldest(nxt))
                if self.state == DRAINING and self._drained(drain):
                    self.state = DONE
        self.machine_state = self.status.state if self.status is not None else "Idle"
        return self._rejected

    def _begin_streaming(self, on_ack, on_error: str, send_and_wait: bool) -> None:
        self.state = STREAMING
        self._on_ack, self._on_error, self._rejected = on_ack, on_error, []
        # A numbered firmware starts at one line and widens to what the board reports free.
        self._lines_budget = 1 if send_and_wait or self.firmware.capabilities.line_numbers else None
        self._send_and_wait = send_and_wait
        self._answered_at = self.reports

    def _serve_pause(self, job: Job, on_pause, on_hold=None) -> None:
        """A board in Hold: say why once (the M0 line's comment, the machine's button, our own
        key) and, if someone answers, send cycle start."""
        status = self.status
        if self.reports <= self._fresh_after:
            return  # a report asked for before the cycle start: it may still say Hold
        if status is None or not self.firmware.is_paused(status):
            self.paused = self._pause_key = None
            self._going_on = False
            return
        if self.firmware.is_moving(status):
            return  # a hold still slowing the machine: GRBL takes a cycle start only once it stands
        if self._going_on:
            # Our cycle start came while the hold was still slowing, and the board dropped it.
            self.link.write(self.firmware.cycle_start)
            self._fresh_after = self.reports + int(self._query_unanswered)
            return
        index = next((e.index for e in self._sent if e.index is not None and e.index in job.pauses), None)
        key = index if index is not None else "hold"
        if key == self._pause_key:
            self.machine_state = f"paused: {self.paused}"
            return  # shown already (and a report sent before the cycle start may still say Hold)
        self._pause_key = key
        if index is not None:
            self.paused = job.pauses[index] or f"program pause ({job.line(index)})"
        else:
            self.paused = (
                "from the keyboard (press the pause key to go on)"
                if self._held_by_us
                else "feed hold on the machine"
            )
        self.machine_state = f"paused: {self.paused}"
        if self._held_by_us and index is None:
            if on_hold is not None:
                on_hold(self.paused)
            return  # the key that paused resumes
        if on_pause is not None and on_pause(self.paused):
            self._held_by_us = False
            self.link.write(self.firmware.cycle_start)
            self._fresh_after = self.reports + int(self._query_unanswered)
        self.link.restart_silence()  # waiting for the user is not the board's silence

    def _serve_keys(self, keys, index: int) -> None:
        for request in keys.poll():
            if request == "stop":
                raise StreamFault("interrupt", index, "the stop key")
            if request == "pause" and self.firmware.capabilities.feed_hold:
                held = self._held_by_us or (self.status is not None and self.firmware.is_paused(self.status))
                self.link.write(self.firmware.cycle_start if held else self.firmware.feed_hold)
                self._held_by_us, self._going_on = not held, held
                self._fresh_after = self.reports + int(self._query_unanswered)

    def _fill(self, job: Job, nxt: int) -> int:
        """Send what fits of the frames asked for again, then of ``job`` from ``nxt``; return the
        next line to send."""
        while self._resend and self._fits(self._resend[0].size):
            entry = self._resend.popleft()
            self._write([entry], entry.frame)
        if self._resend:
            return nxt
        numbered = self.firmware.capabilities.line_numbers
        entries: list[SentLine] = []
        first, batch = nxt, 0
        waits = job.system.waits
        while nxt < len(job):
            if nxt - 1 in waits and (entries or not self._moved_alone()):
                break  # a jog or homing first ends: the board refuses G-code meanwhile
            entry = self._framed(job.line(nxt), nxt) if numbered else SentLine(nxt, job.size(nxt))
            if not self._fits(entry.size, len(entries), batch):
                self.number -= numbered  # not sent: its number is the next frame's
                break
            entries.append(entry)
            batch += entry.size
            nxt += 1
        if entries:
            # Counted before the write: a stop that lands between the two must not miss lines
            # the board may have (a line counted but never written only widens the search).
            self.sent = max(self.sent, nxt - 1)
            self._write(
                entries, b"".join(e.frame for e in entries) if numbered else job.frames_between(first, nxt)
            )
        return nxt

    def _moved_alone(self) -> bool:
        """Whether the line before has been answered and a status report newer than that says the
        machine is not moving (a jog or homing cycle over)."""
        return (
            not self._sent
            and self.reports > self._answered_at
            and self.status is not None
            and not self.firmware.is_moving(self.status)
        )

    def _fits(self, size: int, lines: int = 0, batch: int = 0) -> bool:
        """Whether a frame of ``size`` bytes may go now, after ``lines`` frames of ``batch`` bytes
        that go with it: within the line budget, and within the receive buffer (one line always
        goes when nothing is in flight)."""
        in_flight = len(self._sent) + lines
        if self._lines_budget is not None and in_flight >= self._lines_budget:
            return False
        return in_flight == 0 or self._in_flight + batch + size <= self.receive_buffer

    def _drained(self, drain: SentLine | None) -> bool:
        if self._sent or self._resend:
            return False
        if self.firmware.drain_command:
            return drain is not None and drain.reply is not None
        # A "?" that reached the board while it parsed the last line is answered right after
        # the ok but before GRBL starts the cycle: that report can say Idle with the move still
        # queued. Only a report newer than that counts.
        return (
            self.reports > self._answered_at
            and self.status is not None
            and self.firmware.is_finished(self.status)
        )
