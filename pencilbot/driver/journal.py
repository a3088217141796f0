"""The job journal: a small JSON file that remembers how far a plot got.

It sits next to the G-code (``drawing.gcode`` → ``drawing.gcode.job.json``) or, when that folder
is not writable, in the user's state folder. Every update writes a temporary file and renames it
over the old one, so a crash or a pulled plug leaves either the old or the new journal, never half
of one. ``pencilbot draw --resume JOURNAL`` reads it back.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import shlex
from dataclasses import asdict, dataclass, field
from pathlib import Path

from pencilbot.errors import PencilbotError, PlotError, RefusedError
from pencilbot.fileio import read_bounded, write_atomic

SUFFIX = ".job.json"
FORMAT = 1
#: How far past the bed's edge (mm) a recorded stop point may lie: a carriage stopped by an
#: alarm or a reset can coast a little past a corner on the edge.
STOP_SLACK = 1.0


@dataclass
class Journal:
    """How far one job got.

    Attributes
    ----------
    gcode : str
        Absolute path of the G-code file.
    sha256 : str
        Hash of the file's bytes, so a resume refuses a file that changed since.
    port, profile : str
        Where and with which plotter profile the job ran.
    total_lines : int
        Number of lines in the file.
    acked_line : int
        File line number (1-based) of the last line the plotter acknowledged; 0 before any.
    next_line : int
        File line number to send first on resume (a guess while ``stop_work`` is None: the
        resume finds out what ran from the position it re-establishes).
    sent_line : int
        File line number of the last line written to the board (it may have run unanswered).
    stop_xy : list of float or None
        Where the pen stopped inside ``next_line``'s move (job units), if it stopped mid-move.
    stop_work, stop_mpos : list of float or None
        Where the pen stood when the job stopped, proven by the board at rest: work and machine
        position X, Y (mm). None: the position was lost (power cycle, reset or alarm in motion,
        a silent board or a lost port), and the resume must re-establish it.
    count_work : list of float or None
        Where the board counted the pen at a stop that could not prove it (a reset or alarm in
        motion): work X, Y (mm). A re-zero whose jog agrees with it takes it as exact.
    pen : str
        The pen in use: the last pen change (``M0 (pen change: insert NAME)``) the job passed.
    options : dict
        Connection options of the run (baud, timeout, send_and_wait, on_error), for the resume.
    status : {"running", "stopped"}
        (A finished job's journal is removed.)
    message : str
        The fault that stopped the job, if any.
    resume : str
        The command that resumes a stopped job (also printed, where a terminal is left).
    """

    gcode: str
    sha256: str
    port: str
    profile: str
    total_lines: int
    acked_line: int = 0
    next_line: int = 1
    sent_line: int = 0
    stop_xy: list[float] | None = None
    stop_work: list[float] | None = None
    stop_mpos: list[float] | None = None
    count_work: list[float] | None = None
    pen: str = ""
    options: dict = field(default_factory=dict)
    status: str = "running"
    message: str = ""
    resume: str = ""
    path: Path | None = field(default=None, compare=False, repr=False)

    def save(self) -> None:
        """Write the journal atomically (temporary file + rename)."""
        assert self.path is not None
        data = {k: v for k, v in asdict(self).items() if k != "path"}
        data["format"] = FORMAT
        self.path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(self.path, json.dumps(data, indent=1).encode("utf-8"))


def for_file(path: Path, *, port: str, profile: str, total_lines: int) -> Journal:
    """A new journal of the job file at ``path`` (not yet saved): its digest, where it is kept."""
    return Journal(
        gcode=str(path.resolve()),
        sha256=file_sha256(path),
        port=port,
        profile=profile,
        total_lines=total_lines,
        path=journal_path(path),
    )


def file_sha256(path: Path) -> str:
    """Hex SHA-256 of a file's bytes (read a block at a time: a big job is not held twice)."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def state_dir() -> Path:
    """The per-user folder for journals of read-only G-code (``$XDG_STATE_HOME/pencilbot/jobs``)."""
    base = os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state"
    return Path(base) / "pencilbot" / "jobs"


def journal_path(gcode: Path) -> Path:
    """Where the journal of a G-code file lives: beside it if that folder is writable."""
    gcode = Path(gcode).resolve()
    if os.access(gcode.parent, os.W_OK):
        return gcode.with_name(gcode.name + SUFFIX)
    return _in_state_dir(gcode)


def _in_state_dir(gcode: Path) -> Path:
    digest = hashlib.sha256(str(gcode).encode()).hexdigest()[:16]
    return state_dir() / f"{gcode.name}-{digest}{SUFFIX}"


def resume_command(journal: Journal) -> str:
    """The command that resumes the job ``journal`` (saved at ``journal.path``) records."""
    return f"pencilbot draw --resume {shlex.quote(str(journal.path))} --port {shlex.quote(journal.port)}"


def save_stopped(journal: Journal) -> str:
    """Save a stopped job's journal where it is, else in the user's state folder, and say how
    to resume: a job must not be lost because its folder went or its disk filled up.

    Returns
    -------
    str
        The advice: the resume command; where the journal went instead; or, written nowhere,
        everything it holds (the ``--start-line`` command, the stop point).
    """
    journal.resume = resume_command(journal)
    try:
        journal.save()
        return f"Resume with: {journal.resume}"
    except (OSError, PencilbotError) as exc:
        first = f"at {journal.path} ({why_not(exc)})"
    here, other = journal.path, _in_state_dir(Path(journal.gcode))
    if other != here:
        journal.path = other
        journal.resume = resume_command(journal)
        try:
            journal.save()
            return f"The job journal could not be written {first}, so it is at {other}. Resume with: {journal.resume}"
        except (OSError, PencilbotError) as exc:
            first += f" or at {other} ({why_not(exc)})"
            journal.path = here
    gcode, port, line = shlex.quote(journal.gcode), shlex.quote(journal.port), journal.next_line
    stop = ""
    if journal.stop_xy is not None:
        x, y = journal.stop_xy
        stop = (
            f" (the pen stopped at X{x:.4f} Y{y:.4f} inside line {line}'s move, and --start-line draws "
            "that line whole)"
        )
    journal.resume = f"pencilbot draw {gcode} --port {port} --start-line {line}"
    return (
        f"The job journal could not be written {first}; what it would hold: the job goes on at line {line} "
        f"of {journal.gcode}{stop}. Resume with: {journal.resume}"
    )


def why_not(exc: Exception) -> str:
    """What a failed write says, briefly: the system's words for an OSError."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    said = re.search(r"\(([^()]+)\)", str(exc))  # fileio's "cannot write PATH (REASON); …"
    return said.group(1) if said else str(exc)


def load_journal(path: str | Path) -> Journal:
    """Read a journal written by :meth:`Journal.save`.

    Parameters
    ----------
    path : str or Path
        The journal, or the G-code file whose journal to read.

    Raises
    ------
    PlotError
        The journal is missing or unreadable.
    """
    path = Path(path)
    if not path.name.endswith(SUFFIX):
        path = journal_path(path)
    try:
        data = json.loads(read_bounded(path, "job journal").decode("utf-8"))
        if not isinstance(data, dict) or data.pop("format", None) != FORMAT:
            raise ValueError("not a pencilbot job journal")
        journal = Journal(**data)
    except FileNotFoundError:
        raise RefusedError(
            f"no job journal at {path}: resume needs the journal a stopped 'pencilbot draw' wrote; "
            "or give --start-line N with the G-code file"
        ) from None
    except (OSError, ValueError, TypeError) as exc:
        raise RefusedError(f"job journal {path} is unreadable ({exc}); use --start-line N instead") from None
    journal.path = path
    wrong = _wrong_field(journal)
    if wrong is not None:
        raise damaged(journal, wrong)
    return journal


def damaged(journal: Journal, wrong: str) -> PlotError:
    """The one message for a journal that cannot be trusted: what is wrong and how to go on."""
    gcode = shlex.quote(journal.gcode) if isinstance(journal.gcode, str) else "FILE"
    port = shlex.quote(journal.port) if isinstance(journal.port, str) else "PORT"
    return RefusedError(
        f"job journal {journal.path} is unreadable or was edited: {wrong}; nothing was sent. Continue from "
        f"the line you see drawn last with: pencilbot draw {gcode} --port {port} --start-line N, or draw "
        f"the file again from line 1 with: pencilbot draw {gcode} --port {port} --restart"
    )


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_point(value) -> bool:
    return (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    )


def _wrong_field(journal: Journal) -> str | None:
    """What is wrong with a journal's fields, read as user input (None: nothing)."""
    for name in ("gcode", "sha256", "port", "profile", "pen", "status", "message", "resume"):
        if not isinstance(getattr(journal, name), str):
            return f"{name} is {getattr(journal, name)!r}, not text"
    if journal.status not in ("running", "stopped"):
        return f"status is {journal.status!r}, not 'running' or 'stopped'"
    for name, least in (("total_lines", 1), ("next_line", 1), ("acked_line", 0), ("sent_line", 0)):
        value = getattr(journal, name)
        if not _is_int(value) or value < least:
            return f"{name} is {value!r}, not a whole number of at least {least}"
    if journal.next_line > journal.total_lines + 1:
        return f"next_line {journal.next_line} is past the file's {journal.total_lines} lines"
    for name in ("acked_line", "sent_line"):
        if getattr(journal, name) > journal.total_lines:
            return f"{name} {getattr(journal, name)} is past the file's {journal.total_lines} lines"
    for name in ("stop_xy", "stop_work", "stop_mpos"):
        value = getattr(journal, name)
        if value is not None and not _is_point(value):
            return f"{name} is {value!r}, not two finite numbers (X, Y)"
    if (journal.stop_work is None) != (journal.stop_mpos is None):
        return "stop_work and stop_mpos go together, and only one is set"
    options = journal.options
    if not isinstance(options, dict):
        return f"options is {options!r}, not a table"
    checks = {
        "baud": lambda v: _is_int(v) and v > 0,
        "timeout": lambda v: (
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0
        ),
        "send_and_wait": lambda v: isinstance(v, bool),
        "on_error": lambda v: v in ("stop", "continue"),
        # an EBB stop: step positions (and file lines) of where it may stand and what was in flight
        "ebb_resume": lambda v: _int_rows(v, 3),
        "ebb_moves": lambda v: _int_rows(v, 5),
        "ebb_origin": lambda v: _int_rows([v], 2),
    }
    for name, ok in checks.items():
        if name in options and not ok(options[name]):
            return f"options.{name} is {options[name]!r}"
    return None


def _int_rows(value, width: int) -> bool:
    """A list of lists of ``width`` whole numbers."""
    return isinstance(value, list) and all(
        isinstance(row, list) and len(row) == width and all(map(_is_int, row)) for row in value
    )
