"""A plot job from start to end: load, wake, (check), resume, stream, and stop cleanly on faults.

This is where a :class:`~pencilbot.driver.stream.StreamFault` becomes one plain
:class:`~pencilbot.errors.PlotError` message: what happened, at which line of the file, what the
pen is doing now, and the exact command that resumes the job. What the board can do (check mode,
unlock, feed hold, status reports) comes from its firmware's capabilities, the same for all.
"""

from __future__ import annotations

import re
import shlex
import signal
import threading
import time
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from pencilbot.driver import journal as journal_mod
from pencilbot.driver import position
from pencilbot.driver.bed_check import check_on_bed, check_resumable
from pencilbot.driver.job import Job, load_job
from pencilbot.driver.port import LineReader, open_port, sim_url
from pencilbot.driver.progress import Progress
from pencilbot.driver.resume import flight_start, locate_stop, resume_preamble
from pencilbot.driver.stream import DEFAULT_TIMEOUT, Interrupted, Stream, StreamFault
from pencilbot.errors import PencilbotError, PlotError
from pencilbot.firmware.base import ERROR
from pencilbot.machine.profile import DEFAULT_PROFILE, Profile, load_profile
from pencilbot.units import MM_PER_INCH

JOURNAL_INTERVAL = 0.2  # s between journal writes while streaming (always written on stop)
_PEN_CHANGE = re.compile(r"pen change:\s*insert\s+(.+)", re.IGNORECASE)
#: A cleaned line a GRBL-protocol board answers only after every earlier move has run.
_SYNCHRONIZING = re.compile(r"^(?:N\d+)?(?:[^G]*G0*4(?![0-9.])|[^M]*M0*[01](?![0-9.]))")
#: Signals that stop a plot as safely as Ctrl-C (pen up, journal stopped, resume command).
STOP_SIGNALS = {signal.SIGINT: "Ctrl-C", signal.SIGTERM: "SIGTERM", getattr(signal, "SIGHUP", None): "SIGHUP"}
# Job lines before the last one answered among which a progress record looks for the machine: its
# last status report may be up to a poll old, and short hatch moves pass quickly.
_SHOW_WINDOW = 600


@dataclass
class DrawResult:
    """What :func:`draw` did: lines sent, rejected line numbers (``--on-error continue``), time.
    (A finished job's journal is removed: there is nothing left to resume.)"""

    lines_sent: int
    rejected: list[int] = field(default_factory=list)
    seconds: float = 0.0


