"""System commands in a G-code file (GRBL's ``$`` lines), which change the board, not the drawing.

A jog (``$J=``) is a move and is followed like one (:mod:`pencilbot.driver.gcode.modal`, so the bed
check sees it). Every other system command the firmware knows (:meth:`Firmware.system_command`: a
startup block, a setting, check mode, sleep, a restore, homing, an unlock, a report…) is refused
by line, before anything is sent, unless the user names it (``--allow-system-commands '$H,$C'``);
then what it does to the plot is said (a warning naming the line), and the few after which the
board runs nothing more (sleep, a restore, which resets it) must be the file's last command.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from pencilbot.errors import PencilbotError

if TYPE_CHECKING:
    from pencilbot.driver.gcode.job import Job

_LOG = logging.getLogger(__name__)
_FIRST = ord("$")  # the byte every system command line starts with


@dataclass(frozen=True)
class SystemLines:
    """The system commands a job was allowed to send.

    Attributes
    ----------
    check_from : int or None
        The job line that turns on check mode (``$C``): the board draws nothing after it.
    notes : tuple of str
        What each allowed command does to the plot, naming its line.
    waits : frozenset of int
        Job lines (jogs, homing) the board must have finished before it takes the next.
    """

    check_from: int | None = None
    notes: tuple[str, ...] = ()
    waits: frozenset[int] = frozenset()


def allowed_names(text: str | Iterable[str] | None) -> frozenset[str]:
    """The names ``--allow-system-commands`` gives (``'$H,$C'``, ``h c $100=``): upper case, each
    with its ``$``, without what follows an ``=``."""
    if text is None:
        return frozenset()
    items = re.split(r"[,\s]+", text) if isinstance(text, str) else list(text)
    names = (item.strip().upper().split("=", 1)[0] for item in items)
    return frozenset(name if name.startswith("$") else "$" + name for name in names if name.strip("$"))


def check_system_lines(job: Job, allowed: frozenset[str] = frozenset()) -> SystemLines:
    """Refuse the system commands of ``job`` that are not ``allowed``; say what the others do.

    Raises
    ------
    PencilbotError
        Naming the first refused line, what it would do and how to allow it; or an allowed
        command after which the board runs nothing more (sleep, restore) followed by commands; or
        a second check mode (leaving it resets the board).
    """
    fw = job.profile.firmware
    starts = job.offsets[:-1]
    if not len(starts):
        return SystemLines()
    check_from, notes, waits = None, [], set()
    for index in np.flatnonzero(np.frombuffer(job.frames, dtype=np.uint8)[starts] == _FIRST).tolist():
        text = job.line(index)
        if fw.waits_after(text):
            waits.add(index)
        name = fw.system_command(text)
        if name is None:
            continue
        effect, ends, check_mode = fw.system_effect(name)
        where = f"line {job.number(index)} of {job.source} ({text!r})"
        if not any(fw.system_covers(given, name) for given in allowed):
            raise PencilbotError(
                f"{where} is a system command for the board, not a drawing: it {effect}; nothing was sent. "
                f"Take it out of the file, or send it on purpose: --allow-system-commands '{name}'"
            )
        if ends and index < len(job) - 1:
            raise PencilbotError(
                f"{where} {effect}, and {len(job) - 1 - index} command lines come after it, which the board would "
                f"never run (it {ends}); nothing was sent. Put it last, or take it out of the file"
            )
        if check_mode:
            if check_from is not None:
                raise PencilbotError(
                    f"{where} leaves check mode, which resets the board and loses the lines queued after it; "
                    "nothing was sent. Take the second one out of the file"
                )
            check_from = index
        notes.append(f"{where} {effect}")
    for note in notes:
        _LOG.warning(note)
    return SystemLines(check_from, tuple(notes), frozenset(waits))
