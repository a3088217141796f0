"""What GRBL does with a received line: its protocol loop's filter (:func:`filter_line`), and the
line its main loop is inside of while the line's steps wait for the machine (:class:`Task`)."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from firmware_protocol import grbl


@dataclass
class Task:
    """A line GRBL's main loop is inside of: its steps run until done, then ``finish`` answers.
    ``line`` is its (log index, text), or ``None`` for a startup line."""

    steps: Iterator
    finish: Callable[[], None]
    line: tuple[int, str] | None


def filter_line(raw: bytes, line_buffer: int = grbl.LINE_BUFFER_SIZE) -> str | None:
    """GRBL's protocol-loop filter: the significant characters, or ``None`` on overflow."""
    if b"(" in raw or b";" in raw:
        raw = re.sub(rb"\([^)]*\)?|;.*", b"", raw)
    text = raw.translate(None, grbl.DROPPED_BYTES).upper()
    if len(text) >= line_buffer:
        return None
    return text.decode("latin-1")
