"""What stops a stream: one :class:`StreamFault` naming the job line, and :class:`Interrupted`,
a request to stop safely (Ctrl-C, a signal, the stop key).

The caller (:mod:`pencilbot.driver.gcode.runner`) turns a fault into one message with the way to resume.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Fault kinds → what happened, in words.
KINDS = {
    "error": "the plotter rejected a line",
    "alarm": "the plotter raised an alarm",
    "reset": "the plotter reset in the middle of the job; the lines it had buffered were lost",
    "timeout": "the plotter stopped answering",
    "port": "the serial port vanished",
    "interrupt": "stopped by",  # + who: Ctrl-C, SIGTERM, SIGHUP, the stop key
    "journal": "the job journal could not be written",
    "unexpected": (
        "the plotter answered a line pencilbot did not send: another program is writing to the "
        "port, and the plotter ran what it wrote (the drawing may hold a stray line); close that "
        "program before you resume"
    ),
}


@dataclass
class StreamFault(Exception):
    """A stream stopped at job line ``index`` (0-based; −1: none) for reason ``kind`` (see
    :data:`KINDS`)."""

    kind: str
    index: int
    detail: str = ""

    def __str__(self) -> str:
        if self.kind == "interrupt":
            return f"{KINDS[self.kind]} {self.detail or 'Ctrl-C'}"
        return KINDS[self.kind] + (f" ({self.detail})" if self.detail else "")


class Interrupted(KeyboardInterrupt):
    """A request to stop safely: Ctrl-C, a signal (SIGTERM, SIGHUP) or the stop key; ``by`` says
    which."""

    def __init__(self, by: str = "Ctrl-C"):
        super().__init__(by)
        self.by = by
