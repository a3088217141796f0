"""GRBL 1.1 serial protocol: message grammar, code tables, constants. Pure functions, no I/O.

Both sides use this module: a sender parses what the board says with :func:`parse_line` and
frames what it sends with :func:`encode_line`; the virtual plotter (:mod:`sim`) formats its
replies with the ``format_*`` functions. ``parse_line(format_x(m)) == m`` for every message.

Facts follow GRBL 1.1's interface documentation: a 128-byte serial receive buffer, an 80-byte
line buffer (79 significant characters plus the terminator; spaces, comments and the end of
line do not count), realtime bytes that bypass the buffer, and the error / alarm tables.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from firmware_protocol import ProtocolError

#: Serial receive buffer of the board, in bytes. A character-counting sender keeps the sum of
#: the encoded lengths of its unacknowledged lines at or below this.
RX_BUFFER_SIZE = 128
#: GRBL's line buffer, in bytes, including the terminating NUL: a line may hold at most
#: ``LINE_BUFFER_SIZE - 1`` significant characters (whitespace and comments are not stored).
LINE_BUFFER_SIZE = 80
#: Bytes GRBL's line buffer never stores: whitespace, control characters and block delete ``/``.
DROPPED_BYTES = bytes(range(ord(" ") + 1)) + b"/"
#: Planner ring size; GRBL reports ``BLOCK_BUFFER_SIZE - 1`` free blocks when empty.
BLOCK_BUFFER_SIZE = 16

#: Realtime commands: single bytes picked off the serial stream as they arrive, never
#: buffered and never answered with ``ok``.
STATUS_QUERY = b"?"
FEED_HOLD = b"!"
CYCLE_START = b"~"
SOFT_RESET = b"\x18"
REALTIME_BYTES = frozenset(STATUS_QUERY + FEED_HOLD + CYCLE_START + SOFT_RESET)
#: Extended realtime command (bytes >= 0x80 never enter the line buffer): stop a ``$J=`` jog.
JOG_CANCEL = b"\x85"

VERSION = "1.1h"
BUILD_DATE = "20190825"
BANNER = f"Grbl {VERSION} ['$' for help]"
#: What ``$`` prints.
HELP = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]"


def build_report(info: str = "", options: str = "V") -> tuple[str, ...]:
    """What ``$I`` prints: version and the stored build info, then the compile options, free
    planner blocks and receive buffer."""
    return f"[VER:{VERSION}.{BUILD_DATE}:{info}]", f"[OPT:{options},{BLOCK_BUFFER_SIZE - 1},{RX_BUFFER_SIZE}]"


#: ``error:N`` → (short name, explanation), GRBL 1.1.
ERRORS: dict[int, tuple[str, str]] = {
    1: ("Expected command letter", "G-code words consist of a letter and a value. Letter was not found."),
    2: ("Bad number format", "Missing the expected G-code word value or numeric value format is not valid."),
    3: ("Invalid statement", "Grbl '$' system command was not recognized or supported."),
    4: ("Value < 0", "Negative value received for an expected positive value."),
    5: ("Setting disabled", "Homing cycle failure. Homing is not enabled via settings."),
    6: ("Value < 3 usec", "Minimum step pulse time must be greater than 3usec."),
    7: (
        "EEPROM read fail. Using defaults",
        "An EEPROM read failed. Auto-restoring affected EEPROM to default values.",
    ),
    8: (
        "Not idle",
        "Grbl '$' command cannot be used unless Grbl is IDLE. Ensures smooth operation during a job.",
    ),
    9: ("G-code lock", "G-code commands are locked out during alarm or jog state."),
    10: ("Homing not enabled", "Soft limits cannot be enabled without homing also enabled."),
    11: ("Line overflow", "Max characters per line exceeded. Received command line was not executed."),
    12: ("Step rate > 30kHz", "Grbl '$' setting value cause the step rate to exceed the maximum supported."),
    13: ("Check Door", "Safety door detected as opened and door state initiated."),
    14: (
        "Line length exceeded",
        "Build info or startup line exceeded EEPROM line length limit. Line not stored.",
    ),
    15: ("Travel exceeded", "Jog target exceeds machine travel. Jog command has been ignored."),
    16: ("Invalid jog command", "Jog command has no '=' or contains prohibited g-code."),
    17: ("Setting disabled", "Laser mode requires PWM output."),
    20: ("Unsupported command", "Unsupported or invalid g-code command found in block."),
    21: ("Modal group violation", "More than one g-code command from same modal group found in block."),
    22: ("Undefined feed rate", "Feed rate has not yet been set or is undefined."),
    23: ("Invalid gcode ID:23", "G-code command in block requires an integer value."),
    24: ("Invalid gcode ID:24", "More than one g-code command that requires axis words found in block."),
    25: ("Invalid gcode ID:25", "Repeated g-code word found in block."),
    26: (
        "Invalid gcode ID:26",
        "No axis words found in block for g-code command or current modal state which requires them.",
    ),
    27: ("Invalid gcode ID:27", "Line number value is invalid."),
    28: ("Invalid gcode ID:28", "G-code command is missing a required value word."),
    29: ("Invalid gcode ID:29", "G59.x work coordinate systems are not supported."),
    30: ("Invalid gcode ID:30", "G53 only allowed with G0 and G1 motion modes."),
    31: (
        "Invalid gcode ID:31",
        "Axis words found in block when no command or current modal state uses them.",
    ),
    32: ("Invalid gcode ID:32", "G2 and G3 arcs require at least one in-plane axis word."),
    33: ("Invalid gcode ID:33", "Motion command target is invalid."),
    34: ("Invalid gcode ID:34", "Arc radius value is invalid."),
    35: ("Invalid gcode ID:35", "G2 and G3 arcs require at least one in-plane offset word."),
    36: ("Invalid gcode ID:36", "Unused value words found in block."),
    37: (
        "Invalid gcode ID:37",
        "G43.1 dynamic tool length offset is not assigned to configured tool length axis.",
    ),
    38: ("Invalid gcode ID:38", "Tool number greater than max supported value."),
}

#: ``ALARM:N`` → (short name, explanation), GRBL 1.1.
ALARMS: dict[int, tuple[str, str]] = {
    1: (
        "Hard limit",
        "Hard limit has been triggered. Machine position is likely lost due to sudden halt. Re-homing is highly recommended.",
    ),
    2: (
        "Soft limit",
        "Soft limit alarm. G-code motion target exceeds machine travel. Machine position retained. Alarm may be safely unlocked.",
    ),
    3: (
        "Abort during cycle",
        "Reset while in motion. Machine position is likely lost due to sudden halt. Re-homing is highly recommended.",
    ),
    4: ("Probe fail", "Probe is not in the expected initial state before starting probe cycle."),
    5: ("Probe fail", "Probe did not contact the workpiece within the programmed travel."),
    6: ("Homing fail", "The active homing cycle was reset."),
    7: ("Homing fail", "Safety door was opened during homing cycle."),
    8: (
        "Homing fail",
        "Pull off travel failed to clear limit switch. Try increasing pull-off setting or check wiring.",
    ),
    9: (
        "Homing fail",
        "Could not find limit switch within search distances. Try increasing max travel, decreasing pull-off distance, or check wiring.",
    ),
}

#: Settings GRBL prints without decimals; the rest are printed with three.
INTEGER_SETTINGS = frozenset({0, 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 26, 30, 31, 32})

#: Status report machine states (``Hold`` and ``Door`` carry a ``:n`` sub-state).
STATES = ("Idle", "Run", "Hold", "Jog", "Alarm", "Door", "Check", "Home", "Sleep")


# --- messages -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Ok:
    """``ok``: the line was parsed and queued (not necessarily executed)."""


@dataclass(frozen=True)
class Error:
    """``error:N``: the line was rejected; ``text`` is the table's short name."""

    code: int

    @property
    def text(self) -> str:
        return ERRORS.get(self.code, ("Unknown error", ""))[0]

    @property
    def explanation(self) -> str:
        return ERRORS.get(self.code, ("", "Not in the GRBL 1.1 error table."))[1]


