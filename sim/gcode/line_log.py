"""The log of every complete line a virtual GRBL board received, with the reply it got.

Tests prove exactly-once delivery from it (:meth:`sim.gcode.firmware.Firmware.accepted_lines`).
"""

from __future__ import annotations

from array import array
from collections.abc import Iterator
from dataclasses import dataclass


@dataclass(frozen=True)
class LoggedLine:
    """A complete line the board received: 1-based ``index``, the text, and its reply."""

    index: int
    text: str
    reply: str


class LineLog:
    """Every complete line the board received, with its reply, in the order they were answered.

    A sequence of :class:`LoggedLine`, held as flat arrays (the texts in one byte string, each
    reply as a number into the few distinct replies): a million-line job costs tens of bytes a
    line, not the ~200 an object per line took.
    """

    def __init__(self) -> None:
        self._texts = bytearray()
        self._ends = array("Q")  # where each line's text ends in _texts
        self._index = array("L")
        self._reply = array("H")  # into _replies
        self._replies: list[str] = []
        self._reply_code: dict[str, int] = {}

    def append(self, index: int, text: str, reply: str) -> None:
        code = self._reply_code.get(reply)
        if code is None:
            code = self._reply_code[reply] = len(self._replies)
            self._replies.append(reply)
        self._texts += text.encode("latin-1")
        self._ends.append(len(self._texts))
        self._index.append(index)
        self._reply.append(code)

    def __len__(self) -> int:
        return len(self._ends)

    def __getitem__(self, i: int) -> LoggedLine:
        n = len(self._ends)
        if not -n <= i < n:
            raise IndexError(f"line {i} of a log of {n}")
        i %= n
        start = self._ends[i - 1] if i else 0
        text = self._texts[start : self._ends[i]].decode("latin-1")
        return LoggedLine(self._index[i], text, self._replies[self._reply[i]])

    def __iter__(self) -> Iterator[LoggedLine]:
        return (self[i] for i in range(len(self)))

    def texts_answered(self, reply: str) -> list[str]:
        """Texts of the non-blank lines answered ``reply``, in order (blank lines, such as a
        sender's wake-up line ends, carry nothing to deliver)."""
        code = self._reply_code.get(reply)
        if code is None:
            return []
        texts = self._texts.decode("latin-1")
        starts = [0, *self._ends[:-1]]
        return [texts[a:b] for a, b, r in zip(starts, self._ends, self._reply) if r == code and b > a]
