"""HP-GL (HP 7470A / 7475A / 7440A, Roland DXY in RD-GL mode): pure grammar, no I/O.

Two kinds of bytes go to such a plotter over RS-232:

* **HP-GL instructions** — a two-letter mnemonic, parameters separated by commas (or spaces),
  ended by ``;`` (or by the next mnemonic): ``IN;SP1;PU400,400;PD800,400,800,800;``. They go
  into the plotter's input buffer (1024 bytes on a 7475A) and run in order; coordinates are
  plotter units of 0.025 mm. Output instructions (``OI``, ``OA``, ``OS``, ``OE``) are buffered
  too, so their answer comes once everything before them has run: ``OA;`` is a sync point.
* **Device-control sequences** — ``ESC . <letter>`` (some with parameters ended by ``:``). They
  bypass the buffer and act at once: ``ESC.B`` answers the free buffer bytes, ``ESC.E`` the
  extended (I/O) error, ``ESC.O`` the extended status, ``ESC.R`` resets the handshake, ``ESC.K``
  aborts the graphics (the buffer is discarded), ``ESC.J`` aborts a device-control sequence.

Answers are decimal fields separated by commas, ended by the output terminator (CR by
default). Flow control is by polling ``ESC.B`` (or XON/XOFF, which many USB adapters mishandle).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from firmware_protocol import ProtocolError

#: One plotter unit, mm (HP 7475A metric: 40 units per mm).
UNIT_MM = 0.025
ESC = b"\x1b"
#: Device-control sequences (``ESC . letter``): answered or acted upon at once, never buffered.
BUFFER_SPACE = b"\x1b.B"  # answer: free bytes of the input buffer
EXTENDED_ERROR = b"\x1b.E"  # answer: the RS-232 error code (and clears it)
EXTENDED_STATUS = b"\x1b.O"  # answer: status bits (8: buffer empty, 16: view, 32: paper lever up)
RESET_HANDSHAKE = b"\x1b.R"  # handshake settings to their defaults
ABORT_GRAPHICS = b"\x1b.K"  # the buffer's instructions are discarded
ABORT_DEVICE_CONTROL = b"\x1b.J"  # a partial device-control sequence is dropped
#: Device-control letters that take ``;``-separated parameters ended by ``:``.
PARAMETER_SEQUENCES = frozenset(b"@HIMNPS")
#: Device-control letters the 7475A answers or acts on without parameters.
PLAIN_SEQUENCES = frozenset(b"ABEJKLORYZ()")
XON, XOFF = 0x11, 0x13
TERMINATOR = b"\r"  # the default output terminator
LABEL_END = b"\x03"  # ETX ends an LB label's text
MAX_COORDINATE = 32767  # the 7475A's parameter range for coordinates

#: OE error codes (HP-GL errors; OS bit 32 is set while one is pending).
ERRORS = {
    0: "no error",
    1: "instruction not recognised",
    2: "wrong number of parameters",
    3: "out-of-range parameters",
    5: "unknown character set",
    6: "position overflow",
}
#: ESC.E extended (I/O) error codes.
IO_ERRORS = {
    0: "no I/O error",
    10: "output instruction received while another output is pending",
    11: "invalid byte received after first two characters, ESC.",
    12: "invalid byte received while parsing a device control instruction",
    13: "parameter out of range",
    14: "too many parameters received",
    15: "framing, parity or overrun error",
    16: "input buffer overflow",
}
#: OS status bits.
STATUS_PEN_DOWN = 1
STATUS_P1P2_CHANGED = 2
STATUS_INITIALIZED = 8
STATUS_READY = 16  # paper loaded (the lever is down)
STATUS_ERROR = 32

_MNEMONIC = re.compile(rb"[A-Za-z]{2}")
_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)")
_SEPARATORS = b", \t\r\n"


@dataclass(frozen=True)
class Instruction:
    """One HP-GL instruction: its mnemonic (upper case) and numeric parameters.

    ``text`` holds an ``LB`` label's characters (without the ETX); other instructions have none.
    """

    mnemonic: str
    params: tuple[float, ...] = ()
    text: str = ""

    def encode(self) -> bytes:
        """The instruction as a plotter reads it (``PD120,40;``)."""
        return encode(self.mnemonic, *self.params, text=self.text)


def encode(mnemonic: str, *params: float, text: str = "") -> bytes:
    """``MN p1,p2,...;`` — integers written without a decimal point.

    Raises
    ------
    ProtocolError
        The mnemonic is not two letters.
    """
    if not (len(mnemonic) == 2 and mnemonic.isascii() and mnemonic.isalpha()):
        raise ProtocolError(f"an HP-GL mnemonic is two letters, not {mnemonic!r}")
    if mnemonic.upper() == "LB":
        return b"LB" + text.encode("ascii") + LABEL_END
    body = ",".join(str(int(p)) if float(p).is_integer() else f"{p:.4f}".rstrip("0") for p in params)
    return f"{mnemonic.upper()}{body};".encode("ascii")


def split_instructions(
    data: bytes, *, final: bool = True, limit: int | None = None
) -> tuple[list[Instruction], int]:
    """Parse HP-GL instructions from ``data`` (no device-control sequences in it).

    Parameters
    ----------
    data : bytes
        Instruction bytes as a plotter's buffer holds them.
    final : bool
        True: ``data`` is everything there is (a file), so an instruction may end at the end.
        False: more may come (a buffer being filled), so the last instruction counts only once
        its ``;`` or the next mnemonic arrived.
    limit : int, optional
        Stop after this many instructions (a plotter takes one at a time from its buffer).

    Returns
    -------
    (list of Instruction, int)
        The complete instructions and how many bytes of ``data`` they took.

    Raises
    ------
    ProtocolError
        A byte that cannot start an instruction, or a parameter that is not a number.
    """
    out: list[Instruction] = []
    at, n = 0, len(data)
    while at < n and (limit is None or len(out) < limit):
        byte = data[at]
        if byte in _SEPARATORS or byte == ord(";"):
            at += 1
            continue
        head = _MNEMONIC.match(data, at)
        if head is None:
            if not final and at + 1 >= n and chr(byte).isalpha():
                break  # half a mnemonic so far
            raise ProtocolError(f"byte {at}: {data[at : at + 8]!r} does not start an HP-GL instruction")
        mnemonic = head.group().decode().upper()
        body_start = head.end()
        if mnemonic == "LB":
            stop = data.find(LABEL_END, body_start)
            if stop < 0:
                if final:
                    raise ProtocolError(f"byte {at}: label without its end (ETX)")
                break
            out.append(Instruction("LB", (), data[body_start:stop].decode("ascii", errors="replace")))
            at = stop + 1
            continue
        end = body_start
        while end < n and not (data[end] == ord(";") or chr(data[end]).isalpha()):
            end += 1
        if end >= n and not final:
            break  # the parameters may go on
        out.append(Instruction(mnemonic, parse_params(data[body_start:end], where=at)))
        at = end + 1 if end < n and data[end] == ord(";") else end
    return out, at


def parse_params(body: bytes, *, where: int = 0) -> tuple[float, ...]:
    """Numbers separated by commas or spaces (``+`` allowed); an empty body has none."""
    tokens = [t for t in re.split(rb"[,\s]+", body.strip()) if t]
    values = []
    for token in tokens:
        if not _NUMBER.fullmatch(token):
            raise ProtocolError(f"byte {where}: parameter {token!r} is not a number")
        values.append(float(token))
    return tuple(values)


def split_device_control(data: bytes) -> tuple[list[tuple[bytes, bytes]], bytes, int]:
    """Take the device-control sequences out of a byte stream.

    Returns
    -------
    (list of (bytes, bytes), bytes, int)
        Each sequence as ``(letter, parameters)`` in order; the other bytes (instructions);
        and how many bytes at the end are an unfinished sequence (kept for the next call).
    """
    sequences: list[tuple[bytes, bytes]] = []
    rest = bytearray()
    at, n = 0, len(data)
    while at < n:
        esc = data.find(ESC, at)
        if esc < 0:
            rest += data[at:]
            break
        rest += data[at:esc]
        if esc + 2 >= n:
            return sequences, bytes(rest), n - esc
        if data[esc + 1] != ord("."):
            at = esc + 1  # a lone ESC: dropped, as the plotter drops it
            continue
        letter = data[esc + 2]
        if letter in PARAMETER_SEQUENCES:
            stop = data.find(b":", esc + 3)
            if stop < 0:
                return sequences, bytes(rest), n - esc
            sequences.append((bytes([letter]), data[esc + 3 : stop]))
            at = stop + 1
        else:
            sequences.append((bytes([letter]), b""))
            at = esc + 3
    return sequences, bytes(rest), 0


def parse_answer(text: str) -> tuple[int, ...]:
    """The integers of an answer (``"1024"``, ``"400,300,1"``).

    Raises
    ------
    ProtocolError
        The answer is not comma-separated integers.
    """
    fields = [f.strip() for f in text.strip().split(",")]
    try:
        return tuple(int(float(f)) for f in fields)
    except ValueError:
        raise ProtocolError(f"not a numeric HP-GL answer: {text!r}") from None


def to_units(mm: float) -> int:
    """Millimetres to whole plotter units (rounded to the nearest)."""
    return int(round(mm / UNIT_MM))