@dataclass(frozen=True)
class Alarm:
    """``ALARM:N``: the machine stopped and locks G-code until reset / ``$X``."""

    code: int

    @property
    def text(self) -> str:
        return ALARMS.get(self.code, ("Unknown alarm", ""))[0]

    @property
    def explanation(self) -> str:
        return ALARMS.get(self.code, ("", "Not in the GRBL 1.1 alarm table."))[1]


@dataclass(frozen=True)
class Status:
    """A ``<…>`` realtime status report. Positions in mm, rates in mm/min.

    Fields absent from the report are ``None``. ``wpos``/``mpos``: only one is sent by the board
    (``$10``); the other can be derived with ``wco`` when that is known.
    """

    state: str
    substate: int | None = None
    mpos: tuple[float, ...] | None = None
    wpos: tuple[float, ...] | None = None
    buffer: tuple[int, int] | None = None  # (free planner blocks, free RX bytes)
    line_number: int | None = None
    feed: float | None = None
    spindle: float | None = None
    pins: str | None = None
    wco: tuple[float, ...] | None = None
    overrides: tuple[int, int, int] | None = None  # feed, rapid, spindle in %
    accessories: str | None = None


@dataclass(frozen=True)
class Feedback:
    """A bracketed push message ``[TAG:text]``: MSG, GC, VER, OPT, HLP, G54, PRB, …"""

    tag: str
    text: str


