"""A virtual HP-GL pen plotter (HP 7475A): an input buffer that fills, a carousel, paper limits.

What a sender meets on the real machine:

* Instruction bytes go into a buffer of the profile's ``receive_buffer`` bytes (1024 on a 7475A).
  A byte that arrives when it is full is lost and ``ESC.E`` reports error 16 (buffer overflow),
  as on the real plotter: a sender must poll ``ESC.B`` (free bytes) and never write more.
  Optional XON/XOFF (``xonxoff``): XOFF when fewer than 80 bytes are free, XON at 128 again.
* Device-control sequences act at once, whatever the buffer holds: ``ESC.B`` free bytes,
  ``ESC.L`` the buffer's size,
  ``ESC.E`` the I/O error (then cleared), ``ESC.O`` extended status (8: buffer empty and idle),
  ``ESC.K`` discards the buffer (the vector being drawn is finished), ``ESC.R`` / ``ESC.J``.
* Instructions run in order: ``IN SP PU PD PA PR VS``, circles, arcs and edged rectangles
  (:mod:`sim.hpgl.shapes`), the settings, and the outputs ``OI OA OC OD OF OO OS OE OH OP OW``
  (answered once everything before them ran, CR-terminated); a move's pairs run as they arrive,
  so one instruction may be longer than the buffer. Any 7475A instruction whose drawing is not
  emulated (labels, fills, scaling) is counted in ``unemulated``. A move beyond the hard-clip
  limits (the profile's bed), an unknown instruction or a wrong parameter count is not run and
  sets the ``OE`` error (3, 1, 2), which ``OS`` shows as bit 32. ``OS`` bit 8 (initialised) is
  set by a power-up (or reset) and by ``IN``, and cleared once ``OS`` has output it, as on the
  real plotter (HP 7470A manual, "The Output Status Instruction"): a sender reads it to learn
  that the plotter lost its place.
* Time: every vector is a rest-to-rest trapezoid of the shared motion model (pen down at the
  ``VS`` speed, pen up at the profile's travel speed), a pen lift or drop costs the profile's
  delay; ``realtime=0`` runs it all at once (the clock still counts), ``r > 0`` runs r times
  faster than real time, so the buffer fills as on hardware.
* Time on the poll clock (``tick=t``): each ``ESC.B`` answered lets ``t`` plotter seconds pass,
  and nothing else does, so a sender that polls as it waits finds the plotter at the same place
  every run, whatever the host's speed (what the fault tests use).
* Faults (``KIND@K``, K the 1-based count of executed instructions): ``drop`` (or ``unplug``:
  the plotter has its own mains supply) pulls the RS-232 cable, ``reset`` is a power cycle
  (buffer lost, pen home and put away), ``silent`` loses the next answer, ``garbage`` sends a
  line of noise, ``interrupt[:SIGNAL]`` has the sender's process get SIGNAL (default SIGINT:
  Ctrl-C) as the plotter starts instruction K.

Pen-down vectors are recorded as polylines in machine mm, the way the GRBL simulator records
them, so the same renderer draws both.
"""

from __future__ import annotations

import math

import numpy as np

from firmware_protocol import ProtocolError
from firmware_protocol import hpgl as protocol
from pencilbot.machine.motion import block_duration
from pencilbot.paths import Paths
from sim.hpgl import shapes as hpgl_shapes

MODEL = "7475A"
_XOFF_BELOW, _XON_AT = 80, 128
_GARBAGE = b"\xfe#%\x07?!\r"


