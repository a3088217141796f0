"""Streaming to a plotter that acknowledges nothing (HP-GL): poll its free buffer bytes.

The firmware module says how (``flow = "polled"``): ``free_query`` asks how many bytes of the
input buffer are free (HP-GL ``ESC.B``, answered at once), ``sync_command`` is answered only
once everything before it has run (HP-GL ``OA;``, with the pen position), ``abort_bytes``
discard the buffer (``ESC.K``). The sender never writes more than the board said is free, so
the buffer cannot overflow, whatever the wire does.

What ran: the buffer holds the bytes not yet started, so ``sent − (size − free)`` bytes have
run or are running. A stop polls once more, aborts, lifts the pen and asks the position; the
first instruction at or after that floor whose end is that position is the last one drawn, and
the job resumes after it — exactly once. If no instruction there ends where the pen is (the
plotter was power-cycled, or the link was lost mid-job and the position does not match), the
resume is refused until the user chooses ``--start-line``.

A reset the positions cannot show (the pen homed where the program would have put it, e.g. its
park at home after everything was sent) is caught by the status byte (``OS;``): its
initialised bit is read once after the plotter's power-up and after each ``IN`` has run
(clearing it), and set at the next read (a pen change, the end) means the plotter lost its place.

Pauses: the pause key stops at once as a stop does (abort, lift, locate), waits for the person
(the terminal's prompt, or the pause key again) and goes on from the very instruction; a pen the
carousel lacks (a plan with more pens than ``[paper] carousel``) waits until everything before
it has run (a sync point), puts the pen away and asks for the pen to be put in its slot.
"""

from __future__ import annotations

import threading
import time
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import serial

from pencilbot.driver import journal as journal_mod
from pencilbot.driver import stop_signals
from pencilbot.driver.hpgl.link import (
    POLL_PAUSE,
    Answers,
    Lost,
    Moved,
    Silent,
    Stopped,
    check_initialised,
    check_point,
    drain,
    poll_free,
    read_status,
)
from pencilbot.driver.hpgl.program import check_limits, seconds_after
from pencilbot.driver.hpgl.stops import (
    check_resume_position,
    hold,
    keys_say_pause,
    on_signal,
    settle,
    stop_here,
    stopped,
    wait_empty,
)
from pencilbot.driver.port import DEFAULT_TIMEOUT, open_port
from pencilbot.driver.progress import Progress
from pencilbot.driver.result import DrawResult
from pencilbot.errors import PlotError, RefusedError


def draw_polled(
    data: bytes,
    port: str,
    plotter,
    *,
    path: Path | None,
    profile_arg: str,
    baud: int | None,
    start: int = 0,
    journal=None,
    timeout: float = DEFAULT_TIMEOUT,
    progress: str = "quiet",
    announce=None,
    source: str | None = None,
    operator=None,
    keys=None,
):
    """Stream an HP-GL program to a polled-flow plotter; see the module docstring.

    Parameters
    ----------
    data : bytes
        The program (a file's bytes).
    port : str
        Device or pyserial URL.
    plotter : Profile
        The plotter (its firmware has ``flow = "polled"``).
    path : Path or None
        The file (only a file gets a journal and a resume).
    start : int
        First instruction (0-based, of :class:`~pencilbot.firmware.hpgl.Program`) to send.
    journal : Journal, optional
        The stopped job being resumed (its proven stop position is checked first).
    operator : pencilbot.driver.position.Operator, optional
        Someone at the machine: answers the pauses (the pause key, a pen change).
    keys : pencilbot.driver.keys.KeyReader, optional
        The terminal's keys: pause / resume and stop.

    Returns
    -------
    pencilbot.driver.result.DrawResult

    Raises
    ------
    PlotError
        Any fault, with the command that resumes the job.
    """

    fw = plotter.firmware
    name = source or (str(path) if path else "the program")
    try:
        program, changes = fw.program(data).in_carousel(plotter.paper.carousel)
    except ValueError as exc:  # the file, before anything is sent: bad input, not a stopped plot
        raise RefusedError(f"{name}: {exc}") from None
    if not program.frames:
        raise RefusedError(f"{name} holds no HP-GL instructions; export a drawing first (pencilbot export)")
    check_limits(program, plotter, fw, name)
    # A resume may start past the last move: everything was sent, and the stop (a plotter that
    # lost its buffer) is found on the sheet among what was sent.
    if not 0 <= start < max(len(program) + (journal is not None), 1):
        raise RefusedError(f"--start-line {start + 1} is outside {name} (moves 1..{len(program)})")
    run = PolledRun(plotter, program, changes, start, name, timeout, operator, keys)
    run.resuming = journal is not None
    baud = baud or fw.baud
    if path is not None and journal is None:
        journal = journal_mod.for_file(path, port=port, profile=profile_arg, total_lines=len(program))
    if journal is not None:
        journal.port, journal.status, journal.options = port, "running", {"baud": baud, "timeout": timeout}
        journal.save()
    run.journal = journal
    return run.draw(port, baud, profile_arg, progress, announce)


