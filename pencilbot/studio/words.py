"""A plot's message as the page says it: plain words and the page's own next step.

The driver writes for a terminal: the G-code's path in the server's temporary folder, the
G-code line in quotes, the ``pencilbot draw --resume …`` command, the firmware's alarm code.
On the page the file is "the plot", the resume is the page's button, and an alarm says what it
means (its code kept, for the plotter's manual).
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

#: GRBL's alarm codes in plain words.
ALARMS = {
    "1": "a limit switch was hit",
    "2": "a move would leave the plotter's travel",
    "3": "the board was reset while moving, so it lost its position",
    "4": "the probe was not in the state expected",
    "5": "the probe did not touch",
    "6": "homing was reset",
    "7": "a door opened while homing",
    "8": "homing could not leave the switch",
    "9": "homing found no switch",
    "10": "a limit switch was hit while homing",
}
RESUME_BUTTON = 'Press "Resume the stopped plot" to go on from there.'
_RESUME = re.compile(r"(?:Resume with|continue with): pencilbot draw [^\n]*?(?=$| \(line \d+ )")
_QUOTED_LINE = re.compile(r"(at line \d+ of the plot) \((['\"]).*?\2\)")
_ALARM = re.compile(r"ALARM:(\d+)(?!\d)[^()]*")  # the code and the firmware's own words after it


def page_words(message: str, gcode: Path, resumable: bool) -> str:
    """``message`` (the driver's, about the plot of ``gcode``) in the page's words."""
    for path in (f"{gcode}.job.json", str(gcode)):
        message = message.replace(shlex.quote(path), path).replace(path, "the plot")
    message = _QUOTED_LINE.sub(r"\1", message)
    message = _RESUME.sub(RESUME_BUTTON if resumable else "Start the plot again to draw it.", message)
    return _ALARM.sub(lambda m: f"ALARM:{m[1]}: {ALARMS[m[1]]}" if m[1] in ALARMS else m[0], message)
