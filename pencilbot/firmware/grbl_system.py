"""GRBL's system commands (``$`` lines other than a ``$J=`` jog), as a G-code file may hold them:
their names and what each does to a plot (:mod:`pencilbot.driver.gcode.system_lines` refuses them
unless the user names them, then says what they do)."""

from __future__ import annotations

import re

#: What each system command does to a plot, by name (``$N`` and ``$<n>`` stand for every number).
EFFECTS = {
    "$C": "turns on the board's check mode: it parses every line after it and moves for none, so "
    "nothing after it is drawn",
    "$H": "homes the machine: the carriage runs to its home switches, at machine X0 Y0",
    "$X": "unlocks the board from an alarm without homing it",
    "$SLP": "puts the board to sleep: it runs nothing after it until it is reset",
    "$RST": "restores the board's factory settings or offsets and resets it",
    "$N": "stores a startup block the board runs after every reset and homing",
    "$n": "changes a setting stored in the board (steps per mm, speeds, limits, pen output), so its "
    "moves may no longer be the file's",
    "$I": "reads or stores the board's build information",
}
#: After these the board runs nothing more of a job: what it does then.
ENDS_JOB = {"$SLP": "sleeps", "$RST": "resets"}
CHECK_MODE = "$C"
JOG = "$J="
_NAME = re.compile(r"\$(N\d+|\d+|[A-Z]+|\$|#)?")


def command_name(line: str) -> str | None:
    """The name of a cleaned system command line (``$N0=G0X5`` → ``$N0``, ``$100=250`` →
    ``$100``, ``$RST=*`` → ``$RST``, ``$$`` → ``$$``); None for a jog or a line that is not one."""
    if not line.startswith("$"):
        return None
    if line.startswith(JOG):
        return None
    name = _NAME.match(line)
    return name.group() if name else line


def moves_alone(line: str) -> bool:
    """Whether cleaned ``line`` is a jog or a homing cycle, during which GRBL refuses G-code
    (error:9): a sender waits until it has finished before the next line."""
    return line.startswith(JOG) or line == "$H"


def effect(name: str) -> str:
    """What system command ``name`` does, in words that follow "it"."""
    if name in EFFECTS:
        return EFFECTS[name]
    if name.startswith("$N") and len(name) > 2:
        return EFFECTS["$N"]
    if name[1:].isdigit():
        return EFFECTS["$n"].replace("a setting", f"setting {name}")
    return "prints a report of the board"


def covers(allowed: str, name: str) -> bool:
    """Whether the allowed name covers ``name`` (``$N`` covers ``$N0`` and ``$N1``)."""
    return allowed == name or (allowed == "$N" and name[:2] == "$N" and name[2:].isdigit())
