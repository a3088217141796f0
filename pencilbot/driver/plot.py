"""A plot job from start to end: :func:`draw` reads the options, the profile and the journal,
checks the job, and hands it to the driver its firmware needs: a board that acknowledges lines
to :class:`~pencilbot.driver.gcode.runner.Runner`, one that takes step commands to
:mod:`~pencilbot.driver.ebb.plot`, one that answers nothing per line to
:mod:`~pencilbot.driver.hpgl.plot`.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from pencilbot.driver import journal as journal_mod
from pencilbot.driver.gcode.bed_check import check_on_bed, check_resumable
from pencilbot.driver.gcode.job import Job, check_journal, load_job
from pencilbot.driver.gcode.runner import Runner
from pencilbot.driver.gcode.stream import Stream
from pencilbot.driver.messages import check_unchanged
from pencilbot.driver.port import DEFAULT_TIMEOUT, LineReader, open_port, sim_url
from pencilbot.driver.result import DrawResult
from pencilbot.errors import RefusedError
from pencilbot.fileio import read_bounded
from pencilbot.firmware.hpgl import MAX_HPGL_FILE
from pencilbot.machine.profile import DEFAULT_PROFILE, Profile, load_profile
from pencilbot.machine.profile_edit import profile_with


@dataclass(frozen=True)
class DrawOptions:
    """How a job is drawn: everything :func:`draw` takes besides the program and the port.

    One value a script builds once and hands to every job (``draw(path, port, options)``), reads
    back, or varies with :func:`dataclasses.replace`; ``draw(path, port, profile=…, …)`` takes the
    same fields as keywords.

    Attributes
    ----------
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
        What fault messages call the program when it is not a file (e.g. the file it was read
        from); a file is named by its path.
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
    overrides : dict, optional
        Profile values for this run only, by table (``{"motion": {"draw_feed": 2000}}``, as
        :func:`~pencilbot.machine.profile_edit.profile_with` takes them); a resume runs with the
        stopped job's.
    allow_system : frozenset of str
        System commands (``$`` lines: ``$H``, ``$C``, ``$100``…) the file may send; any other is
        refused by line before the port is opened (:mod:`pencilbot.driver.gcode.system_lines`).
    """

    profile: str | None = None
    baud: int | None = None
    unlock: bool = False
    check: bool = False
    send_and_wait: bool = False
    on_error: str = "stop"
    start_line: int | None = None
    resume: str | Path | None = None
    progress: str = "quiet"
    timeout: float = DEFAULT_TIMEOUT
    wake_wait: float = 2.5
    source: str | None = None
    announce: Callable[[str, Job], None] | None = None
    operator: Any = None
    keys: Any = None
    on_progress: Callable[[dict], None] | None = None
    overrides: dict[str, dict[str, float]] | None = None
    allow_system: frozenset[str] = frozenset()


def draw(
    gcode: str | Path | bytes | Sequence[str], port: str, options: DrawOptions | None = None, **fields: Any
) -> DrawResult:
    """Stream a G-code file (or program, or lines) to a plotter and wait until it has drawn everything.

    Parameters
    ----------
    gcode : path, bytes or sequence of str
        A G-code file, a whole program, or its lines. Only a file gets a job journal (and
        ``--resume``).
    port : str
        Device or pyserial URL (``/dev/ttyUSB0``, ``COM3``, ``socket://…``, ``sim://…``).
    options : DrawOptions, optional
        How to draw it; default :class:`DrawOptions`'s defaults.
    **fields
        Any of :class:`DrawOptions`'s fields, over ``options`` (``draw(path, port, profile="x")``).

    Raises
    ------
    PlotError
        Any fault; the message says what happened, where, and how to resume.
    """
    o = replace(options or DrawOptions(), **fields)
    journal = journal_mod.load_journal(o.resume) if o.resume is not None else None
    if journal is not None:
        gcode = Path(journal.gcode)
        check_unchanged(journal, gcode)
    profile, plotter, overrides = _plotter(o.profile, journal, o.overrides)
    o = replace(o, overrides=overrides)
    run = _Run(port, plotter, profile, o.baud or plotter.firmware.baud, journal)
    if plotter.firmware.flow == "polled":  # no acknowledgements (HP-GL): driver.hpgl
        return _draw_polled(gcode, run, o)
    return _draw_acknowledged(gcode, run, o)


@dataclass(frozen=True)
class _Run:
    """What :func:`draw` resolved: the port, the profile (with this run's overrides), its name
    or resolved path, the line speed, the resumed job's journal."""

    port: str
    plotter: Profile
    profile: str
    baud: int
    journal: Any


# draw's own signature names every option (DrawOptions's fields, said once there), for help(),
# inspect and editors: draw(path, port, on_error="continue") reads as a typed keyword.
_PLAIN = list(inspect.signature(draw).parameters.values())[:3]
draw.__signature__ = inspect.signature(draw).replace(  # type: ignore[attr-defined]
    parameters=[
        *_PLAIN,
        *(
            inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, default=f.default, annotation=f.type)
            for f in fields(DrawOptions)
        ),
    ]
)


def _draw_acknowledged(gcode, run: _Run, o: DrawOptions) -> DrawResult:
    """A job for a board that acknowledges each line (G-code) or takes step commands (EBB):
    checked whole before the port is opened, journalled, run by the family's driver."""
    port, plotter, journal = run.port, run.plotter, run.journal
    fw = plotter.firmware
    if o.check and not fw.capabilities.check_mode:
        raise RefusedError(
            f"--check runs the file through the board's parse-only mode (GRBL's $C check mode), and "
            f"profile {plotter.name} is for {fw.title}, which has none; draw without --check"
        )
    job = load_job(gcode, plotter, o.source, allow=o.allow_system)
    check_on_bed(job)  # before the port is opened: nothing is sent
    if journal is not None:
        check_journal(journal, job)  # a journal is input too: its lines and stop point
    start, stop_xy = _start(job, journal, o.start_line)
    check_resumable(job, start)  # a resume restores no work offset the file set up
    resumed = journal if o.resume is not None else None
    path = Path(gcode) if isinstance(gcode, (str, Path)) else None
    journal = _running_journal(journal, path, job, port, run.profile)
    if journal is not None:
        journal.options = {
            **(journal.options or {}),  # (an EBB stop keeps its step counters here)
            "baud": run.baud,
            "timeout": o.timeout,
            "send_and_wait": o.send_and_wait,
            "on_error": o.on_error,
            **({"overrides": o.overrides} if o.overrides else {}),
        }
    if fw.capabilities.host_motion:  # the board takes step commands: the host plans the motion
        from pencilbot.driver.ebb.plot import draw_ebb

        return draw_ebb(
            job, plotter, sim_url(port, run.profile), journal, start=start, resumed=resumed, baud=run.baud,
            progress=o.progress, timeout=o.timeout, operator=o.operator, keys=o.keys, announce=o.announce,
        )  # fmt: skip
    runner = Runner(
        job, plotter, port, journal, o.progress, o.send_and_wait, o.on_error, o.unlock, o.operator, o.keys
    )
    runner.announce = o.announce
    runner.on_progress = o.on_progress
    link = LineReader(open_port(port, baudrate=run.baud, profile=run.profile))
    try:
        stream = Stream(link, fw, receive_buffer=plotter.receive_buffer, timeout=o.timeout)
        return runner.run(stream, start, stop_xy, o.check, o.wake_wait, resumed)
    finally:
        try:
            link.port.close()
        except Exception:  # noqa: BLE001 - a vanished port may fail to close; nothing to do
            pass


def _plotter(profile: str | None, journal, overrides):
    """The profile's name or resolved path, the profile with this run's overrides, the overrides:
    by default the resumed job's profile and overrides."""
    profile = profile or (journal.profile if journal else DEFAULT_PROFILE)
    if Path(profile).suffix.lower() == ".toml":
        profile = str(Path(profile).resolve())  # the journal's resume works from any folder
    plotter = load_profile(profile)
    if overrides is None and journal is not None:
        overrides = (journal.options or {}).get("overrides")
    if overrides:  # this run's speeds, pen heights, delays (checked as a profile file's are)
        plotter = profile_with(plotter, overrides, where="draw options")
    return profile, plotter, overrides


def _start(job: Job, journal, start_line: int | None) -> tuple[int, list[float] | None]:
    """The job index to start from, and the stop point a resume knows."""
    if journal is not None:
        return job.index_of(journal.next_line), journal.stop_xy
    if start_line is None:
        return 0, None
    if not 1 <= start_line <= job.total_lines:
        raise RefusedError(f"--start-line {start_line} is outside {job.source} (lines 1..{job.total_lines})")
    return job.index_of(start_line), None


def _running_journal(journal, path: Path | None, job: Job, port: str, profile: str):
    """The journal of this run (a file's new one, or the resumed one), marked running."""
    if path is not None and journal is None:
        journal = journal_mod.for_file(path, port=port, profile=profile, total_lines=job.total_lines)
    if journal is not None:
        journal.port, journal.profile, journal.status = port, profile, "running"  # the message: once resumed
    return journal


def _draw_polled(gcode, run: _Run, o: DrawOptions) -> DrawResult:
    """A job for a firmware that answers nothing per line: read it whole, stream it polled."""
    from pencilbot.driver.hpgl.plot import draw_polled

    path = Path(gcode) if isinstance(gcode, (str, Path)) else None
    if path is not None:
        try:
            data = read_bounded(path, "HP-GL file", MAX_HPGL_FILE)
        except OSError as exc:
            raise RefusedError(f"cannot read {path} ({exc.strerror or exc})") from None
    else:
        data = gcode if isinstance(gcode, bytes) else "\n".join(gcode).encode("ascii", errors="replace")
    journal = run.journal
    start = journal.next_line - 1 if journal is not None else (o.start_line - 1 if o.start_line else 0)
    return draw_polled(
        data,
        run.port,
        run.plotter,
        path=path,
        profile_arg=run.profile,
        baud=run.baud,
        start=start,
        journal=journal,
        timeout=o.timeout,
        progress=o.progress,
        announce=o.announce,
        source=o.source,
        operator=o.operator,
        keys=o.keys,
    )
