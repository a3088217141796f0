"""Marlin serial protocol: replies and ``N… *checksum`` line framing. Pure functions, no I/O.

Marlin answers each line with ``ok`` (optionally followed by ``N<line> P<planner> B<buffer>``
with ADVANCED_OK). A line whose number or checksum is wrong gets ``Error:…`` followed by
``Resend: N``; the sender must resend from line N. While a long command runs Marlin sends
``echo:busy: processing`` keep-alives. Framing: ``N<n> <command>*<cs>`` where ``cs`` is the XOR
of every byte before ``*``; ``M110 N<n>`` sets the next expected line number.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import reduce

from firmware_protocol import ProtocolError

#: Marlin's default command length limit (MAX_CMD_SIZE 96, including the terminator).
MAX_CMD_SIZE = 96


@dataclass(frozen=True)
class Ok:
    """``ok``; with ADVANCED_OK also the last line number and free planner / buffer slots."""

    line_number: int | None = None
    planner_free: int | None = None
    buffer_free: int | None = None


@dataclass(frozen=True)
class Resend:
    """``Resend: N``: resend every line from number ``line_number`` on."""

    line_number: int


@dataclass(frozen=True)
class Busy:
    """``busy: <reason>`` keep-alive: the previous command is still running."""

    reason: str


@dataclass(frozen=True)
class Echo:
    """``echo:<text>``: informational output."""

    text: str


@dataclass(frozen=True)
class Error:
    """``Error:<text>``: the line was rejected (a ``Resend`` usually follows)."""

    text: str


@dataclass(frozen=True)
class Start:
    """``start``: the board has just booted."""


@dataclass(frozen=True)
class Unknown:
    """Any other line (temperature reports, noise); log and ignore."""

    text: str


Message = Ok | Resend | Busy | Echo | Error | Start | Unknown

_OK = re.compile(r"^ok(?:\s+N(\d+))?(?:\s+P(\d+))?(?:\s+B(\d+))?(?:\s.*)?$")
_RESEND = re.compile(r"^(?:Resend|rs):?\s*N?(\d+)\s*$", re.IGNORECASE)


def _int_or_none(text: str | None) -> int | None:
    return None if text is None else int(text)


def parse_line(line: str | bytes) -> Message:
    """Parse one line a Marlin board sent. Never raises; non-Marlin text is :class:`Unknown`."""
    if isinstance(line, bytes):
        line = line.decode("ascii", errors="replace")
    text = line.strip("\r\n").strip()
    if m := _OK.match(text):
        return Ok(*(_int_or_none(g) for g in m.groups()))
    if m := _RESEND.match(text):
        return Resend(int(m.group(1)))
    if text.startswith(("echo:busy:", "busy:")):
        return Busy(text.split("busy:", 1)[1].strip())
    if text.startswith("echo:"):
        return Echo(text[5:])
    if text.lower().startswith("error:"):
        return Error(text[6:])
    if text == "start":
        return Start()
    return Unknown(text)


def checksum(text: str) -> int:
    """XOR of the ASCII bytes of ``text`` (Marlin's line checksum, 0..255)."""
    return reduce(lambda acc, b: acc ^ b, text.encode("ascii"), 0)


def frame_line(number: int, command: str) -> bytes:
    """``N<number> <command>*<checksum>\\n`` for a numbered, checksummed send.

    Raises
    ------
    ProtocolError
        If ``command`` is not ASCII, holds a line break or ``*``, or is too long for Marlin.
    """
    body = f"N{number} {command.strip()}"
    if not body.isascii() or any(ch in body for ch in "\r\n*"):
        raise ProtocolError(
            f"G-code line {command!r} cannot be framed for Marlin (non-ASCII, '*' or a line break)."
        )
    framed = f"{body}*{checksum(body)}"
    if len(framed) >= MAX_CMD_SIZE:
        raise ProtocolError(
            f"G-code line {command!r} is too long for Marlin once numbered ({len(framed)} of "
            f"{MAX_CMD_SIZE - 1} characters); use fewer decimals."
        )
    return framed.encode("ascii") + b"\n"


def unframe_line(line: str) -> tuple[int, str] | None:
    """The board's side of :func:`frame_line`: ``(number, command)`` or ``None`` if corrupt."""
    m = re.fullmatch(r"N(\d+) ?(.*)\*(\d+)", line.strip())
    if m is None:
        return None
    body = line.strip().rsplit("*", 1)[0]
    if checksum(body) != int(m.group(3)):
        return None
    return int(m.group(1)), m.group(2).strip()


def reset_line_numbers(number: int = 0) -> bytes:
    """The framed ``M110`` that makes Marlin expect ``number + 1`` next."""
    return frame_line(number, f"M110 N{number}")