@dataclass(frozen=True)
class Welcome:
    """The start-up banner ``Grbl 1.1h ['$' for help]``: the board has just reset."""

    version: str


@dataclass(frozen=True)
class Setting:
    """One ``$N=V`` line of a ``$$`` listing."""

    number: int
    value: float


@dataclass(frozen=True)
class Unknown:
    """Anything else (line noise, a different firmware); a sender should log and ignore it."""

    text: str


Message = Ok | Error | Alarm | Status | Feedback | Welcome | Setting | Unknown

_BANNER = re.compile(r"^Grbl (\S+) \['\$' for help\]$")
_SETTING = re.compile(r"^\$(\d+)=(-?\d+(?:\.\d*)?)$")
_FEEDBACK = re.compile(r"^\[([A-Z0-9.]+):(.*)\]$")
_STATUS_TOKEN = re.compile(r"^[A-Za-z]+(?::\d+)?$")


def _floats(text: str) -> tuple[float, ...]:
    return tuple(float(v) for v in text.split(","))


def _parse_status(body: str) -> Status | None:
    fields = body.split("|")
    if not _STATUS_TOKEN.match(fields[0]):
        return None
    state, _, sub = fields[0].partition(":")
    values: dict = {"state": state, "substate": int(sub) if sub else None}
    for field in fields[1:]:
        key, sep, val = field.partition(":")
        if not sep:
            return None
        if key == "MPos":
            values["mpos"] = _floats(val)
        elif key == "WPos":
            values["wpos"] = _floats(val)
        elif key == "WCO":
            values["wco"] = _floats(val)
        elif key == "Bf":
            blocks, rx = val.split(",")
            values["buffer"] = (int(blocks), int(rx))
        elif key == "Ln":
            values["line_number"] = int(val)
        elif key == "FS":
            feed, spindle = _floats(val)
            values["feed"], values["spindle"] = feed, spindle
        elif key == "F":
            values["feed"] = float(val)
        elif key == "Ov":
            feed, rapid, spindle = (int(v) for v in val.split(","))
            values["overrides"] = (feed, rapid, spindle)
        elif key == "Pn":
            values["pins"] = val
        elif key == "A":
            values["accessories"] = val
        # Unknown fields (forks add their own) are skipped, as the interface docs ask.
    return Status(**values)


def parse_line(line: str | bytes) -> Message:
    """Parse one line a GRBL 1.1 board sent (with or without its ``\\r\\n``).

    Never raises: anything that is not GRBL grammar comes back as :class:`Unknown`.
    """
    if isinstance(line, bytes):
        line = line.decode("ascii", errors="replace")
    text = line.strip("\r\n")
    if text == "ok":
        return Ok()
    try:
        if text.startswith("error:"):
            return Error(int(text[6:]))
        if text.startswith("ALARM:"):
            return Alarm(int(text[6:]))
        if text.startswith("<") and text.endswith(">"):
            status = _parse_status(text[1:-1])
            if status is not None:
                return status
    except ValueError:
        pass  # a mangled number: not a message GRBL sends
    if m := _FEEDBACK.match(text):
        return Feedback(m.group(1), m.group(2))
    if m := _BANNER.match(text):
        return Welcome(m.group(1))
    if m := _SETTING.match(text):
        return Setting(int(m.group(1)), float(m.group(2)))
    return Unknown(text)


# --- formatting (the board's side) ----------------------------------------------------------


MM_PER_INCH = 25.4


def format_coords(values, *, inches: bool = False) -> str:
    """Positions (mm) as GRBL prints them: 3 decimals, or inches with 4 when ``$13=1``."""
    if inches:
        return ",".join(f"{v / MM_PER_INCH + 0.0:.4f}" for v in values)
    return ",".join(f"{v + 0.0:.3f}" for v in values)  # + 0.0: GRBL never prints -0.000 for zero


