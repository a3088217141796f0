"""A plot job from start to end: load, wake, (check), resume, stream, and stop cleanly on faults.

This is where a :class:`~pencilbot.driver.faults.StreamFault` becomes one plain
:class:`~pencilbot.errors.PlotError` message: what happened, at which line of the file, what the
pen is doing now, and the exact command that resumes the job.
"""

from __future__ import annotations

import shlex
import time
from dataclasses import dataclass, field
from pathlib import Path

from pencilbot.driver import journal as journal_mod
from pencilbot.driver.faults import BadLine, StreamFault, is_rejection
from pencilbot.driver.grbl_stream import GrblSession, encode_lines
from pencilbot.driver.marlin_stream import MarlinSession, check_lines
from pencilbot.driver.modal import MM_PER_INCH, ModalState, advance, clean_line, line_seconds
from pencilbot.driver.port import LineReader, PortLost, open_port
from pencilbot.driver.progress import Progress
from pencilbot.driver.resume import locate_stop, pen_model, resume_preamble
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile

JOURNAL_INTERVAL = 0.2  # s between journal writes while streaming (always written on stop)


@dataclass
class Job:
    """The lines to send, with their file line numbers, modal states and time estimates."""

    lines: list[str]
    numbers: list[int]  # 1-based file line of each job line
    states: list[ModalState]  # state after each line
    seconds: list[float]  # cumulative motion estimate after each line (s)
    source: str = "<lines>"

    def index_of(self, file_line: int) -> int:
        """Index of the first job line at or after ``file_line``."""
        for i, number in enumerate(self.numbers):
            if number >= file_line:
                return i
        return len(self.lines)


def load_job(raw_lines: list[str], profile, source: str = "<lines>") -> Job:
    """Clean the lines (comments, blanks dropped) and follow their state through the job."""
    pen = pen_model(profile)
    lines, numbers, states, seconds = [], [], [], []
    state, total = ModalState(), 0.0
    for number, raw in enumerate(raw_lines, start=1):
        line = clean_line(raw)
        if not line:
            continue
        after = advance(state, line, pen)
        total += line_seconds(state, after, line, profile.motion.travel_feed, profile.dialect)
        lines.append(line)
        numbers.append(number)
        states.append(after)
        seconds.append(total)
        state = after
    return Job(lines, numbers, states, seconds, source)


@dataclass
class DrawResult:
    """What :func:`draw` did: lines sent, rejected line numbers (``--on-error continue``), time."""

    lines_sent: int
    rejected: list[int] = field(default_factory=list)
    seconds: float = 0.0
    journal: Path | None = None