def draw(
    gcode: str | Path | bytes | Sequence[str],
    port: str,
    *,
    profile: str | None = None,
    baud: int | None = None,
    unlock: bool = False,
    check: bool = False,
    send_and_wait: bool = False,
    on_error: str = "stop",
    start_line: int | None = None,
    resume: str | Path | None = None,
    progress: str = "quiet",
    timeout: float = DEFAULT_TIMEOUT,
    wake_wait: float = 2.5,
    source: str | None = None,
    announce: Callable[[str, Job], None] | None = None,
    operator=None,
    keys=None,
    on_progress: Callable[[dict], None] | None = None,
) -> DrawResult:
    """Stream a G-code file (or program, or lines) to a plotter and wait until it has drawn everything.

    Parameters
    ----------
    gcode : path, bytes or sequence of str
        A G-code file, a whole program, or its lines. Only a file gets a job journal (and
        ``--resume``).
    port : str
        Device or pyserial URL (``/dev/ttyUSB0``, ``COM3``, ``socket://…``, ``sim://…``).
    profile : str, optional
        Plotter profile name or TOML path (firmware, receive buffer, pen commands); by default the
        resumed job's, else :data:`~pencilbot.machine.profile.DEFAULT_PROFILE`.
    baud : int, optional
        Serial speed in bit/s; by default the firmware's (:attr:`Firmware.baud`).
    unlock : bool
        Leave alarm lock if the board starts in it (GRBL ``$X``).
    check : bool
        Run the whole job through the firmware's check mode first (GRBL ``$C``); stop if any line
        fails.
    send_and_wait : bool
        One line in flight at a time instead of filling the board's buffer.
    on_error : {"stop", "continue"}
        On a refused line: stop (feed hold, pen up), or log it and go on.
    start_line : int, optional
        Start from this file line (1-based), rebuilding the state of the lines before it.
    resume : path, optional
        A job journal (or its G-code file) to continue from where it stopped.
    progress : {"bar", "quiet", "json"}
        How to show progress.
    timeout : float
        Seconds of silence from the board before the job is declared stuck.
    wake_wait : float
        Seconds to wait for the start-up banner.
    source : str, optional
        What fault messages call ``gcode`` when it is not a file (e.g. the file it was read from);
        a file is named by its path.
    announce : callable, optional
        Called with the board's start-up banner and the job once the board answered, before
        anything is streamed (``draw -v`` prints them).
    operator : pencilbot.driver.position.Operator, optional
        Someone at the machine: answers program pauses and guides a re-zero when a resume finds
        the position lost. Without one, a pause waits for the machine's cycle-start button and a
        lost position is a refusal that says what to do.
    keys : pencilbot.driver.keys.KeyReader, optional
        The terminal's keys: pause / resume (feed hold, cycle start) and stop.
    on_progress : callable, optional
        ``on_progress(record)`` with each progress record (as ``progress="json"`` prints them,
        whatever ``progress`` is), a progress record also saying where the machine is:
        ``running`` the file line it is drawing (located from its reported position on the
        lines sent, as a stop is; absent when not found) and ``xy`` its work position (mm).

    Raises
    ------
    PlotError
        Any fault; the message says what happened, where, and how to resume.
    """
    stop_xy = None
    journal = None
    if resume is not None:
        journal = journal_mod.load_journal(resume)
        gcode = Path(journal.gcode)
        _check_unchanged(journal, gcode)
    profile = profile or (journal.profile if journal else DEFAULT_PROFILE)
    if Path(profile).suffix.lower() == ".toml":
        profile = str(Path(profile).resolve())  # the journal's resume works from any folder
    machine = load_profile(profile)
    fw = machine.firmware
    baud = baud or fw.baud
    if getattr(fw, "flow", "") == "polled":  # no acknowledgements (HP-GL): driver.polled
        return _draw_polled(gcode, port, machine, profile, baud, start_line, journal, timeout, progress, announce, source)
    if check and not fw.capabilities.check_mode:
        raise PlotError(
            f"--check runs the file through the board's parse-only mode (GRBL's $C check mode), and "
            f"profile {machine.name} is for {fw.title}, which has none; draw without --check"
        )
    path = Path(gcode) if isinstance(gcode, (str, Path)) else None
    job = load_job(gcode, machine, source)
    check_on_bed(job)  # before the port is opened: nothing is sent
    if journal is not None:
        journal_mod.check_against(journal, job)  # a journal is input too: its lines and stop point

    start = 0
    if journal is not None:
        start, stop_xy = job.index_of(journal.next_line), journal.stop_xy
    elif start_line is not None:
        if not 1 <= start_line <= job.total_lines:
            raise PlotError(f"--start-line {start_line} is outside {job.source} (lines 1..{job.total_lines})")
        start = job.index_of(start_line)
    check_resumable(job, start)  # a resume restores no work offset the file set up
    if path is not None and journal is None:
        journal = journal_mod.Journal(
            gcode=str(path.resolve()), sha256=journal_mod.file_sha256(path), port=port, profile=profile,
            total_lines=job.total_lines, path=journal_mod.journal_path(path),
        )
    if journal is not None:
        journal.port, journal.profile, journal.status = port, profile, "running"  # the message: once resumed
        journal.options = {**(journal.options or {}),  # (an EBB stop keeps its step counters here)
                           "baud": baud, "timeout": timeout, "send_and_wait": send_and_wait, "on_error": on_error}

    if fw.capabilities.host_motion:  # the board takes step commands: the host plans the motion
        from pencilbot.driver.ebb_plot import draw_ebb

        return draw_ebb(job, machine, sim_url(port, profile), journal, start=start, resumed=journal if resume is not None else None,
                        baud=baud, progress=progress, timeout=timeout, operator=operator, keys=keys)
    runner = _Runner(job, machine, port, journal, progress, send_and_wait, on_error, unlock, operator, keys)
    runner.announce = announce
    runner.on_progress = on_progress
    link = LineReader(open_port(port, baudrate=baud, profile=profile))
    try:
        stream = Stream(link, fw, receive_buffer=machine.receive_buffer, timeout=timeout)
        resumed = journal if resume is not None else None
        return runner.run(stream, start, stop_xy, check, wake_wait, resumed)
    finally:
        try:
            link.port.close()
        except Exception:  # noqa: BLE001 - a vanished port may fail to close; nothing to do
            pass


