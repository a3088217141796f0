"""The job journal: a small JSON file that remembers how far a plot got.

It sits next to the G-code (``drawing.gcode`` → ``drawing.gcode.job.json``) or, when that folder
is not writable, in the user's state folder. Every update writes a temporary file and renames it
over the old one, so a crash or a pulled plug leaves either the old or the new journal, never half
of one. ``pencilbot draw --resume JOURNAL`` reads it back.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

from pencilbot.errors import PlotError
from pencilbot.fileio import write_atomic

SUFFIX = ".job.json"
FORMAT = 1


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
    digest = hashlib.sha256(str(gcode).encode()).hexdigest()[:16]
    return state_dir() / f"{gcode.name}-{digest}{SUFFIX}"


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
        data = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(data, dict) or data.pop("format", None) != FORMAT:
            raise ValueError("not a pencilbot job journal")
        journal = Journal(**data)
    except FileNotFoundError:
        raise PlotError(
            f"no job journal at {path}: resume needs the journal a stopped 'pencilbot draw' wrote; "
            "or give --start-line N with the G-code file"
        ) from None
    except (OSError, ValueError, TypeError) as exc:
        raise PlotError(f"job journal {path} is unreadable ({exc}); use --start-line N instead") from None
    journal.path = path
    return journal
