"""One G-code job's run on a board that acknowledges lines: wake, (check), resume, stream, and
stop cleanly on faults.

This is where a :class:`~pencilbot.driver.gcode.stream.StreamFault` becomes one plain
:class:`~pencilbot.errors.PlotError` message (:mod:`pencilbot.driver.messages`): what happened, at
which line of the file, what the pen is doing now, and the exact command that resumes the job.
What the board can do (check mode, unlock, feed hold, status reports) comes from its firmware's
capabilities, the same for all.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable

from pencilbot.driver import journal as journal_mod
from pencilbot.driver import position, stop_signals
from pencilbot.driver.faults import Interrupted, StreamFault
from pencilbot.driver.gcode.job import Job
from pencilbot.driver.gcode.resume import StopLocator, resume_preamble
from pencilbot.driver.gcode.resume_point import ResumePointFinder
from pencilbot.driver.gcode.stream import Stream
from pencilbot.driver.messages import stop_message
from pencilbot.driver.progress import Progress
from pencilbot.driver.result import DrawResult
from pencilbot.errors import PencilbotError, PlotError
from pencilbot.firmware.base import ERROR
from pencilbot.machine.profile import Profile

JOURNAL_INTERVAL = 0.2  # s between journal writes while streaming (always written on stop)
_PEN_CHANGE = re.compile(r"pen change:\s*insert\s+(.+)", re.IGNORECASE)
# Job lines before the last one answered among which a progress record looks for the machine: its
# last status report may be up to a poll old, and short hatch moves pass quickly.
_SHOW_WINDOW = 600


class Runner:
    """Holds one job's running state between the stream and the journal/progress."""

    def __init__(
        self,
        job: Job,
        profile: Profile,
        port,
        journal,
        progress,
        send_and_wait,
        on_error,
        unlock,
        operator=None,
        keys=None,
    ):
        self.job, self.profile, self.port, self.journal = job, profile, port, journal
        self.firmware = profile.firmware
        self.pen = profile.pen_model
        self.progress_mode = progress
        self.send_and_wait, self.on_error, self.unlock = send_and_wait, on_error, unlock
        self.operator, self.keys = operator, keys
        self._stopping = False  # in the stop sequence: a further Ctrl-C or signal waits for it
        self._count: tuple[float, float] | None = (
            None  # the board's count where it stopped (work mm), read by the stop
        )
        self.locator = StopLocator(job, profile)
        self.acked = -1
        self._journal_at = 0.0
        self.announce: Callable[[str, Job], None] | None = None
        self.on_progress: Callable[[dict], None] | None = None

    def run(self, stream: Stream, start, stop_xy, check, wake_wait, resumed=None) -> DrawResult:
        """Stream from job line ``start``; ``resumed``: the journal of a stopped job to continue."""
        t0 = time.monotonic()
        job = self.job
        start, stop_xy = self._begin(stream, start, stop_xy, check, wake_wait, resumed)
        self.acked = start - 1
        done0 = job.seconds_after(start - 1)
        total = job.seconds_after(len(job) - 1) - done0
        self.progress = Progress(self.progress_mode, len(job) - start, total, listener=self.on_progress)
        try:
            self._save_journal(force=True)
        except StreamFault as fault:  # the journal cannot be written: stop as any fault does
            self._stopping = True
            raise PlotError(self._stop(stream, fault)) from None

        def on_ack(index, state):
            self.acked = index
            if index in job.pauses and self.journal is not None:
                pen = _PEN_CHANGE.search(job.pauses[index])
                self.journal.pen = pen.group(1).strip() if pen else self.journal.pen
            self.progress.update(
                index + 1 - start, job.seconds_after(index) - done0, state, where=lambda: self._where(stream)
            )
            self._save_journal(stream)

        def on_pause(reason):
            self.progress.show_state(f"paused: {reason}")
            if self.operator is None:
                return False  # the machine's cycle-start button resumes it
            self.operator.pause(f"paused: {reason}")
            return True

        with self._stop_signals():
            try:
                rejected = stream.stream(
                    job,
                    start,
                    on_ack,
                    send_and_wait=self.send_and_wait,
                    on_error=self.on_error,
                    on_pause=on_pause,
                    keys=self.keys,
                    on_hold=lambda reason: self.progress.show_state(f"paused: {reason}"),
                )
            except StreamFault as fault:
                self._stopping = True  # from here a second Ctrl-C must not cut the stop short
                message = self._stop(stream, fault)
                self.progress.close("stopped", message)
                raise PlotError(message) from None
        self.progress.update(len(job) - start, total, stream.machine_state)  # drawn: now Idle
        self.progress.close("done")
        if self.journal is not None:
            try:
                self.journal.path.unlink(missing_ok=True)  # a finished job has nothing to resume
            except OSError:
                pass  # its folder is gone: nothing left to remove
        return DrawResult(
            lines_sent=len(job) - start,
            rejected=[job.number(i) for i in rejected],
            seconds=time.monotonic() - t0,
        )

    def _begin(self, stream: Stream, start, stop_xy, check, wake_wait, resumed):
        """Wake and check the board; a resume's point found and the job's state restored before
        it. ``(start, stop_xy)`` as the resume found them."""
        try:
            self._prepare(stream, check, wake_wait, resuming=resumed is not None)
            if resumed is not None:
                # Where the machine stands now, checked against what the stop proved, tells
                # whether its position can be trusted and what the stopped job really drew.
                start, stop_xy = ResumePointFinder(
                    self.job, self.profile, self.port, self.operator, self.locator, self._setup_command
                ).find(stream, resumed)
                resumed.message = ""
                if resumed.pen and self.operator is not None:
                    self.operator.pause(
                        f"pen change: insert {resumed.pen} (the pen the job was drawing with)"
                    )
            if start > 0:
                state = self.job.state_after(start - 1)
                decimals = max(self.profile.gcode.decimals, 4)  # a stop point is known to 1 µm
                for line in resume_preamble(
                    state, self.pen, stop_xy=stop_xy, decimals=decimals, dwell=self.firmware.dwell
                ):
                    self._setup_command(stream, line, "restoring the job's state")
        except StreamFault as fault:
            raise PlotError(
                f"{fault} before the job started; nothing was drawn. Check the plotter and retry."
            ) from None
        return start, stop_xy

    def _stop_signals(self):
        """The stop signals (:mod:`~pencilbot.driver.stop_signals`) stop the stream safely; during
        the stop they are noted, not obeyed (the stop lifts the pen and writes the resume command
        either way)."""

        def stop(by: str) -> None:
            if not self._stopping:
                self._stopping = True  # set here: a second one, however soon, finds it set
                raise Interrupted(by)

        return stop_signals.caught(stop)

    def _prepare(self, stream: Stream, check, wake_wait, resuming: bool = False) -> None:
        banner = stream.wake(wake_wait)
        if self.announce is not None:
            self.announce(banner, self.job)
        status = stream.wait_until_still()  # a reconnected board may still be drawing
        fw = self.firmware
        if status is not None and fw.is_alarm(status) and not resuming:
            # (A resume looks at an alarm itself: it may be the stop's own, or a lost position.)
            if not (self.unlock and fw.capabilities.unlock):
                raise PlotError(
                    f"the plotter on {self.port} is in alarm lock. Make sure the pen can move freely, "
                    f"then run the same command with --unlock (sends {fw.unlock_command or 'an unlock'}), "
                    "or home the machine"
                )
            self._setup_command(stream, fw.unlock_command, "unlocking")
        elif status is not None and fw.is_paused(status):
            # A held board queues what it gets and runs none of it: the job would wait forever.
            raise PlotError(
                f"the plotter on {self.port} is paused ({status.state}: a feed hold or an open door). "
                "Close the door, or press resume (cycle start, '~') or reset on the machine, then run again"
            )
        if check:
            self._check_mode(stream)

    def _setup_command(self, stream: Stream, line, doing) -> None:
        reply = stream.command(line)
        if reply.kind == ERROR:
            raise PlotError(f"the plotter refused {line!r} while {doing} ({reply.text}); check the profile")

    def _check_mode(self, stream: Stream) -> None:
        """Run every line through check mode (parse only, no motion) and refuse the job on any error."""
        job, toggle = self.job, self.firmware.check_command
        self._setup_command(stream, toggle, "entering check mode")
        try:
            rejected = stream.stream(job, 0, lambda i, s: None, on_error="continue")
        except StreamFault as fault:
            if fault.kind != "alarm" or fault.index >= len(job):
                raise
            stream.reset()  # soft limits still alarm in check mode, and lock until a reset
            raise PlotError(
                f"{self.firmware.title} check mode ({toggle}) stopped at line {job.number(fault.index)} of "
                f"{job.source} ({job.line(fault.index)!r}): {fault}; nothing was drawn. "
                "Fix the G-code (pencilbot export keeps every move on the bed), then run again "
                "with --unlock"
            ) from None
        stream.command(toggle)  # leaving check mode soft-resets GRBL
        stream.reset()
        stream.sent = -1
        if rejected:
            where = ", ".join(str(job.number(i)) for i in rejected[:10])
            more = f" and {len(rejected) - 10} more" if len(rejected) > 10 else ""
            raise PlotError(
                f"{self.firmware.title} check mode ({toggle}) rejected lines {where}{more} of {job.source}; "
                "nothing was drawn. Fix those lines (pencilbot export writes G-code the plotter takes) "
                "and run again"
            )

    def _save_journal(self, stream: Stream | None = None, force: bool = False) -> None:
        if self.journal is None:
            return
        now = time.monotonic()
        if not force and now - self._journal_at < JOURNAL_INTERVAL:
            return
        self._journal_at = now
        if self.acked >= 0:
            self.journal.acked_line = self.job.number(self.acked)
        self.journal.next_line = self.job.number(self.acked + 1)
        if stream is not None and stream.sent >= 0:
            self.journal.sent_line = self.job.number(stream.sent)
        try:
            self.journal.save()
        except (OSError, PencilbotError) as exc:
            if not self._stopping:  # (the stop saves it last, wherever it can)
                # Going on would leave no record of how far the job got: stop it now.
                raise StreamFault("journal", self.acked + 1, journal_mod.why_not(exc)) from None

    # --- stopping ------------------------------------------------------------------------------

    def _stop(self, stream: Stream, fault: StreamFault) -> str:
        """Stop the machine after ``fault``, record where to resume, and say so in one message."""
        pen_note, proven = self._halt_and_lift(stream, fault)
        if fault.kind == "unexpected":
            proven = None  # answers were counted one line off: what ran is not known from them
        job = self.job
        located = None
        if proven is not None:
            # GRBL answers a line once it is planned, and runs only planned lines: with the
            # board at rest and its answers in, nothing past the line after the last answered
            # one can have run (lines still in its receive buffer were dropped by the reset).
            last = min(stream.sent, self.acked + 1)
            pen_down = position.pen_down_in(stream.rest_status, self.pen)
            floor = self.locator.planner_floor(
                stream.rest_status, self.acked, fault.index if fault.kind == "error" else None
            )
            after = None
            if floor is None:
                # Where it was when the hold began (or at an earlier report): on from there.
                floor, after = self.locator.floor(stream, last) or (None, None)
            located = self.locator.locate(
                last,
                self.locator.job_units(proven[0], last),
                pen_down,
                floor,
                answered=self.acked,
                after=after,
            )
            if located is None:
                proven = None  # where it stands is not on the lines it had: not a stop point
        if located is not None:
            index, stop_xy = located
        else:
            # Lost: the resume re-establishes the position and finds out; the guess is the first
            # line not acknowledged (a refused line never ran).
            index = min(self.acked, fault.index - 1) + 1 if fault.kind == "error" else self.acked + 1
            stop_xy = None
        advice = self._resume_advice(stream, index, stop_xy, fault, proven)
        return stop_message(job, fault, index, pen_note, proven is not None, advice, self.journal)

    def _halt_and_lift(self, stream: Stream, fault: StreamFault):
        """Stop the machine, read where it stands and raise the pen: (note, proven), where
        ``proven`` is (work X, Y; machine X, Y) in mm when the board's count is known to be
        where the pen is, else None."""
        if fault.kind == "port":
            return "the pen state is unknown (no port left to raise it)", None
        fw = self.firmware
        try:
            at_rest = False
            if fault.kind in ("error", "interrupt", "timeout", "unexpected", "journal"):
                at_rest = stream.halt()
            elif fault.kind == "alarm":
                stream.reset()  # a limit alarm blocks all input until a reset
            status = stream.query_status(wait=min(stream.timeout, 3.0))
            alarm = status is not None and fw.is_alarm(status)
            work, mpos = stream.work_position(), stream.machine_position()
            # At rest before our reset: the count is exact. A board that reset by itself
            # (banner, no alarm) kept it if it was idle, unless it powered up counting from 0, 0.
            trusted = at_rest or (fault.kind == "reset" and not alarm and not position.near(mpos, (0.0, 0.0)))
            proven = (work, mpos) if trusted and work is not None and mpos is not None else None
            # Where the board counts the pen, proven or not; a board that restarted by itself
            # unalarmed counts from where it powered up instead.
            self._count = work if (alarm or fault.kind != "reset") else None
            if alarm and at_rest and fw.capabilities.unlock:
                # Our own reset of a machine at rest: the position is exact, so the alarm
                # (GRBL's "reset with moves queued") is safe to clear to lift the pen.
                stream.command(fw.unlock_command)
            for line in self.pen.up_lines:
                if stream.command(line).kind == ERROR:
                    if self.pen.kind == "spindle":
                        # The alarm switched the spindle off, and spindle off is pen up.
                        return "pen up (the alarm switched the spindle off)", proven
                    # (A Z pen left down has no known height to restore the origin with.)
                    return (
                        "the alarm locks G-code, so the pen could not be raised",
                        None if self.pen.kind == "z" else proven,
                    )
            # Wait until it is up: a Z pen's lift is a move, and closing the port resets an
            # Arduino board (DTR), which would cut the move short and leave the pen down.
            stream.wait_until_still()
            return "pen raised", proven
        except StreamFault as exc:
            return f"could not raise the pen ({exc})", None

    def _where(self, stream: Stream) -> dict:
        """Where the machine is while streaming: its work position and the file line it runs."""
        xy = stream.work_position()
        if xy is None:
            return {}
        # The machine runs a line at most one past the last answered (GRBL answers once planned).
        last = min(self.acked + 1, len(self.job) - 1)
        # The report may be a poll old, older than the answers since: no floor from the answered
        # dwells (answered=-1), the latest pass through the point in the window.
        found = self.locator.locate(
            last,
            self.locator.job_units(xy, last),
            position.pen_down_in(stream.status, self.pen),
            window=_SHOW_WINDOW,
            answered=-1,
        )
        where: dict[str, object] = {"xy": [round(xy[0], 3), round(xy[1], 3)]}
        if found is not None:
            where["running"] = self.job.number(found[0])
        return where

    def _resume_advice(self, stream: Stream, index, stop_xy, fault, proven) -> str:
        """Record where to resume in the journal and say how: the command, or the line."""
        line = self.job.number(index)
        if self.journal is None:  # lines from a program (simulate, the library): no command to give
            return f"Resume from line {line} of {self.job.source}"
        journal = self.journal
        journal.next_line = line
        journal.acked_line = self.job.number(self.acked) if self.acked >= 0 else 0
        journal.sent_line = self.job.number(stream.sent) if stream.sent >= 0 else 0
        journal.stop_xy = list(stop_xy) if stop_xy is not None else None
        journal.stop_work = list(proven[0]) if proven is not None else None
        journal.stop_mpos = list(proven[1]) if proven is not None else None
        journal.count_work = list(self._count) if proven is None and self._count is not None else None
        journal.status = "stopped"
        journal.message = str(fault)
        return journal_mod.save_stopped(journal)