def draw(
    gcode: str | Path | list[str],
    port: str,
    *,
    profile: str | None = None,
    baud: int = 115200,
    unlock: bool = False,
    check: bool = False,
    send_and_wait: bool = False,
    on_error: str = "stop",
    start_line: int | None = None,
    resume: str | Path | None = None,
    progress: str = "quiet",
    timeout: float = 10.0,
    wake_wait: float = 2.5,
    source: str | None = None,
) -> DrawResult:
    """Stream a G-code file (or lines) to a plotter and wait until it has drawn everything.

    Parameters
    ----------
    gcode : path or list of str
        A G-code file, or its lines. Only a file gets a job journal (and ``--resume``).
    port : str
        Device or pyserial URL (``/dev/ttyUSB0``, ``COM3``, ``socket://…``, ``sim://…``).
    profile : str, optional
        Plotter profile name or TOML path (dialect, receive buffer, pen commands); by default the
        resumed job's, else ``grbl-servo-a4``.
    baud : int
        Serial speed in bit/s.
    unlock : bool
        Send ``$X`` if the board starts in alarm lock (GRBL).
    check : bool
        Run the whole job through GRBL's ``$C`` check mode first; stop if any line fails.
    send_and_wait : bool
        One line in flight at a time instead of GRBL character counting.
    on_error : {"stop", "continue"}
        On ``error:N``: stop (feed hold, pen up), or log it and go on.
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
        What fault messages call ``gcode`` when it is a list of lines (e.g. the file they were
        read from); a file is named by its path.

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
        if journal.status == "done":
            raise PlotError(
                f"the job of {gcode} finished; there is nothing to resume. To draw it again: "
                f"pencilbot draw {shlex.quote(str(gcode))} --port {shlex.quote(port)} --profile "
                f"{shlex.quote(profile or journal.profile)}"
            )
        _check_unchanged(journal, gcode)
    profile = profile or (journal.profile if journal else "grbl-servo-a4")
    prof = load_profile(profile)
    if check and not prof.firmware.capabilities.check_mode:
        raise PlotError(
            f"--check runs the file through GRBL's $C check mode, and profile {prof.name} is for "
            f"{prof.dialect}, which has none; draw without --check"
        )
    if isinstance(gcode, (str, Path)):
        path = Path(gcode)
        try:
            # Comments may hold any text; a command that is not ASCII is refused line by line below.
            raw = path.read_text(encoding="utf-8", errors="replace").splitlines()
        except FileNotFoundError:
            raise PlotError(f"G-code file {path} does not exist; give the path of a .gcode file") from None
        except OSError as exc:
            raise PlotError(f"cannot read G-code file {path} ({exc})") from None
        job = load_job(raw, prof, str(path))
        total_lines = len(raw)
    else:
        path, job, total_lines = None, load_job(list(gcode), prof, source or "<lines>"), len(gcode)
    if not job.lines:
        raise PlotError(f"{job.source} holds no G-code commands; export a drawing first (pencilbot export)")
    if any("\x00" in line for line in job.lines):
        raise PlotError(
            f"{job.source} is not G-code text (it holds NUL bytes, as binary files do); give the "
            ".gcode file that pencilbot export wrote"
        )
    try:
        encode_lines(job.lines) if prof.dialect == "grbl" else check_lines(job.lines)
    except BadLine as bad:
        raise PlotError(f"line {job.numbers[bad.index]} of {job.source}: {bad.reason}") from None

    start = 0
    if journal is not None:
        start, stop_xy = job.index_of(journal.next_line), journal.stop_xy
    elif start_line is not None:
        if not 1 <= start_line <= total_lines:
            raise PlotError(f"--start-line {start_line} is outside {job.source} (lines 1..{total_lines})")
        start = job.index_of(start_line)
    if path is not None and journal is None:
        journal = journal_mod.Journal(
            gcode=str(path.resolve()), sha256=journal_mod.file_sha256(path), port=port, profile=profile,
            total_lines=total_lines, path=journal_mod.journal_path(path),
        )
    if journal is not None:
        journal.port, journal.profile, journal.status, journal.message = port, profile, "running", ""

    runner = _Runner(job, prof, port, journal, progress, send_and_wait, on_error, unlock)
    reader = LineReader(open_port(port, baudrate=baud))
    try:
        session = (
            GrblSession(reader, budget=prof.receive_buffer, timeout=timeout)
            if prof.dialect == "grbl"
            else MarlinSession(reader, timeout=timeout)
        )
        resumed_acked = job.index_of(journal.acked_line) if resume is not None and journal.acked_line else None
        return runner.run(session, start, stop_xy, check, wake_wait, resumed_acked)
    finally:
        try:
            reader.port.close()
        except Exception:  # noqa: BLE001 - a vanished port may fail to close; nothing to do
            pass


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
    """Holds one job's running state between the session and the journal/progress."""

    def __init__(self, job, profile, port, journal, progress, send_and_wait, on_error, unlock):
        self.job, self.profile, self.port, self.journal = job, profile, port, journal
        self.pen = pen_model(profile)
        self.progress_mode = progress
        self.send_and_wait, self.on_error, self.unlock = send_and_wait, on_error, unlock
        self.acked = -1
        self._journal_at = 0.0

    def run(self, session, start, stop_xy, check, wake_wait, resumed_acked=None) -> DrawResult:
        """Stream from job line ``start``; ``resumed_acked``: last acknowledged index of a resumed job."""
        t0 = time.monotonic()
        try:
            self._prepare(session, check, wake_wait)
            if resumed_acked is not None:
                # Where the machine stands now tells what the stopped job really drew (a lost link
                # or a hung board leaves moves that were acknowledged but never run).
                here = self._job_position(session, resumed_acked)
                start, stop_xy = locate_stop(self.job.states, resumed_acked, here) or (start, stop_xy)
            if start > 0:
                state = self.job.states[start - 1]
                for line in resume_preamble(state, self.pen, stop_xy=stop_xy, decimals=self.profile.gcode.decimals):
                    self._setup_command(session, line, "restoring the job's state")
        except StreamFault as fault:
            raise PlotError(f"{fault} before the job started; nothing was drawn. Check the plotter and retry.") from None
        except PortLost as exc:
            raise PlotError(f"the serial port {self.port} vanished before the job started ({exc})") from None

        self.acked = start - 1
        done0 = self.job.seconds[start - 1] if start > 0 else 0.0
        total = self.job.seconds[-1] - done0
        self.progress = Progress(self.progress_mode, len(self.job.lines) - start, total)
        self._save_journal(force=True)

        def on_ack(index, state):
            self.acked = index
            self.progress.update(index + 1 - start, self.job.seconds[index] - done0, state)
            self._save_journal()

        try:
            rejected = session.stream(
                self.job.lines, start, on_ack, send_and_wait=self.send_and_wait, on_error=self.on_error
            )
        except StreamFault as fault:
            message = self._stop(session, fault)
            self.progress.close("stopped", message)
            raise PlotError(message) from None
        self.progress.update(len(self.job.lines) - start, total, session.state)  # drawn: now Idle
        self.progress.close("done")
        if self.journal is not None:
            self.journal.status, self.journal.next_line = "done", self.job.numbers[-1] + 1
            self.journal.stop_xy = None
            self._save_journal(force=True)
        return DrawResult(
            lines_sent=len(self.job.lines) - start,
            rejected=[self.job.numbers[i] for i in rejected],
            seconds=time.monotonic() - t0,
            journal=self.journal.path if self.journal else None,
        )

    def _prepare(self, session, check, wake_wait) -> None:
        session.wake(wake_wait)
        if not isinstance(session, GrblSession):
            return
        status = session.wait_until_still()  # a reconnected board may still be drawing
        if status.state == "Alarm":
            if not self.unlock:
                raise PlotError(
                    f"the plotter on {self.port} is in alarm lock. Make sure the pen can move freely, "
                    "then run the same command with --unlock (sends $X), or home the machine"
                )
            self._setup_command(session, "$X", "unlocking")
        elif status.state in ("Hold", "Door"):
            # A held board queues what it gets and runs none of it: the job would wait forever.
            raise PlotError(
                f"the plotter on {self.port} is paused ({status.state}: a feed hold or an open door). "
                "Close the door, or press resume (cycle start, '~') or reset on the machine, then run again"
            )
        if check:
            self._check_mode(session)

    def _setup_command(self, session, line, doing) -> None:
        reply = session.command(line)
        if is_rejection(reply):
            raise PlotError(f"the plotter refused {line!r} while {doing} ({reply}); check the profile")

    def _check_mode(self, session) -> None:
        """Run every line through ``$C`` (parse only, no motion) and refuse the job on any error."""
        self._setup_command(session, "$C", "entering check mode")
        try:
            rejected = session.stream(self.job.lines, 0, lambda i, s: None, on_error="continue")
        except StreamFault as fault:
            if fault.kind != "alarm" or fault.index >= len(self.job.lines):
                raise
            session.reset()  # soft limits still alarm in check mode, and lock until a reset
            raise PlotError(
                f"GRBL check mode ($C) stopped at line {self.job.numbers[fault.index]} of "
                f"{self.job.source} ({self.job.lines[fault.index]!r}): {fault}; nothing was drawn. "
                "Fix the G-code (pencilbot export keeps every move on the bed), then run again "
                "with --unlock"
            ) from None
        session.command("$C")  # leaving check mode soft-resets GRBL
        session.reset()
        if rejected:
            where = ", ".join(str(self.job.numbers[i]) for i in rejected[:10])
            more = f" and {len(rejected) - 10} more" if len(rejected) > 10 else ""
            raise PlotError(
                f"GRBL check mode ($C) rejected lines {where}{more} of {self.job.source}; nothing was "
                "drawn. Fix those lines (pencilbot export writes GRBL-safe G-code) and run again"
            )

    def _save_journal(self, force: bool = False) -> None:
        if self.journal is None:
            return
        now = time.monotonic()
        if not force and now - self._journal_at < JOURNAL_INTERVAL:
            return
        self._journal_at = now
        job = self.job
        if self.acked >= 0:
            self.journal.acked_line = job.numbers[self.acked]
        self.journal.next_line = job.numbers[self.acked + 1] if self.acked + 1 < len(job.lines) else job.numbers[-1] + 1
        self.journal.save()

    def _stop(self, session, fault: StreamFault) -> str:
        """Stop the machine after ``fault``, record where to resume, and say so in one message."""
        pen_note, position = self._halt_and_lift(session, fault)
        if fault.kind == "error" and self.on_error == "stop":
            # The rejected line never ran: resume no later than it (it is sent again).
            self.acked = min(self.acked, fault.index - 1)
        # Without a known position, trust the acknowledgements; a resume looks again (the
        # machine's position after reconnecting tells what a lost link or hung board ran).
        index, stop_xy = locate_stop(self.job.states, self.acked, position) or (self.acked + 1, None)
        line_no = self.job.numbers[min(fault.index, len(self.job.lines) - 1)] if fault.index >= 0 else None
        where = f"at line {line_no} of {self.job.source} ({self.job.lines[fault.index]!r})" if line_no else ""
        message = f"{fault} {where}. Stopped; {pen_note}. {self._resume_advice(index, stop_xy, fault)}"
        if fault.kind == "error" and line_no:
            # Lines without a journal have no command line to resume them: say it in plain words.
            fix = "use --start-line" if self.journal is not None else "start from it"
            message += f" (this sends line {line_no} again; if the line itself is wrong, fix it and {fix})"
        return message

    def _halt_and_lift(self, session, fault):
        """Stop the machine, read where it stands (job units) and raise the pen: (note, position)."""
        if fault.kind == "port":
            return "the pen state is unknown (no port left to raise it)", None
        try:
            at_rest = False
            if fault.kind in ("error", "interrupt", "timeout"):
                at_rest = session.halt()
            elif fault.kind == "alarm":
                session.reset()  # a limit alarm blocks all input until a reset
            status = session.query_status(wait=min(session.timeout, 3.0))
            position = self._job_position(session, self.acked)
            if status is not None and status.state == "Alarm" and at_rest:
                # Our own reset of a machine at rest: the position is exact, so the alarm
                # (GRBL's "reset with moves queued") is safe to clear to lift the pen.
                session.command("$X")
            for line in self.pen.up_lines:
                if is_rejection(session.command(line)):
                    if self.pen.kind == "spindle":
                        # The alarm switched the spindle off, and spindle off is pen up.
                        return "pen up (the alarm switched the spindle off)", position
                    return "the alarm locks G-code, so the pen could not be raised", position
            return "pen raised", position
        except (StreamFault, PortLost) as exc:
            return f"could not raise the pen ({exc})", None

    def _job_position(self, session, acked: int):
        """The machine's work position X, Y in the units the job uses at line ``acked``."""
        position = session.work_position()
        if position is not None and self.job.states[max(acked, 0)].inches:
            position = (position[0] / MM_PER_INCH, position[1] / MM_PER_INCH)
        return position

    def _resume_advice(self, index, stop_xy, fault) -> str:
        """Record where to resume in the journal and say how: the command, or the line."""
        unlock = " --unlock" if fault.kind in ("alarm", "reset") else ""
        port = shlex.quote(self.port)
        line = self.job.numbers[index] if index < len(self.job.lines) else self.job.numbers[-1] + 1
        if self.journal is None:  # lines from a program (simulate, the library): no command to give
            return f"Resume from line {line} of {self.job.source}"
        self.journal.next_line = line
        self.journal.acked_line = self.job.numbers[self.acked] if self.acked >= 0 else 0
        self.journal.stop_xy = list(stop_xy) if stop_xy is not None else None
        self.journal.status = "stopped"
        self.journal.message = str(fault)
        self.journal.save()
        return f"Resume with: pencilbot draw --resume {shlex.quote(str(self.journal.path))} --port {port}{unlock}"
