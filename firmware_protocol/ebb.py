"""The EiBotBoard (EBB) serial protocol: commands and replies, both reply syntaxes. Pure, no I/O.

What an AxiDraw, NextDraw or EBB-compatible iDraw board speaks over USB CDC (VID:PID 04D8:FD92,
any baud). Facts from Evil Mad Scientist's EBB command reference (``docs/ebb.html``) and the
firmware source (``EBB_firmware/app.X/source/UBW.c``, ``ebb.c``, v3.0.3) of evil-mad/EggBot:

* A command is ASCII, case-insensitive, no whitespace, ``NAME[,arg...]`` ending in ``\\r``, at
  most 256 bytes with the CR.
* **Legacy syntax** (the default at boot): most commands answer ``OK\\r\\n``; queries answer
  their data with line endings of their own (``QS``: ``a,b\\n\\rOK\\r\\n``; ``QG``: ``HH\\r\\n``
  without OK; ``V``: the version string and ``\\r\\n`` without OK).
* **Future syntax** (``CU,10,1``, firmware 3.x): every reply is the command's name, then
  ``,data`` if it has data, then ``\\n``. The switch itself answers oddly: ``CU,10,1`` from legacy
  gives a bare ``\\n``; ``CU,10,0`` from future gives ``CUOK\\r\\n``.
* Errors: ``!N Err: text`` then ``\\r\\n`` (legacy), or ``NAME,!N Err: text\\n`` (future).
* Motion commands (SM, XM, LM, HM, SP 0/1, EM, ...) go through a FIFO (1 deep at boot,
  ``CU,4,n`` up to ``QU,2``); a command is parsed, and answered, only once there is room.
* ``LM`` rates: added to a 31-bit accumulator every 40 µs; rate = 2³¹ × 40 µs × step Hz.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from firmware_protocol import ProtocolError

MAX_COMMAND = 256  # bytes, with the terminating CR
TICK = 40e-6  # s: the step interrupt runs at 25 kHz
MAX_STEP_RATE = 25_000.0  # steps/s on each motor
ACCUMULATOR = 1 << 31  # a step is taken each time the accumulator passes 2^31
RATE_PER_HZ = ACCUMULATOR * TICK  # ≈ 85 899.35: LM's Rate for one step per second
SERVO_TICK = 1 / 12e6  # s per servo position unit (83.3 ns)
SERVO_PERIOD = 0.024  # s: the servo channel fires (and its rate is applied) every 24 ms
VERSION = "3.0.3"
VERSION_TEXT = f"EBBv13_and_above EB Firmware Version {VERSION}"
#: Commands and ``CU`` parameters firmware before this version does not have: ``QU`` is an
#: unknown command (``!8``), ``CU,4`` (FIFO depth), ``CU,10`` (future syntax) and ``CU,60``
#: (power-lost threshold) are taken and do nothing (v2.8.1's ``parse_CU_packet`` acts on 1 and
#: 2 only); the FIFO stays one deep.
SINCE = {"QU": (3, 0), "T3": (3, 0), "TD": (3, 0)}
CU_SINCE = {4: (3, 0), 10: (3, 0), 60: (3, 0)}
MAX_DELAY_MS = 100_000  # SM,ms,0,0 (a delay) is capped at 100 s


def version_text(version: str = VERSION) -> str:
    """What ``V`` answers on a board with firmware ``version`` (an EBB v1.3 or later board)."""
    return f"EBBv13_and_above EB Firmware Version {version}"


def version_tuple(version: str) -> tuple[int, ...]:
    """``"2.8.1"`` → ``(2, 8, 1)``; raises ``ValueError`` for anything else."""
    parts = tuple(int(p) for p in version.split("."))
    if len(parts) != 3:
        raise ValueError(f"an EBB firmware version is three numbers (3.0.3), not {version!r}")
    return parts


USB_ID = (0x04D8, 0xFD92)
FIFO_MAX = 32  # what QU,2 reports on the emulated board
#: Bit masks of the QG status byte (firmware 3.x meanings).
QG_LIMIT, QG_POWER_LOST, QG_BUTTON, QG_PEN_UP, QG_COMMAND, QG_MOTOR1, QG_MOTOR2, QG_FIFO = (
    128,
    64,
    32,
    16,
    8,
    4,
    2,
    1,
)

_INT32 = (-(1 << 31), (1 << 31) - 1)
_UINT32 = (0, (1 << 32) - 1)
_UINT16 = (0, 65535)


@dataclass(frozen=True)
class Spec:
    """One command's grammar: argument ranges (required first), whether it waits for FIFO
    room, and the shape of its legacy reply (``ok``: ``OK\\r\\n``; ``data_ok``: data, the given
    ending, then ``OK\\r\\n``; ``data``: data and ``\\r\\n`` only)."""

    ranges: tuple[tuple[int, int], ...]
    required: int
    queued: bool = False
    reply: str = "ok"
    ending: str = "\r\n"
    kinds: str = ""  # per argument: "i" a number (the default), "c" one character, "s" the rest as text


COMMANDS: dict[str, Spec] = {
    "V": Spec((), 0, reply="data"),
    "R": Spec((), 0),
    "CU": Spec(((0, 65535), (-32768, 32767)), 2),
    "CS": Spec((), 0),
    "EM": Spec(((0, 5), (0, 5)), 1, queued=True),
    "ES": Spec(((0, 1),), 0, reply="data_ok", ending="\n\r"),
    "HM": Spec(((2, 25000), _INT32, _INT32), 1, queued=True),
    "LM": Spec((_INT32, _INT32, _INT32, _INT32, _INT32, _INT32, (0, 3)), 6, queued=True),
    "SM": Spec((_UINT32, _INT32, _INT32, (0, 3)), 2, queued=True),
    "XM": Spec(((1, _INT32[1]), _INT32, _INT32, (0, 3)), 3, queued=True),
    "SP": Spec(((0, 255), _UINT16, (0, 255)), 1, queued=True),  # State > 3 is 3, Pin > 7 is 1
    "TP": Spec(((1, 65535),), 0, queued=True),
    "SC": Spec(((0, 255), _UINT16), 2),
    "SR": Spec((_UINT32, (0, 1)), 1),
    "QB": Spec((), 0, reply="data_ok"),
    "QG": Spec((), 0, reply="data"),
    "QP": Spec((), 0, reply="data_ok", ending="\n\r"),
    "QS": Spec((), 0, reply="data_ok", ending="\n\r"),
    "QU": Spec(((0, 255),), 1, reply="data_ok"),
    "QE": Spec((), 0, reply="data_ok", ending="\n\r"),
    "QR": Spec((), 0, reply="data_ok", ending="\n\r"),
    "QM": Spec((), 0, reply="data", ending="\n\r"),
    "QT": Spec((), 0, reply="data_ok"),
    "ST": Spec(((0, 16),), 0, kinds="s"),  # the board's name (nickname), at most 16 characters
    "QC": Spec((), 0, reply="data_ok"),
    "QL": Spec(((0, 255),), 0, reply="data_ok"),
    "SL": Spec(((0, 255), (0, 255)), 1),
    "QN": Spec((), 0, reply="data_ok"),
    "SN": Spec((_UINT32,), 1),
    "NI": Spec((), 0),
    "ND": Spec((), 0),
    "PI": Spec(((0, 255), (0, 255)), 2, reply="data", kinds="ci"),
    "PO": Spec(((0, 255), (0, 255), (0, 255)), 3, kinds="cii"),
    "PD": Spec(((0, 255), (0, 255), (0, 255)), 3, kinds="cii"),
    "S2": Spec((_UINT16, (0, 255), _UINT16, _UINT16), 0, queued=True),
    "T3": Spec((_UINT32, *[_INT32] * 6, _UINT32), 7, queued=True),
    "TD": Spec((_UINT32, *[_INT32] * 8, _UINT32), 9, queued=True),
    "RB": Spec((), 0),
}
#: Replies whose legacy form repeats the command's name (``QM,0,0,0,0``, ``QU,32``).
NAMED_LEGACY = ("QM", "QU", "PI")

_ERRORS = {4: "Missing parameter(s)", 6: "Invalid parameter value", 7: "Extra parameter"}
_NUMBER = re.compile(r"^[-+]?\d+$")


@dataclass(frozen=True)
class Command:
    """A parsed command: upper-case ``name`` and integer ``args``."""

    name: str
    args: tuple = ()  # numbers; a port letter (PI, PO, PD) or the name (ST) as text

    @property
    def queued(self) -> bool:
        """Goes through the motion FIFO (SP 2/3 bypass it)."""
        return COMMANDS[self.name].queued and not (self.name == "SP" and self.args[0] >= 2)


class CommandError(ProtocolError):
    """The board refused a command: ``code`` (EBB's ``!N``) and its text."""

    def __init__(self, name: str, code: int, text: str):
        super().__init__(f"!{code} Err: {text}")
        self.name, self.code, self.text = name, code, text


def encode(name: str, *args: int) -> bytes:
    """The bytes of one command, e.g. ``encode("SM", 100, 20, -5)`` → ``b"SM,100,20,-5\\r"``.

    Raises
    ------
    ProtocolError
        Unknown command, wrong argument count, a value out of range, or longer than 256 bytes.
    """
    text = ",".join([name.upper(), *(str(int(a)) for a in args)])
    parse_command(text)  # the board's own checks, before anything is sent
    data = text.encode("ascii") + b"\r"
    if len(data) > MAX_COMMAND:
        raise ProtocolError(f"EBB command {text[:20]}... is {len(data)} bytes; the board takes {MAX_COMMAND}")
    return data


def parse_command(text: str) -> Command:
    """Parse one command line (without its CR) the way the EBB does.

    Raises
    ------
    CommandError
        ``!8`` unknown command, ``!4`` missing parameter, ``!6`` invalid value (out of range or
        not a number), ``!7`` extra parameter.
    """
    parts = text.strip("\r\n").split(",")
    name = parts[0].upper()
    if name not in COMMANDS:
        code = "".join(f"{ord(c):02X}" for c in name[:2])
        raise CommandError(name, 8, f"Unknown command '{name[:2]}:{code}'")
    spec = COMMANDS[name]
    raw = parts[1:]
    if len(raw) < spec.required:
        raise CommandError(name, 4, _ERRORS[4])
    if len(raw) > len(spec.ranges):
        raise CommandError(name, 7, _ERRORS[7])
    if spec.kinds == "s":  # text: everything after the first comma, commas and all
        text_arg = text.strip("\r\n").split(",", 1)[1] if len(parts) > 1 else ""
        return Command(name, (text_arg[: spec.ranges[0][1]],))
    args: list = []
    for i, (value, (low, high)) in enumerate(zip(raw, spec.ranges)):
        if spec.kinds[i : i + 1] == "c":  # a port letter, taken upper-case (checked by the command)
            if len(value) != 1:
                raise CommandError(name, 6, _ERRORS[6])
            args.append(value.upper())
            continue
        if not _NUMBER.match(value) or not low <= int(value) <= high:
            raise CommandError(name, 6, _ERRORS[6])
        args.append(int(value))
    if name == "HM" and len(args) == 2:  # Position1 needs Position2
        raise CommandError(name, 4, _ERRORS[4])
    if (name == "SM" and args[0] == 0) or (name == "XM" and args[0] == 0):
        raise CommandError(name, 6, _ERRORS[6])
    return Command(name, tuple(args))


# --- replies: the board writes them (the simulator), a sender reads them (the driver) -----------


def format_reply(name: str, data: str | None, *, future: bool, old: bool = False) -> bytes:
    """What the board sends back after command ``name`` with reply ``data`` (None: none);
    ``old``: firmware 2.x, whose ``QR`` ends its data ``\\r\\n``."""
    spec = COMMANDS[name]
    if future:
        return f"{name},{data}\n".encode() if data is not None else f"{name}\n".encode()
    if spec.reply == "ok" or data is None:
        return b"OK\r\n"
    text = f"{name},{data}" if name in NAMED_LEGACY else data
    ending = "\r\n" if old and name == "QR" else spec.ending
    if spec.reply == "data":
        return f"{text}{ending}".encode()
    return f"{text}{ending}OK\r\n".encode()


def format_error(error: CommandError, *, future: bool) -> bytes:
    """An error reply in either syntax."""
    return (f"{error.name},{error}\n" if future else f"{error}\r\n").encode("ascii", "replace")


def syntax_switch_reply(on: bool, *, future: bool) -> bytes:
    """The odd reply to ``CU,10,n`` (the reply is made half before, half after the switch)."""
    if on and not future:
        return b"\n"
    if not on and future:
        return b"CUOK\r\n"
    return b"CU\n" if future else b"OK\r\n"


@dataclass(frozen=True)
class Reply:
    """A whole reply read back: ``data`` (None for a plain acknowledgement) or an ``error``."""

    data: str | None = None
    error: str | None = None


def reply_lines(name: str, *, future: bool) -> int:
    """How many non-empty lines a successful reply to ``name`` takes (a sender reads this many)."""
    spec = COMMANDS[name]
    if future or spec.reply in ("ok", "data"):
        return 1
    return 2


def read_reply(name: str, lines: list[str], *, future: bool) -> Reply:
    """Interpret the non-empty lines of a reply to ``name`` (see :func:`reply_lines`).

    Either syntax is accepted whatever ``future`` says when the shape is unambiguous, so a board
    left in the other mode is recognised instead of misread.
    """
    first = lines[0].strip("\r\n")
    if "Err:" in first:
        return Reply(error=first.split(",", 1)[1] if first.startswith(f"{name},") else first)
    if first == name:  # future syntax, no data
        return Reply()
    if first.startswith(f"{name},") and (future or name not in NAMED_LEGACY):
        return Reply(data=first[len(name) + 1 :])
    if first in ("OK", "CUOK"):
        return Reply()
    if name in NAMED_LEGACY and first.startswith(f"{name},"):
        return Reply(data=first[len(name) + 1 :])
    return Reply(data=first)


#: What the data line of a legacy reply looks like, per query (anything else is line noise).
_DATA = {
    name: re.compile(pattern)
    for name, pattern in {
        "QG": r"[0-9A-Fa-f]{2}",
        "QS": r"-?\d+,-?\d+",
        "QE": r"\d+,\d+",
        "ES": r"[01](,\d+){4}|[01]",
        "QP": r"[01]",
        "QC": r"\d+,\d+",
        "QL": r"\d+",
        "QN": r"\d+",
        "PI": r"PI,[01]",
        "QB": r"[01]",
        "QR": r"[01]",
        "V": r"EBB.*|UBW.*",
        "QM": r"QM,\d,\d,\d,\d",
        "QU": r"QU,.*",
    }.items()
}


def plausible(name: str, line: str, *, future: bool) -> bool:
    """Whether ``line`` can be part of the reply to ``name`` (noise on the wire is not)."""
    if "Err:" in line or line == name or line.startswith(f"{name},") or line in ("OK", "CUOK"):
        return True
    if future or COMMANDS[name].reply == "ok":
        return False
    pattern = _DATA.get(name)
    return bool(pattern.fullmatch(line)) if pattern is not None else True


def lm_rate(step_hz: float) -> int:
    """LM's Rate for a step frequency (Hz), rounded."""
    return int(round(step_hz * RATE_PER_HZ))


def lm_ticks(steps: int, rate: int, accel: int, carry: int = 0) -> int:
    """40 µs ticks until an LM axis has taken ``steps`` (>0) steps: the least T with
    ``carry + rate·T + accel·T²/2 ≥ steps·2³¹``; -1 if it never gets there (it stalls)."""
    need = steps * ACCUMULATOR - carry
    if need <= 0:
        return 0
    if accel == 0:
        return -1 if rate <= 0 else math.ceil(need / rate)
    disc = rate * rate + 2.0 * accel * need
    if disc < 0:
        return -1
    t = (-rate + math.sqrt(disc)) / accel
    if t < 0:
        return -1
    t = max(math.floor(t) - 1, 0)
    peak = -rate / accel if accel < 0 else math.inf  # a slowing axis covers less after this tick
    while rate * t + accel * t * t / 2 < need:  # exact integers from the float's neighbourhood
        if t > peak:
            return -1  # the float said it just gets there; the exact ticks fall short: it stalls
        t += 1
    return t


def lm_steps_at(t: int, steps: int, rate: int, accel: int, carry: int = 0) -> int:
    """Steps an LM axis has taken after ``t`` ticks (at most ``steps``)."""
    return min(steps, max(int((carry + rate * t + accel * t * t // 2) // ACCUMULATOR), 0))


def servo_travel_seconds(start: int, end: int, rate: int) -> float:
    """Seconds the servo signal takes from position ``start`` to ``end`` at ``rate`` units per
    24 ms (0: at once), the EBB reference's FAQ formula."""
    if rate <= 0 or start == end:
        return 0.0
    return math.ceil(abs(end - start) / rate) * SERVO_PERIOD