def _draw_polled(gcode, port, machine, profile, baud, start_line, journal, timeout, progress, announce, source):
    """A job for a firmware that answers nothing per line: read it whole, stream it polled."""
    from pencilbot.driver.polled import draw_polled

    path = Path(gcode) if isinstance(gcode, (str, Path)) else None
    if path is not None:
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise PlotError(f"cannot read {path} ({exc.strerror or exc})") from None
    else:
        data = gcode if isinstance(gcode, bytes) else "\n".join(gcode).encode("ascii", errors="replace")
    start = journal.next_line - 1 if journal is not None else (start_line - 1 if start_line else 0)
    return draw_polled(data, port, machine, path=path, profile_arg=profile, baud=baud,
                       start=start, journal=journal, timeout=timeout, progress=progress, announce=announce,
                       source=source)


def _check_unchanged(journal, gcode: Path) -> None:
    try:
        digest = journal_mod.file_sha256(gcode)
    except OSError:
        raise PlotError(f"the job's G-code file {gcode} is gone; resume needs the same file") from None
    if digest != journal.sha256:
        raise PlotError(
            f"{gcode} changed since the job stopped, so the journal no longer matches it; check the "
            f"file and continue with: pencilbot draw {shlex.quote(str(gcode))} --port "
            f"{shlex.quote(journal.port)} --profile {shlex.quote(journal.profile)} --start-line {journal.next_line}"
        )


