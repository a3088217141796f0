"""HP-GL pen plotters (HP 7470A / 7475A / 7440A, Roland DXY in RD-GL mode).

No acknowledgements: a sender polls the free bytes of the plotter's input buffer (``ESC.B``) and
never writes more than that; ``OA;`` (output the actual position) is answered only once every
instruction before it has run, so it is the sync point that says a job is drawn and where the
pen is. ``ESC.K`` discards the buffer (a stop); the plotter knows its absolute position (it
homes at power-up), so after a stop the pen is where ``OA;`` says.

A program is read into :class:`Program`: one instruction per move (``PU x,y;`` / ``PD x,y;``,
absolute plotter units), with the pen position, pen state and carousel pen after each, so the
driver can say what ran from what the buffer still holds and resume after it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from firmware_protocol import ProtocolError
from firmware_protocol import hpgl as protocol
from pencilbot.firmware.base import OTHER, STATUS, Capabilities, Firmware, Reply
from pencilbot.paths import Paths

#: File names HP-GL goes by (the first is the one export gives).
HPGL_SUFFIXES = (".hpgl", ".hpg", ".plt", ".hgl")
#: How an HP-GL program starts (after device-control escapes and blanks): a two-letter
#: instruction then its terminator or its first number; G-code starts with a letter and a number.
_HPGL_START = re.compile(rb"^(?:\x1b\.[^:;]*[:;]?|\s)*[A-Z]{2}\s*(?:;|-?\d|\n|$)", re.IGNORECASE)


def looks_like_hpgl(path) -> bool:
    """Whether the file at ``path`` is HP-GL by its name or, failing that, its first bytes."""
    from pathlib import Path

    path = Path(path)
    if path.suffix.lower() in HPGL_SUFFIXES:
        return True
    try:
        with open(path, "rb") as handle:
            head = handle.read(256)
    except OSError:
        return False
    return bool(_HPGL_START.match(head))


#: The longest HP-GL file read (bytes), whole: a plot of a million pen moves is about 20 MB.
MAX_HPGL_FILE = 256 << 20
#: The highest pen number (HP-GL's integers are 16-bit) and speed (``VS``, cm/s: the 7475A's
#: fastest is 38.1; HP-GL's range ends below 128).
MAX_PEN = 32767
MAX_SPEED = 128.0
#: Instructions a sender may pass on unchanged: they set nothing the moves depend on.
_PASSED = {"DF", "PS", "OI", "OS", "OE", "OA", "OH", "OP", "OW", "OC", "CS", "CA", "SS", "SA", "LT", "DT"}
#: Instructions that change how coordinates map to the paper or draw shapes: not translated.
_REFUSED = {
    "SC": "user scaling",
    "IP": "scaling points",
    "IW": "a window",
    "RO": "rotation",
    "AA": "arcs",
    "AR": "arcs",
    "CI": "circles",
    "LB": "labels",
    "EA": "rectangles",
    "ER": "rectangles",
    "RA": "filled rectangles",
    "RR": "filled rectangles",
    "EW": "wedges",
    "WG": "wedges",
    "FT": "fill types",
    "PT": "fill spacing",
    "XT": "ticks",
    "YT": "ticks",
    "TL": "ticks",
    "SM": "symbol mode",
    "PM": "polygons",
}


@dataclass(frozen=True)
class Program:
    """An HP-GL program as the sender streams it: one instruction per entry.

    Attributes
    ----------
    frames : list of bytes
        Each instruction's bytes (``PD400,400;\\n``).
    offsets : (n + 1,) int array
        Cumulative byte offsets of the frames in the stream.
    xy : (n, 2) int array
        Pen position after each instruction, plotter units.
    down : (n,) bool array
        Pen on the paper after each instruction.
    pen : (n,) int array
        Carousel pen held after each instruction (0: none).
    speed : (n,) float array
        ``VS`` pen-down speed in force after each instruction, cm/s (0: the plotter's top).
    lines : (n,) int array
        Instruction number in the file (1-based) that each entry comes from.
    """

    frames: list[bytes]
    offsets: np.ndarray
    xy: np.ndarray
    down: np.ndarray
    pen: np.ndarray
    speed: np.ndarray
    lines: np.ndarray

    def __len__(self) -> int:
        return len(self.frames)

    def preamble(self, start: int, at: tuple[int, int] | None = None) -> bytes:
        """What brings a freshly initialised plotter to the state before entry ``start``:
        ``IN;``, the pen, the speed, and a pen-up move to where the pen was (or to ``at``, a
        point on entry ``start``'s move where it stopped)."""
        out = [b"IN;"]
        if start > 0:
            i = start - 1
            if self.pen[i]:
                out.append(protocol.encode("SP", int(self.pen[i])))
            if self.speed[i]:
                out.append(protocol.encode("VS", float(self.speed[i])))
            x, y = at if at is not None else (int(self.xy[i, 0]), int(self.xy[i, 1]))
            out.append(protocol.encode("PU", x, y))
        return b"".join(out) + b"\n"

    def in_carousel(self, slots: int) -> tuple[Program, dict[int, str]]:
        """The program for a carousel of ``slots`` pens, and the pen changes it needs.

        A pen beyond the carousel (``SP n``, ``n > slots``) is selected from slot
        ``(n - 1) mod slots + 1``, after someone has put it there by hand; so is a pen whose slot
        another pen took meanwhile. Returns the program that selects only slots (the pen array
        holds slots too) and ``{entry: prompt}``: before each such ``SP`` entry a pause.
        """
        if not len(self) or int(self.pen.max()) <= slots:
            return self, {}
        holds = {k: k for k in range(1, slots + 1)}  # slot -> the pen in it
        frames, changes = list(self.frames), {}
        slot = np.where(self.pen > 0, (self.pen - 1) % slots + 1, 0)
        for i, frame in enumerate(frames):
            if not frame.startswith(b"SP") or not self.pen[i]:
                continue
            pen, k = int(self.pen[i]), int(slot[i])
            if holds[k] != pen:
                changes[i] = f"pen change: put pen {pen} in carousel slot {k} (in place of pen {holds[k]})"
                holds[k] = pen
            frames[i] = protocol.encode("SP", k) + b"\n"
        lengths = np.fromiter(map(len, frames), dtype=np.int64, count=len(frames))
        return replace(
            self, frames=frames, offsets=np.concatenate([[0], np.cumsum(lengths)]), pen=slot
        ), changes

    def drawn(self) -> tuple[Paths, np.ndarray]:
        """The pen-down polylines (plotter units) and the carousel pen of each, in order."""
        if not len(self):
            return Paths.empty(), np.zeros(0, np.int64)
        down = self.down
        before = np.concatenate([[False], down[:-1]])
        previous = np.vstack([[0, 0], self.xy[:-1]])  # the plotter starts at 0,0
        moved = np.any(self.xy != previous, axis=1)
        starts = down & ~before  # the pen goes down here: where it stood (a PD x,y then moves)
        drawn = down & moved  # and moves to each of these points
        # Sort keys: 2i for the point the pen touches down at, 2i + 1 for where entry i moves to.
        keys = np.concatenate([2 * np.flatnonzero(starts), 2 * np.flatnonzero(drawn) + 1])
        points = np.concatenate([previous[starts], self.xy[drawn]])
        order = np.argsort(keys, kind="stable")
        keys, points = keys[order], points[order].astype(np.float64)
        if not len(points):
            return Paths.empty(), np.zeros(0, np.int64)
        first = np.flatnonzero(keys % 2 == 0)
        return Paths(points, np.append(first, len(points))), self.pen[keys[first] // 2]


class Hpgl(Firmware):
    """An HP-GL plotter on RS-232, flow-controlled by polling ``ESC.B``."""

    name = "hpgl"
    title = "HP-GL"
    protocol = protocol
    capabilities = Capabilities()
    receive_buffer = 1024  # the HP 7475A's input buffer, bytes (ESC.B on an idle plotter)
    baud = 9600  # RS-232 plotters' usual speed (the 7475A's DIP switches allow 75..9600)
    line_limit = 1024
    rapids_take_feed = True  # pen-up moves run at the plotter's top speed (the profile's travel feed)
    wake_bytes = protocol.ABORT_DEVICE_CONTROL + protocol.EXTENDED_ERROR  # a clean parser, no stale I/O error
    #: How a sender streams to this firmware: poll the free buffer bytes, no acknowledgements.
    flow = "polled"
    program_language = "hpgl"
    #: Which board the virtual plotter plays for profiles of this firmware.
    sim_board = "hpgl"
    identify_command = b"OI;"
    free_query = protocol.BUFFER_SPACE
    sync_command = b"OA;"
    #: Answered once everything before it ran, with the status byte; its ``initialised`` bit is
    #: set by a power-up (or reset) and by ``IN``, and cleared once output (HP 7470A manual, OS).
    status_command = b"OS;"
    initialised_bit = protocol.STATUS_INITIALIZED
    abort_bytes = protocol.ABORT_GRAPHICS
    lift_command = b"PU;"
    #: Bytes of the input buffer never filled: a 7475A filled to exactly the free space ESC.B
    #: reported overflowed (ESC.E 16) while 4 bytes of slack did not (hpgl-buddy's hardware
    #: notes); the manual says to allow room for the overshoot, and the plotter's own XON
    #: threshold is 128 bytes. A small buffer keeps an eighth of itself.
    buffer_reserve = 128

    def reserve(self, size: int) -> int:
        """Bytes of a ``size``-byte buffer a sender leaves free."""
        return min(self.buffer_reserve, size // 8)

    park_command = b"PU;SP0;"

    def frame(self, command: str, number: int = 0) -> bytes:
        return command.encode("ascii")

    def parse(self, text: str) -> Reply:
        try:
            return Reply(STATUS, text, status=protocol.parse_answer(text))
        except ProtocolError:
            return Reply(OTHER, text)

    def parse_free(self, text: str) -> int | None:
        """Free buffer bytes from an ``ESC.B`` answer (None if it is not one)."""
        try:
            values = protocol.parse_answer(text)
        except ProtocolError:
            return None
        return values[0] if len(values) == 1 and 0 <= values[0] <= 1 << 16 else None

    def parse_position(self, text: str) -> tuple[int, int, bool] | None:
        """``(x, y, pen down)`` in plotter units from an ``OA;`` answer (None if it is not one)."""
        try:
            values = protocol.parse_answer(text)
        except ProtocolError:
            return None
        return (values[0], values[1], bool(values[2])) if len(values) == 3 and values[2] in (0, 1) else None

    def parse_status(self, text: str) -> int | None:
        """The status byte from an ``OS;`` answer (None if it is not one)."""
        try:
            values = protocol.parse_answer(text)
        except ProtocolError:
            return None
        return values[0] if len(values) == 1 and 0 <= values[0] <= 255 else None

    def is_identity(self, text: str) -> bool:
        """An ``OI;`` answer: a model number such as ``7475A``."""
        text = text.strip()
        return 0 < len(text) <= 16 and text[:1].isdigit() and text.replace("-", "").isalnum()

    def program(self, data: bytes) -> Program:
        """Read an HP-GL program into single-move instructions (see :class:`Program`).

        Raises
        ------
        ProtocolError
            A byte that is not HP-GL, or an instruction this sender does not translate (it
            names the instruction and what it is for).
        """
        _, data, _ = protocol.split_device_control(data)
        instructions, _ = protocol.split_instructions(data, final=True)
        return _Interpreter().run(instructions)


def _whole(value: float, low: int, high: int, what: str) -> int:
    """``value`` as a whole number from ``low`` to ``high``, else a ProtocolError naming ``what``."""
    if not (low <= value <= high and float(value).is_integer()):
        raise ProtocolError(f"{what} {value:g} is not a whole number from {low} to {high}")
    return int(value)


class _Interpreter:
    """Follow pen position, pen state, absolute/relative mode, carousel pen and speed."""

    def __init__(self) -> None:
        self.x = self.y = 0
        self.down = False
        self.relative = False
        self.pen = 0
        self.speed = 0.0
        self.rows: list[tuple[bytes, int, int, bool, int, float, int]] = []

    def _emit(self, frame: bytes, number: int) -> None:
        self.rows.append((frame, self.x, self.y, self.down, self.pen, self.speed, number))

    def run(self, instructions) -> Program:
        for number, ins in enumerate(instructions, start=1):
            self.step(ins, number)
        rows = self.rows
        frames = [r[0] + b"\n" for r in rows]
        lengths = np.fromiter(map(len, frames), dtype=np.int64, count=len(frames))
        return Program(
            frames=frames,
            offsets=np.concatenate([[0], np.cumsum(lengths)]),
            xy=np.array([(r[1], r[2]) for r in rows], dtype=np.int64).reshape(-1, 2),
            down=np.array([r[3] for r in rows], dtype=bool),
            pen=np.array([r[4] for r in rows], dtype=np.int64),
            speed=np.array([r[5] for r in rows], dtype=np.float64),
            lines=np.array([r[6] for r in rows], dtype=np.int64),
        )

    def step(self, ins, number: int) -> None:
        m, p = ins.mnemonic, ins.params
        if m in _REFUSED:
            raise ProtocolError(
                f"instruction {number} ({m}: {_REFUSED[m]}) is not translated by pencilbot's HP-GL sender; "
                "convert the drawing to lines first (e.g. vpype read … write --device hp7475a)"
            )
        if m == "IN":
            self.down, self.relative, self.speed = False, False, 0.0
            self._emit(b"IN;", number)
        elif m == "SP":
            self.pen = _whole(p[0], 0, MAX_PEN, f"instruction {number} (SP): pen") if p else 0
            self.down = False  # a pen is taken (or put away) lifted
            self._emit(protocol.encode("SP", self.pen), number)
        elif m == "VS":
            if p and not 0 < p[0] <= MAX_SPEED:
                raise ProtocolError(
                    f"instruction {number} (VS): speed {p[0]:g} cm/s is not one a plotter takes "
                    f"(more than 0, at most {MAX_SPEED:g})"
                )
            self.speed = float(p[0]) if p else 0.0
            self._emit(protocol.encode("VS", *p[:1]), number)
        elif m in ("PA", "PR"):
            self.relative = m == "PR"
            self._moves(p, number)
        elif m in ("PU", "PD"):
            self.down = m == "PD"
            if not p:
                self._emit(protocol.encode(m), number)
            self._moves(p, number)
        elif m in _PASSED:
            self._emit(ins.encode(), number)
        else:
            raise ProtocolError(f"instruction {number} ({m}) is not HP-GL this sender knows")

    def _moves(self, p, number: int) -> None:
        if len(p) % 2:
            raise ProtocolError(f"instruction {number}: an odd number of coordinates ({len(p)})")
        word = "PD" if self.down else "PU"
        for k in range(0, len(p), 2):
            if not max(abs(p[k]), abs(p[k + 1])) <= protocol.MAX_COORDINATE:  # (NaN and inf too)
                raise ProtocolError(
                    f"instruction {number}: coordinate {p[k]:g},{p[k + 1]:g} is beyond "
                    f"±{protocol.MAX_COORDINATE}"
                )
            x, y = round(p[k]), round(p[k + 1])
            if self.relative:
                x, y = self.x + x, self.y + y
            if max(abs(x), abs(y)) > protocol.MAX_COORDINATE:
                raise ProtocolError(
                    f"instruction {number}: coordinate {x},{y} is beyond ±{protocol.MAX_COORDINATE}"
                )
            self.x, self.y = x, y
            self._emit(protocol.encode(word, x, y), number)


HPGL = Hpgl()