class HpglBoard:
    """The plotter's firmware and mechanism (``firmware`` and ``machine`` of its plotter)."""

    #: RS-232 has no auto-reset: opening the port leaves the plotter as it is.
    resets_on_open = False

    def __init__(self, profile, *, faults=None, xonxoff: bool = False):
        self.profile = profile
        self.size = profile.receive_buffer
        self.faults = faults
        self.xonxoff = xonxoff
        self.unit = profile.paper.unit_mm
        self.limits = (
            0,
            0,
            int(round(profile.bed.width / self.unit)),
            int(round(profile.bed.height / self.unit)),
        )
        self.top_speed = profile.motion.travel_speed  # mm/s
        self.link_dropped = False
        self.out = bytearray()
        self.max_fill = 0
        self.overflows = 0
        self.executed = 0  # instructions run since the first power-on (faults count these)
        self.log: list[str] = []
        self.clock = 0.0  # simulated seconds of motion and pen action
        self._strokes: list[np.ndarray] = []
        self._stroke_pens: list[int] = []
        self._stroke: list[tuple[float, float]] = []
        self._travel: list[np.ndarray] = []
        self._silent_next = False
        self.pauses = 0  # pen changes (the colour preview's "which pen drew it")
        self.polls = 0  # ESC.B answered (the poll clock counts them)
        self.discarded = 0  # bytes ESC.K threw away
        self.unemulated: dict[str, int] = {}  # instructions the 7475A knows whose drawing is not emulated
        self.signal_due: int | None = None  # an interrupt@ fault's signal, for the host side
        self.power_cycle(first=True)

    # --- power and buffer --------------------------------------------------------------

    def power_cycle(self, first: bool = False) -> None:
        """Power-up: buffer empty, pen up and in the carousel, at home (0, 0), errors cleared."""
        if not first:
            self._close_stroke()
        self.buffer = bytearray()
        self._escape = b""
        self.x = self.y = 0
        self.down = False
        self.pen = 0
        self.relative = False
        self.speed = self.top_speed
        self.error = 0
        self.io_error = 0
        self.initialized = True  # OS bit 8 until OS outputs it
        self.busy_until = self.now = self.clock
        self._xoff = False

    @property
    def free(self) -> int:
        return self.size - len(self.buffer)

    def receive(self, data: bytes) -> None:
        """Bytes from the host: device-control sequences act now, the rest fills the buffer."""
        if self.link_dropped or not data:
            return
        data = self._escape + data
        self._escape = b""
        at = 0
        while at < len(data):
            esc = data.find(protocol.ESC, at)
            self._fill(data[at : len(data) if esc < 0 else esc])
            if esc < 0:
                break
            sequences, _, left = protocol.split_device_control(data[esc : esc + 64])
            if not sequences:
                if left:
                    self._escape = data[esc:]
                    return
                at = esc + 1
                continue
            letter, params = sequences[0]
            self._device_control(letter, params)
            consumed = 3 + (len(params) + 1 if letter[0] in protocol.PARAMETER_SEQUENCES else 0)
            at = esc + consumed
        self._flow()

    def _fill(self, chunk: bytes) -> None:
        if chunk and not self.buffer and self.busy_until < self.now:
            self.busy_until = self.now  # idle until these bytes came
        room = self.free
        if len(chunk) > room:
            self.overflows += len(chunk) - room
            self.io_error = 16
            chunk = chunk[:room]
        self.buffer += chunk
        self.max_fill = max(self.max_fill, len(self.buffer))

    def _flow(self) -> None:
        if not self.xonxoff:
            return
        if not self._xoff and self.free < _XOFF_BELOW:
            self._xoff = True
            self.out.append(protocol.XOFF)
        elif self._xoff and self.free >= _XON_AT:
            self._xoff = False
            self.out.append(protocol.XON)

    def _device_control(self, letter: bytes, params: bytes) -> None:
        if letter == b"B":
            self._answer(str(self.free))
            self.polls += 1
        elif letter == b"E":
            self._answer(str(self.io_error))
            self.io_error = 0
        elif letter == b"O":
            idle = not self.buffer and self.busy_until <= self.now
            self._answer(str(8 if idle else 0))
        elif letter == b"A":
            self._answer(f"{MODEL},A")
        elif letter == b"L":  # the buffer's size, whatever it holds
            self._answer(str(self.size))
        elif letter == b"K":
            self.discarded += len(self.buffer)
            self.buffer.clear()  # the vector being drawn finishes; nothing after it runs
        elif letter == b"R":
            self._xoff = False
        # ESC.J, ESC.@ and the handshake settings: accepted, nothing to emulate

    def _answer(self, text: str) -> None:
        if self.link_dropped:
            return  # nobody on the other end: the answer is lost
        if self._silent_next:
            self._silent_next = False
            return
        self.out += text.encode("ascii") + protocol.TERMINATOR

    def take_output(self) -> bytes:
        out = bytes(self.out)
        self.out.clear()
        return out

    # --- running instructions --------------------------------------------------------------

    def poll(self, seconds: float) -> None:
        """Let ``seconds`` of plotter time pass (``math.inf``: run everything buffered)."""
        self.now = self.busy_until if math.isinf(seconds) else self.now + seconds
        while True:  # a pulled cable does not stop the plotter: it draws what it holds
            if not math.isinf(seconds) and self.busy_until > self.now:
                break
            try:
                found, used = protocol.split_instructions(bytes(self.buffer), final=False, limit=1)
            except ProtocolError:
                del self.buffer[:1]  # an unreadable byte: the parser skips it
                self.error = 1
                continue
            if not found:
                if not self._run_arrived_pairs():
                    break
                continue
            del self.buffer[:used]
            self._run(found[0])
            if math.isinf(seconds):
                self.now = self.busy_until
        self._flow()

    def _run_arrived_pairs(self) -> bool:
        """A move instruction still arriving: run the coordinate pairs that are complete, as the
        plotter parses them (:func:`sim.hpgl.shapes.complete_pairs`); whether any were."""
        arrived = hpgl_shapes.complete_pairs(bytes(self.buffer))
        if arrived is None:
            return False
        mnemonic, params, used = arrived
        self.buffer[:used] = mnemonic.encode("ascii")  # the instruction goes on with its next pair
        self._run(protocol.Instruction(mnemonic, params))
        return True

    def finish(self) -> None:
        """Run everything buffered (what the drawing will be once the plotter is done)."""
        self.poll(math.inf)

    def _run(self, ins: protocol.Instruction) -> None:
        self.executed += 1
        self.log.append(ins.encode().decode("ascii", errors="replace"))
        fault = self.faults.at.get(self.executed) if self.faults else None
        if fault is not None:
            kind = fault[0]
            if kind in ("drop", "unplug"):
                self.link_dropped = True
            elif kind == "interrupt":
                self.signal_due = fault[1]
            elif kind == "reset":
                self.power_cycle()
                return
            elif kind == "silent":
                self._silent_next = True
            elif kind == "garbage":
                self.out += _GARBAGE
        m, p = ins.mnemonic, ins.params
        if m == "IN":
            self._pen(False)
            self.relative, self.speed, self.error = False, self.top_speed, 0
            self.initialized = True
        elif m == "SP":
            if len(p) > 1 or (p and not 0 <= p[0] <= self.profile.paper.carousel):  # no such slot
                self.error = 2 if len(p) > 1 else 3
                return
            self._pen(False)
            self.pen = int(p[0]) if p else 0
            self.pauses += 1
        elif m == "VS":
            if not p or not 0 < p[0] <= 38.1 or len(p) > 2:
                self.error = 3 if p else 2
                return
            self.speed = min(p[0] * 10.0, self.top_speed)
        elif m in ("PU", "PD", "PA", "PR"):
            self._moves(m, p)
        elif m == "OI":
            self._answer(MODEL)
        elif m in ("OA", "OC"):  # (no scaling: user units are plotter units)
            self._answer(f"{self.x},{self.y},{int(self.down)}")
        elif m == "OF":
            self._answer("40,40")  # plotter units per mm, as the 7475A states them
        elif m == "OO":
            self._answer("0,1,0,0,1,0,0,0")  # pen select, arcs and circles
        elif m == "OD":
            self._answer(f"{self.x},{self.y},{int(self.down)}")
        elif m in hpgl_shapes.SHAPE_PARAMS:
            hpgl_shapes.draw_shape(self, m, p)
        elif m == "OS":
            status = protocol.STATUS_READY | (protocol.STATUS_ERROR if self.error else 0)
            status |= protocol.STATUS_INITIALIZED if self.initialized else 0
            self.initialized = False  # cleared once output (even if the answer is lost on the line)
            self._answer(str(status | int(self.down)))
        elif m == "OE":
            self._answer(str(self.error))
            self.error = 0
        elif m in ("OH", "OP", "OW"):
            self._answer(",".join(map(str, self.limits)))
        elif m in hpgl_shapes.SETTINGS:
            pass
        elif m in hpgl_shapes.UNEMULATED:
            self.unemulated[m] = self.unemulated.get(m, 0) + 1
        else:
            self.error = 1  # not an instruction of the 7475A

    def _pen(self, down: bool) -> None:
        if down == self.down:
            return
        if down and not self.pen:
            self.down = False  # no pen in the holder: nothing touches the paper
            return
        pen = self.profile.pen_model
        self.busy_until += pen.down_delay if down else pen.up_delay
        self.clock += pen.down_delay if down else pen.up_delay
        if not down:
            self._close_stroke()
        self.down = down

    def _moves(self, m: str, p: tuple[float, ...]) -> None:
        if len(p) % 2:
            self.error = 2
            return
        if m in ("PA", "PR"):
            self.relative = m == "PR"
        else:
            self._pen(m == "PD")
        x0, y0, x1, y1 = self.limits
        for k in range(0, len(p), 2):
            x, y = round(p[k]), round(p[k + 1])
            if self.relative:
                x, y = self.x + x, self.y + y
            if not (x0 <= x <= x1 and y0 <= y <= y1):
                self.error = 3  # beyond the hard-clip limits: the plotter does not go there
                return
            self._vector(x, y)

    def _vector(self, x: int, y: int) -> None:
        start = (self.x * self.unit, self.y * self.unit)
        end = (x * self.unit, y * self.unit)
        dx, dy = end[0] - start[0], end[1] - start[1]
        length = math.hypot(dx, dy)
        self.x, self.y = x, y
        if length == 0:
            if self.down and not self._stroke:
                self._stroke = [start]
            return
        scale = 1.0 / max(abs(dx) / length, abs(dy) / length)
        accel = self.profile.motion.acceleration * scale
        speed = self.speed if self.down else self.top_speed
        seconds = block_duration(length, accel, 0.0, 0.0, speed)
        self.busy_until += seconds
        self.clock += seconds
        if self.down:
            if not self._stroke:
                self._stroke = [start]
            self._stroke.append(end)
        else:
            self._travel.append(np.array([start, end]))

    # --- what was drawn --------------------------------------------------------------------

    def _close_stroke(self) -> None:
        if len(self._stroke) >= 2:
            self._strokes.append(np.array(self._stroke))
            self._stroke_pens.append(self.pen)
        self._stroke = []

    def drawn(self) -> Paths:
        """Pen-down polylines so far (machine mm), the one being drawn last."""
        strokes = self._strokes + ([np.array(self._stroke)] if len(self._stroke) >= 2 else [])
        return Paths.of(strokes) if strokes else Paths.empty()

    @property
    def strokes(self) -> list[np.ndarray]:
        return list(self.drawn())

    @property
    def stroke_pens(self) -> list[int]:
        """The carousel pen that drew each of :attr:`strokes`."""
        return self._stroke_pens + ([self.pen] if len(self._stroke) >= 2 else [])

    @property
    def stroke_pauses(self) -> list[int]:
        return self.stroke_pens

    @property
    def travel(self) -> list[np.ndarray]:
        """Pen-up moves so far (machine mm), each a (2, 2) array."""
        return list(self._travel)

    def bed_strokes(self) -> Paths:
        return self._view(self.drawn())

    def bed_travel(self) -> Paths:
        return self._view(Paths.of(self._travel) if self._travel else Paths.empty())

    def _view(self, paths: Paths) -> Paths:
        return Paths(self.profile.bed.to_view(paths.points), paths.offsets) if len(paths) else paths

    def accepted_lines(self) -> list[str]:
        """Every instruction run, in order."""
        return list(self.log)
