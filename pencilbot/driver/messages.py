"""What a plot says when it stops or cannot go on: one plain message with the way to resume.

A :class:`~pencilbot.driver.gcode.stream.StreamFault` becomes one message here: what happened, at
which line of the file, what the pen is doing now, and the command (or the line) that resumes
the job.
"""

from __future__ import annotations

import shlex
from pathlib import Path

from pencilbot.driver import journal as journal_mod
from pencilbot.errors import PlotError


def check_unchanged(journal, gcode: Path) -> None:
    """Refuse to resume ``journal`` if its G-code file ``gcode`` is gone or changed since the stop."""
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


def resume_command(job, journal) -> str:
    """The command that resumes ``job`` from its ``journal``, or words for a job without one."""
    if journal is None:
        return f"resume from the line named above ({job.source} has no journal)"
    return journal_mod.resume_command(journal)


def stop_message(job, fault, index: int, pen_note: str, proven: bool, advice: str, journal) -> str:
    """The one message of a stopped plot.

    Parameters
    ----------
    job : Job
        The job that stopped.
    fault : StreamFault
        What stopped it, and at which job line (0-based index; −1: none).
    index : int
        The job line the resume starts from.
    pen_note : str
        What the stop did with the pen ("pen raised", …).
    proven : bool
        Whether the board proved where the pen stopped.
    advice : str
        How to resume: the command, or the line.
    journal : Journal or None
        The job's journal; without one there is no command line to resume it.

    Returns
    -------
    str
        What happened where, the pen, and how to resume; for a refused line, whether the resume
        sends it again.
    """
    line_no = job.number(min(fault.index, len(job) - 1)) if fault.index >= 0 else None
    where = (
        f"at line {line_no} of {job.source} ({job.line(min(fault.index, len(job) - 1))!r})" if line_no else ""
    )
    lost = (
        ""
        if proven
        else (
            " The plotter cannot prove where the pen stopped, so the resume re-establishes its position first."
        )
    )
    message = f"{fault} {where}. Stopped; {pen_note}.{lost} {advice}"
    if fault.kind == "error" and line_no:
        if index > fault.index:
            message += (
                f" (line {line_no} never ran; the lines the plotter had already taken after it did, "
                "so the resume continues after them)"
            )
        else:
            # Lines without a journal have no command line to resume them: say it in plain words.
            fix = "use --start-line" if journal is not None else "start from it"
            message += f" (this sends line {line_no} again; if the line itself is wrong, fix it and {fix})"
    return message
