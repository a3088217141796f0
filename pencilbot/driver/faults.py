"""What can stop a stream, as data the driver turns into one plain message."""

from __future__ import annotations

from dataclasses import dataclass

#: Fault kinds → what happened, in words.
KINDS = {
    "error": "the plotter rejected a line",
    "alarm": "the plotter raised an alarm",
    "reset": "the plotter reset in the middle of the job; the lines it had buffered were lost",
    "timeout": "the plotter stopped answering",
    "port": "the serial port vanished",
    "interrupt": "stopped by Ctrl-C",
}


@dataclass
class StreamFault(Exception):
    """A stream stopped at job line ``index`` (0-based) for reason ``kind`` (see :data:`KINDS`)."""

    kind: str
    index: int
    detail: str = ""

    def __str__(self) -> str:
        return KINDS[self.kind] + (f" ({self.detail})" if self.detail else "")


class BadLine(Exception):
    """Job line ``index`` (0-based) cannot be sent to this firmware; ``reason`` says why."""

    def __init__(self, index: int, reason: str):
        super().__init__(reason)
        self.index, self.reason = index, reason


def is_rejection(reply) -> bool:
    """Whether a firmware's answer to one line says it was refused (GRBL or Marlin ``Error``)."""
    from firmware_protocol import grbl, marlin

    return isinstance(reply, (grbl.Error, marlin.Error))