class _Runner:
    """Holds one job's running state between the stream and the journal/progress."""

    def __init__(self, job: Job, profile: Profile, port, journal, progress, send_and_wait, on_error, unlock,
                 operator=None, keys=None):
        self.job, self.profile, self.port, self.journal = job, profile, port, journal
        self.firmware = profile.firmware
        self.pen = profile.pen_model
        self.progress_mode = progress
        self.send_and_wait, self.on_error, self.unlock = send_and_wait, on_error, unlock
        self.operator, self.keys = operator, keys
        self._stopping = False  # in the stop sequence: a further Ctrl-C or signal waits for it
        self._count = None  # the board's count where it stopped (work mm), read by the stop
        self._mark = None  # the mark of a hand re-zero
        self.acked = -1
        self._journal_at = 0.0
        self.announce = None
        self.on_progress = None

    def run(self, stream: Stream, start, stop_xy, check, wake_wait, resumed=None) -> DrawResult:
        """Stream from job line ``start``; ``resumed``: the journal of a stopped job to continue."""
        t0 = time.monotonic()
        job = self.job
        try:
            self._prepare(stream, check, wake_wait, resuming=resumed is not None)
            if resumed is not None:
                # Where the machine stands now, checked against what the stop proved, tells
                # whether its position can be trusted and what the stopped job really drew.
                start, stop_xy = self._resume_point(stream, resumed)
                resumed.message = ""
                if resumed.pen and self.operator is not None:
                    self.operator.pause(f"pen change: insert {resumed.pen} (the pen the job was drawing with)")
            if start > 0:
                state = job.state_after(start - 1)
                decimals = max(self.profile.gcode.decimals, 4)  # a stop point is known to 1 µm
                for line in resume_preamble(state, self.pen, stop_xy=stop_xy, decimals=decimals,
                                            dwell=self.firmware.dwell):
                    self._setup_command(stream, line, "restoring the job's state")
        except StreamFault as fault:
            raise PlotError(f"{fault} before the job started; nothing was drawn. Check the plotter and retry.") from None

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
            self.progress.update(index + 1 - start, job.seconds_after(index) - done0, state,
                                 where=lambda: self._where(stream))
            self._save_journal(stream)

        def on_pause(reason):
            self.progress.show_state(f"paused: {reason}")
            if self.operator is None:
                return False  # the machine's cycle-start button resumes it
            self.operator.pause(f"paused: {reason}")
            return True

        with self._stop_signals():
            try:
                rejected = stream.stream(job, start, on_ack, send_and_wait=self.send_and_wait,
                                         on_error=self.on_error, on_pause=on_pause, keys=self.keys,
                                         on_hold=lambda reason: self.progress.show_state(f"paused: {reason}"))
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

    @contextmanager
    def _stop_signals(self):
        """Ctrl-C, SIGTERM and SIGHUP stop the stream safely; during the stop they are noted,
        not obeyed (the stop lifts the pen and writes the resume command either way)."""
        if threading.current_thread() is not threading.main_thread():
            yield  # only the main thread can have signal handlers (a library call elsewhere)
            return

        def stop(signum, frame):
            if not self._stopping:
                self._stopping = True  # set here: a second one, however soon, finds it set
                raise Interrupted(STOP_SIGNALS[signum])

        saved = {}
        for signum in STOP_SIGNALS:
            if signum is not None:
                saved[signum] = signal.signal(signum, stop)
        try:
            yield
        finally:
            for signum, handler in saved.items():
                signal.signal(signum, handler)

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

    # --- where to resume -----------------------------------------------------------------------

    def _resume_point(self, stream: Stream, journal) -> tuple[int, tuple[float, float] | None]:
        """The first line to send and the stop point, once the board's position is trusted."""
        fw, job = self.firmware, self.job
        status = stream.status
        alarm = status is not None and fw.is_alarm(status)
        mpos = stream.machine_position()
        restarted_at_zero = stream.restarted and position.near(mpos, (0.0, 0.0))
        recorded = job.index_of(journal.next_line), (tuple(journal.stop_xy) if journal.stop_xy else None)
        if not fw.capabilities.status_reports:
            # A board that cannot say where it is (Marlin) leaves only the acknowledgements: it
            # runs every move it acknowledged (it has no feed hold), so the first unanswered is next.
            return recorded
        sent = job.index_of(journal.sent_line) if journal.sent_line else recorded[0] - 1
        if journal.stop_work is not None:  # the stop proved where the pen stood
            if not alarm and position.near(mpos, journal.stop_mpos):
                return recorded
            if not alarm and restarted_at_zero:
                # The board restarted (DTR reset on open, power cut) and counts from 0, 0 where
                # the pen stood: that spot is the proven stop point.
                x, y = journal.stop_work
                # A Z pen's count restarted too; the stop raised it to its up height.
                z = f"Z{self.pen.up:.4f}" if self.pen.kind == "z" else ""
                self._setup_command(stream, f"G10L20P0X{x:.4f}Y{y:.4f}{z}", "restoring the origin at the stop point")
                return recorded
            if alarm and self.profile.bed.homing:
                self._setup_command(stream, "$H", "homing")
                return recorded
            why = ("the plotter is in alarm" if alarm else
                   f"the plotter reports X{mpos[0]:.3f} Y{mpos[1]:.3f}, not where the job stopped" if mpos else
                   "the plotter does not report its position")
            here = self._reestablish(stream, why, alarm, recorded[0], journal)
            self._origin_from_stop(stream, here, tuple(journal.stop_work))
            return recorded
        if mpos is not None and not alarm and not restarted_at_zero:
            # The stop could not read the position; a board that kept its count tells it now.
            acked = job.index_of(journal.acked_line) if journal.acked_line else -1
            located = self._locate(sent, self._job_units(stream.work_position(), sent), answered=acked)
            if located is not None:
                return located
        why = f"the job stopped where the plotter could not prove its position ({journal.message or 'unknown'})"
        acked = job.index_of(journal.acked_line) if journal.acked_line else -1
        here = self._reestablish(stream, why, alarm, self._flight_start(max(sent, acked)), journal)
        tolerance = self._rezero_tolerance()
        count = tuple(journal.count_work) if journal.count_work else None
        located = None
        if position.near(here, count, tolerance):
            # The hand agrees with the board's count at the stop: its motors did not slip, and
            # the count is exact where a hand is only as good as its finest step.
            located = self._locate(sent, self._job_units(count, sent), answered=acked)
        if located is None:
            # Found by the hand, after a carriage that may have run on past a move's end.
            located = self._locate(sent, self._job_units(here, sent), answered=acked, tolerance=tolerance,
                                   coast=position.coast_limit(self.profile.motion))
        if located is None:
            raise PlotError(
                f"after the re-zero, the pen had stopped at X{here[0]:.3f} Y{here[1]:.3f}, which is not on the "
                f"last lines the plotter was sent (file lines {job.number(self._flight_start(sent))}-"
                f"{job.number(sent)}); the origin is set again, so continue from the line you see drawn last "
                f"with: pencilbot draw {shlex.quote(str(journal.gcode))} --port {shlex.quote(self.port)} "
                "--start-line N"
            )
        index, stop_xy = located
        on_path = stop_xy if stop_xy is not None else (job.state_after(index - 1).x, job.state_after(index - 1).y)
        to_mm = MM_PER_INCH if job.state_after(max(index - 1, 0)).inches else 1.0
        self._origin_from_stop(stream, here, (on_path[0] * to_mm, on_path[1] * to_mm))
        return located

    def _rezero_tolerance(self) -> float:
        """How close to the stop a re-zero by this operator puts it (its finest jog step)."""
        return position.rezero_tolerance(step=getattr(self.operator, "jog_step", position.FINE_JOG_STEP))

    def _origin_from_stop(self, stream: Stream, here, stop) -> None:
        """After a hand re-zero that put the stop at ``here`` (work mm): if the stop point on the
        job's path (``stop``, mm: proven by the board, or the move the hand's point lies on) is
        within the hand's tolerance of it, it is the better of the two (a vertex exactly, a
        move across its width), so the origin is set again from it and the jog."""
        if not position.near(here, stop, self._rezero_tolerance()) or self._mark is None:
            return
        mark = self._mark.xy
        x, y = stop[0] + mark[0] - here[0], stop[1] + mark[1] - here[1]
        self._setup_command(stream, f"G10L20P0X{x:.4f}Y{y:.4f}", "setting the origin from the stop point")

    def _reestablish(self, stream: Stream, why: str, alarm: bool, certain: int, journal) -> tuple[float, float]:
        """Re-zero with the user (or refuse without one); where the pen stood, work mm."""
        to_mm = MM_PER_INCH if self.job.state_after(max(certain - 1, 0)).inches else 1.0
        mark = position.mark_before(self.job, certain, to_mm)
        if self.pen.kind == "z":
            # Its height is lost with the count: raising it by a number could plunge it.
            raise PlotError(
                f"{why}: the plotter's position cannot be trusted, and with a Z pen its height is lost too. "
                f"Raise the pen, home the machine or set its origin by hand at {mark.text} (with Z at the "
                "pen's up height), then continue with --start-line N from the line you see drawn last"
            )
        if self.operator is None or not self.firmware.capabilities.realtime_protocol:
            raise position.refusal(why, mark, self._resume_command(), self.profile.bed.homing)
        self._mark = mark
        return position.jog_to_mark(stream, self.profile, self.operator, mark, why, alarm)

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
            floor = self._planner_floor(stream.rest_status, fault.index if fault.kind == "error" else None)
            floor = self._floor(stream, last) if floor is None else floor
            located = self._locate(last, self._job_units(proven[0], last), pen_down, floor, answered=self.acked)
            if located is None:
                proven = None  # where it stands is not on the lines it had: not a stop point
        if located is not None:
            index, stop_xy = located
        else:
            # Lost: the resume re-establishes the position and finds out; the guess is the first
            # line not acknowledged (a refused line never ran).
            index = min(self.acked, fault.index - 1) + 1 if fault.kind == "error" else self.acked + 1
            stop_xy = None
        line_no = job.number(min(fault.index, len(job) - 1)) if fault.index >= 0 else None
        where = f"at line {line_no} of {job.source} ({job.line(min(fault.index, len(job) - 1))!r})" if line_no else ""
        lost = "" if proven is not None else (
            " The plotter cannot prove where the pen stopped, so the resume re-establishes its position first.")
        message = f"{fault} {where}. Stopped; {pen_note}.{lost} {self._resume_advice(stream, index, stop_xy, fault, proven)}"
        if fault.kind == "error" and line_no:
            if index > fault.index:
                message += (f" (line {line_no} never ran; the lines the plotter had already taken after it did, "
                            "so the resume continues after them)")
            else:
                # Lines without a journal have no command line to resume them: say it in plain words.
                fix = "use --start-line" if self.journal is not None else "start from it"
                message += f" (this sends line {line_no} again; if the line itself is wrong, fix it and {fix})"
        return message

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
            trusted = (at_rest or (fault.kind == "reset" and not alarm and not position.near(mpos, (0.0, 0.0))))
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
                    return ("the alarm locks G-code, so the pen could not be raised",
                            None if self.pen.kind == "z" else proven)
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
        found = self._locate(last, self._job_units(xy, last), position.pen_down_in(stream.status, self.pen),
                             window=_SHOW_WINDOW, answered=-1)
        where = {"xy": [round(xy[0], 3), round(xy[1], 3)]}
        if found is not None:
            where["running"] = self.job.number(found[0])
        return where

    def _job_units(self, xy, index: int):
        """A work position X, Y (mm) in the units the job uses at line ``index``."""
        if xy is not None and self.job.state_after(max(index, 0)).inches:
            return xy[0] / MM_PER_INCH, xy[1] / MM_PER_INCH
        return xy

    def _locate(self, last: int, position_xy, pen_down: bool | None = None, floor: int | None = None,
                answered: int | None = None, window: int | None = None, **how):
        """:func:`~pencilbot.driver.resume.locate_stop` over the lines up to ``last`` (sent) that
        can have been in flight, or the ``window`` lines before it (``how``: its tolerance and
        coast)."""
        if position_xy is None or last < 0:
            return None
        last = min(last, len(self.job) - 1)
        first = self._flight_start(last) if window is None else max(last - window, 0)
        # GRBL answers a dwell (or a program pause) only once every move before it has run:
        # from the last one answered, the machine runs lines in order, so the first pass
        # through the position after it is where it stood (a stroke that runs back over
        # itself passes a point twice; strokes drawn before the dwell are finished).
        sync = self._synchronized(min(last - 1 if answered is None else answered, last), first)
        if sync is not None:
            floor = max(floor if floor is not None else sync, sync)
        # The state before the window's first line too: its move starts there.
        return locate_stop(self.job.states(max(first - 1, 0), last + 1), last, position_xy,
                           window=last - first + 1, pen_down=pen_down, floor=floor, **how)

    def _synchronized(self, answered: int, first: int) -> int | None:
        """The last line at or before ``answered`` (down to ``first``) that the firmware answers
        only after all motion before it ran: a dwell or a program pause."""
        for i in range(answered, max(first, 0) - 1, -1):
            if _SYNCHRONIZING.match(self.job.line(i)):
                return i
        return None

    def _flight_start(self, last: int) -> int:
        """The earliest line the machine can have been running with lines up to ``last`` sent:
        what the board's receive buffer and planner hold (its firmware's figures)."""
        return flight_start(self.job, min(last, len(self.job) - 1), self.profile.receive_buffer,
                            self.firmware.moves_in_flight())

    def _planner_floor(self, status, refused: int | None = None) -> int | None:
        """The line the machine was running when it came to rest, from the planner count of the
        status report (GRBL's ``Bf:``, reported when ``$10`` asks for it): the blocks still
        planned are the moves of the last lines answered, one block per move (a ``refused``
        line planned none)."""
        if status is None or status.buffer is None or self.acked < 0:
            return None
        queued = self.firmware.planner_blocks - status.buffer[0]
        if queued <= 0:
            return None
        first = max(self._flight_start(self.acked) - 1, 0)
        states = self.job.states(first, self.acked + 1)
        moves = 0
        for i in range(self.acked, first, -1):
            state, before = states[i], states[i - 1]
            if i != refused and (state.x, state.y, state.z) != (before.x, before.y, before.z):
                moves += 1
                if moves == queued:
                    return i
        return None

    def _floor(self, stream: Stream, last: int) -> int | None:
        """The line the machine was running at the last status report of the stream (it can
        only have moved on from there), if that report's position is on the lines sent."""
        if stream.seen is None:
            return None
        xy, status, answered = stream.seen
        bound = min(last, answered + 1)  # then, too, it ran only lines it had answered
        found = self._locate(bound, self._job_units(xy, bound), position.pen_down_in(status, self.pen),
                             answered=answered)
        return None if found is None else found[0] - (found[1] is None and found[0] > 0)

    def _resume_command(self) -> str:
        if self.journal is None:
            return f"resume from the line named above ({self.job.source} has no journal)"
        return journal_mod.resume_command(self.journal)

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