def _rate(value: float, inches: bool) -> str:
    """GRBL prints rates with no decimals in mm/min, one in in/min."""
    return f"{value / MM_PER_INCH:.1f}" if inches else f"{value:.0f}"


def format_status(status: Status, *, inches: bool = False) -> str:
    """The ``<…>`` line for ``status``, fields in GRBL's order (no line ending); ``inches``:
    positions and feed printed in inches, as with GRBL's ``$13=1`` (values are given in mm)."""
    parts = [status.state if status.substate is None else f"{status.state}:{status.substate}"]
    if status.mpos is not None:
        parts.append(f"MPos:{format_coords(status.mpos, inches=inches)}")
    if status.wpos is not None:
        parts.append(f"WPos:{format_coords(status.wpos, inches=inches)}")
    if status.buffer is not None:
        parts.append(f"Bf:{status.buffer[0]},{status.buffer[1]}")
    if status.line_number is not None:
        parts.append(f"Ln:{status.line_number}")
    if status.feed is not None:
        if status.spindle is None:
            parts.append(f"F:{_rate(status.feed, inches)}")
        else:
            parts.append(f"FS:{_rate(status.feed, inches)},{status.spindle:.0f}")
    if status.pins:
        parts.append(f"Pn:{status.pins}")
    if status.wco is not None:
        parts.append(f"WCO:{format_coords(status.wco, inches=inches)}")
    if status.overrides is not None:
        parts.append("Ov:" + ",".join(str(v) for v in status.overrides))
    if status.accessories:
        parts.append(f"A:{status.accessories}")
    return "<" + "|".join(parts) + ">"


def format_message(message: Message) -> str:
    """The exact text a GRBL 1.1 board prints for ``message`` (no line ending)."""
    match message:
        case Ok():
            return "ok"
        case Error(code):
            return f"error:{code}"
        case Alarm(code):
            return f"ALARM:{code}"
        case Status():
            return format_status(message)
        case Feedback(tag, text):
            return f"[{tag}:{text}]"
        case Welcome(version):
            return f"Grbl {version} ['$' for help]"
        case Setting(number, value):
            return f"${number}={value:.0f}" if number in INTEGER_SETTINGS else f"${number}={value:.3f}"
        case Unknown(text):
            return text
    raise TypeError(f"not a GRBL message: {message!r}")


# --- the sender's side ----------------------------------------------------------------------


def significant_length(line: str) -> int:
    """Characters of ``line`` that GRBL stores in its line buffer.

    Whitespace, control characters, ``/``, ``(…)`` comments and ``;`` comments are dropped as
    they arrive, exactly as GRBL's protocol loop does; the result must stay below
    :data:`LINE_BUFFER_SIZE` or the board answers ``error:11``.
    """
    count = 0
    in_paren = in_semicolon = False
    for ch in line:
        if in_semicolon:
            continue
        if in_paren:
            in_paren = ch != ")"
        elif ch <= " " or ch == "/":
            continue
        elif ch == "(":
            in_paren = True
        elif ch == ";":
            in_semicolon = True
        else:
            count += 1
    return count


def encode_line(line: str, *, line_buffer: int = LINE_BUFFER_SIZE, firmware: str = "GRBL") -> bytes:
    """Frame one G-code line for sending: ASCII, stripped, terminated by a single ``\\n``.

    A sender must count ``len(encode_line(line))`` bytes against :data:`RX_BUFFER_SIZE`.
    ``line_buffer`` and ``firmware`` let a firmware with GRBL's protocol and a longer line
    buffer (grblHAL) frame by the same rules.

    Raises
    ------
    ProtocolError
        If the line is not ASCII, contains a line break or a realtime byte, or holds more
        significant characters than the line buffer takes (the board would reject it).
    """
    text = line.strip()
    if not text.isascii():
        raise ProtocolError(
            f"G-code line {text!r} contains non-ASCII characters; {firmware} takes ASCII only."
        )
    bad = [ch for ch in text if ch in "\r\n" or ord(ch) in REALTIME_BYTES]
    if bad:
        raise ProtocolError(
            f"G-code line {text!r} contains {bad[0]!r}, which {firmware} treats as a line end or a "
            "realtime command; remove it from the G-code."
        )
    if significant_length(text) >= line_buffer:
        raise ProtocolError(
            f"G-code line is {significant_length(text)} characters long (without spaces and "
            f"comments); {firmware} accepts at most {line_buffer - 1}. Split the move or use "
            "fewer decimals."
        )
    return text.encode("ascii") + b"\n"