class PolledRun:
    """One run of a program on a polled plotter: what was sent, what has surely run (``floor``),
    the sync points still open, and the stop request; :meth:`draw` from the port's opening to the
    end or the stop's message."""

    def __init__(self, plotter, program, changes, start: int, name: str, timeout: float, operator, keys):
        self.plotter, self.fw, self.program, self.changes = plotter, plotter.firmware, program, changes
        self.start = self.sent = self.floor = self.proven = start
        self.name, self.timeout, self.operator, self.keys = name, timeout, operator, keys
        self.size = plotter.receive_buffer
        self.resuming = False
        self.journal = None
        self.link: Answers | None = None
        self.stop = threading.Event()
        self.why: list[str] = []
        self.base, self.sent_bytes = program.offsets[start], 0
        self.checkpoints: list[int] = []  # entries after which a sync point was sent, not yet answered
        self.in_sent = False  # an IN sent whose status byte is not read yet
        # The status byte is read after each IN has run (the preamble's, the program's): its
        # initialised bit set any other time means the plotter was reset (see check_initialised).
        self.after_in = {int(i) + 1 for i in np.flatnonzero([f.startswith(b"IN") for f in program.frames])}

    def draw(self, port: str, baud: int, profile_arg: str, progress: str, announce) -> DrawResult:
        """The run, its progress shown; a stop becomes the journal and one message."""
        program, start = self.program, self.start
        seconds = seconds_after(program, self.plotter)
        self.seconds, self.done0 = seconds, (seconds[start - 1] if start else 0.0)
        self.shown = Progress(progress, len(program) - start, float(seconds[-1] - self.done0))
        signals = ExitStack()  # closed last, in the finally: a signal during the stop is noted, not obeyed
        signals.enter_context(stop_signals.caught(on_signal(self.stop, self.why)))
        began = time.monotonic()
        finished = False
        try:
            self.link = Answers(open_port(port, baudrate=baud, profile=profile_arg), self.fw.parse_position)
            self._greet(port, baud, announce)
            self._begin()
            self._stream()
            self._finish()
            finished = True
            return DrawResult(lines_sent=len(program) - self.start, seconds=time.monotonic() - began)
        except (Stopped, Moved, Lost, Silent) as exc:
            self._stopped(exc, port)
        finally:
            if not finished:
                self.shown.close("stopped")
            signals.close()
            if self.link is not None:
                try:
                    self.link.port.close()
                except Exception:  # noqa: BLE001 - a vanished port may fail to close
                    pass
        raise AssertionError("unreachable")

    def _greet(self, port: str, baud: int, announce) -> None:
        """The plotter answers (ESC.E, OI;); a fresh job clears the initialised bit of its power-up."""
        link, fw, program, timeout = self.link, self.fw, self.program, self.timeout
        assert link is not None
        try:
            link.port.reset_input_buffer()  # nothing from before this job
        except (serial.SerialException, OSError) as exc:
            raise Lost(str(exc)) from None
        link.write(fw.wake_bytes)
        if link.wait(lambda t: t if t.strip().lstrip("-").isdigit() else None, timeout) is None:
            raise PlotError(
                f"no answer from an HP-GL plotter on {port} (ESC.E): is it on, at {baud} bit/s, "
                "on a null-modem cable?"
            )
        link.write(fw.identify_command)
        identity = link.wait(lambda t: t if fw.is_identity(t) else None, timeout)
        link.positions.clear()
        if not self.resuming and not (
            self.start == 0 and len(program) and program.frames[0].startswith(b"IN")
        ):
            read_status(
                link, fw, timeout
            )  # OI answered: idle; this clears the initialised bit of its power-up
        if announce is not None:
            announce(f"banner '{identity or 'no answer to OI;'}'", (self.plotter, len(program)))

    def _begin(self) -> None:
        """A resume's pen checked (or found on the sheet with the person) and its preamble sent."""
        link, fw, program, timeout = self.link, self.fw, self.program, self.timeout
        assert link is not None
        if self.resuming:
            wait_empty(
                link, fw, self.size, timeout
            )  # a plotter plugged back in may still be drawing what it held
            lost = check_resume_position(
                link, fw, program, self.start, self.journal, timeout, self.name, self.operator is None
            )
            pen_at = None
            if lost is not None:  # someone at the plotter shows where the drawing on the sheet ends
                from pencilbot.driver.hpgl.refind import refind

                self.start, pen_at = refind(
                    link, fw, program, self.journal, self.operator, self.plotter, timeout, lost
                )
                self.sent = self.floor = self.start
            link.write(program.preamble(self.start, pen_at))
        elif self.start > 0:
            link.write(program.preamble(self.start))
        self.in_sent = self.resuming or self.start > 0
        if self.in_sent:
            self.after_in.add(self.start)
        self.base, self.sent_bytes = program.offsets[self.start], 0
        self.floor = self.proven = self.start  # proven: entries before it ran, by a sync point's answer
        self.paused_at = -1  # the pen change answered (not asked again)
        self.pending = sorted(self.changes)
        self.last_save = 0.0

    def _stream(self) -> None:
        """Send what the buffer has room for, with the status reads, pauses and pen changes between."""
        while self.sent < len(self.program):
            if (
                self.in_sent and self.sent in self.after_in
            ):  # before a stop: a resume finds the bit clear unless reset
                self._read_status_after_in()
            elif self.stop.is_set():
                raise Stopped()
            elif self.keys is not None and keys_say_pause(self.keys, self.stop, self.why):
                self._pause_here()
            elif self.sent in self.changes and self.paused_at != self.sent:
                self._change_pen()
            else:
                self._send_what_fits()

    def _read_status_after_in(self) -> None:
        link = self.link
        assert link is not None
        settle(
            link, self.fw, self.program, self.checkpoints, self.sent, self.floor, self.timeout, self.in_sent
        )
        read_status(link, self.fw, self.timeout)  # set by the IN: cleared
        self.in_sent, self.floor = False, self.sent

    def _pause_here(self) -> None:
        """The pause key: stop at once, wait for the person, go on from the very instruction."""
        at = self._stop_here()
        if at is None:
            raise Moved("after the pause key the pen stood on none of the instructions sent")
        hold(self.operator, self.keys, self.stop, self.why, self.shown, "paused: the pause key")
        self.sent = self.floor = at
        self.base, self.sent_bytes = self.program.offsets[at], 0
        self.checkpoints.clear()

    def _change_pen(self) -> None:
        """A pen the carousel lacks: everything before it run, the pen put away, the person asked."""
        link, fw, sent = self.link, self.fw, self.sent
        assert link is not None
        if self.sent_bytes:
            drain(link, fw, self.program, self.checkpoints, sent, self.floor, self.timeout, self.in_sent)
        else:  # nothing of the program sent since the resume's preamble (pen up): it ran
            link.write(fw.sync_command)
            if link.position(fw, self.timeout) is None:
                raise Silent()
        check_initialised(link, fw, self.timeout, sent, self.in_sent)
        self.in_sent, self.floor = False, sent
        link.write(fw.park_command)  # the pen back in the carousel: its slot can be filled
        if self.operator is None and self.keys is None:
            self.why.append(f"a pen change ({self.changes[sent]}) with nobody at the terminal to do it")
            raise Stopped()
        hold(self.operator, self.keys, self.stop, self.why, self.shown, f"paused: {self.changes[sent]}")
        self.paused_at = sent

    def _send_what_fits(self) -> None:
        """Poll the free bytes, move the floor, send the instructions that fit (a sync point now
        and then), check the answered ones, show progress and keep the journal."""
        link, fw, program, sent = self.link, self.fw, self.program, self.sent
        assert link is not None
        free = poll_free(link, fw, self.timeout)
        used = self.size - free
        # Bytes of the program not started yet: the buffer's, less the sync points still in it.
        waiting = used - len(fw.sync_command) * len(self.checkpoints)
        self.floor = max(
            self.floor,
            int(np.searchsorted(program.offsets, self.base + self.sent_bytes - waiting, side="right")) - 1,
        )
        if self.checkpoints and not link.positions and self.floor > self.checkpoints[0] + 1:
            self.checkpoints.pop(0)  # it ran and its answer came before this one's: lost on the line
        room = max(free - fw.reserve(self.size), 0) if not link.xoff else 0  # never to the brim
        end = int(np.searchsorted(program.offsets, program.offsets[sent] + room, side="right")) - 1
        later = list(self.pending[int(np.searchsorted(self.pending, sent, side="right")) :][:1])
        later += [k for k in self.after_in if k > sent]
        end = min([end, *later])  # a pen change waits for everything before it; the status, for an IN
        if end <= sent:
            time.sleep(POLL_PAUSE)
            return
        chunk = b"".join(program.frames[sent:end])
        self.sent_bytes += len(chunk)
        if (
            not self.checkpoints
            and end < len(program)
            and end not in self.after_in
            and len(chunk) + len(fw.sync_command) <= room
        ):
            # A sync point now and then: its answer must be where the program put the pen,
            # or the plotter lost it (a power cycle clears the buffer and homes the pen).
            chunk += fw.sync_command
            self.checkpoints.append(end)
        link.write(chunk)
        self.in_sent = self.in_sent or any(k in self.after_in for k in range(sent + 1, end + 1))
        self.sent = end
        while link.positions and self.checkpoints:
            self.proven = check_point(link.positions.pop(0), program, self.checkpoints)
        if self.floor > self.start:
            self.shown.update(
                self.floor - self.start, float(self.seconds[self.floor - 1] - self.done0), "Run"
            )
        journal = self.journal
        if journal is not None and time.monotonic() - self.last_save > 0.2:
            journal.next_line, journal.sent_line, journal.acked_line = end + 1, end, self.floor
            journal.save()
            self.last_save = time.monotonic()

    def _finish(self) -> None:
        """Everything sent: drained, the status byte read, the journal gone."""
        link, fw, program = self.link, self.fw, self.program
        assert link is not None
        drain(
            link,
            fw,
            program,
            self.checkpoints,
            len(program),
            self.floor,
            self.timeout,
            self.in_sent,
            self.stop,
        )
        # A reset after everything was sent leaves the pen at home, pen up: where many programs end.
        check_initialised(link, fw, self.timeout, len(program), self.in_sent)
        if self.journal is not None and self.journal.path is not None:
            self.journal.path.unlink(missing_ok=True)
        self.shown.update(len(program) - self.start, float(self.seconds[-1] - self.done0), "Idle", force=True)
        self.shown.close("done")

    def _stop_here(self) -> int | None:
        assert self.link is not None
        return stop_here(
            self.link, self.fw, self.program, self.size, self.base, self.sent_bytes, self.floor,
            self.start, self.sent, self.timeout,
        )  # fmt: skip

    def _stopped(self, exc: Exception, port: str) -> None:
        """The stop's journal and message: where it stopped, proven or not."""
        journal, name, program, floor, sent = self.journal, self.name, self.program, self.floor, self.sent
        if isinstance(exc, Stopped):
            at = self._stop_here()
            why = f"stopped by {self.why[0] if self.why else 'the operator'}"
            stopped(journal, at, port, why, name, program, proven=at is not None, floor=floor)
        if isinstance(exc, Moved):
            assert self.link is not None  # Moved comes from reading the plotter
            try:
                self.link.write(
                    self.fw.abort_bytes + self.fw.lift_command
                )  # draw nothing more where the pen is not
            except Lost:
                pass
            # What ran after the last sync point the plotter answered right is not known: its buffer went.
            stopped(
                journal,
                None,
                port,
                str(exc),
                name,
                program,
                proven=False,
                floor=self.proven,
                sent=sent,
                lost=True,
            )
        why = (
            f"the port was lost ({exc})"
            if isinstance(exc, Lost)
            else f"the plotter did not answer for {self.timeout:g} s"
        )
        stopped(journal, None, port, why, name, program, proven=False, floor=floor, sent=sent)
