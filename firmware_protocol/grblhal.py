"""grblHAL's protocol: GRBL 1.1's grammar with grblHAL's limits and banner. Pure, no I/O.

grblHAL (the 32-bit successor of GRBL) speaks GRBL 1.1's line protocol, realtime bytes, status
reports and error codes, so everything here that is not listed below is :mod:`~firmware_protocol.grbl`'s.
What differs for a sender: a 1024-byte serial receive buffer (character counting may keep eight
times as much in flight), a 256-character line buffer, a deeper planner, its own start-up banner
(``GrblHAL 1.1f ['$' or '$HELP' for help]``; in compatibility mode it prints GRBL's, which is read
too), and a longer build report.
"""

from __future__ import annotations

import re

from firmware_protocol import grbl
from firmware_protocol.grbl import Unknown, Welcome

RX_BUFFER_SIZE = 1024
LINE_BUFFER_SIZE = 257  # 256 characters and the terminator
BLOCK_BUFFER_SIZE = 36  # one slot stays empty: 35 planned moves, as $I reports
VERSION = "1.1f"
BUILD_DATE = "20240101"
BANNER = f"GrblHAL {VERSION} ['$' or '$HELP' for help]"
HELP = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H $B ~ ! ? ctrl-x]"
_BANNER = re.compile(r"^GrblHAL (\S+) \['\$' or '\$HELP' for help\]$")


def build_report(info: str = "", options: str = "V") -> tuple[str, ...]:
    """What ``$I`` prints: GRBL's two lines with grblHAL's options, buffers and axis count, then its
    own (axes, extended options, firmware name)."""
    letters = options[:1] + "NMS" + options[1:]  # GRBL's letters, and line numbers, mist, spindle
    return (
        f"[VER:{VERSION}.{BUILD_DATE}:{info}]",
        f"[OPT:{letters},{BLOCK_BUFFER_SIZE - 1},{RX_BUFFER_SIZE},3,0]",
        "[AXS:3:XYZ]",
        "[NEWOPT:ENUMS,RT+]",
        "[FIRMWARE:grblHAL]",
    )


def parse_line(line: str | bytes) -> grbl.Message:
    """Parse one line a grblHAL board sent; never raises (see :func:`firmware_protocol.grbl.parse_line`)."""
    message = grbl.parse_line(line)
    if isinstance(message, Unknown) and (match := _BANNER.match(message.text)):
        return Welcome(match.group(1))
    return message


def encode_line(line: str) -> bytes:
    """:func:`firmware_protocol.grbl.encode_line` with grblHAL's line buffer."""
    return grbl.encode_line(line, line_buffer=LINE_BUFFER_SIZE, firmware="grblHAL")
