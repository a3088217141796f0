"""The virtual plotter's G-code interpreter: modal state, soft limits, pen, planner, clock.

:class:`Machine` takes one *filtered* line at a time (what GRBL's protocol loop stores: no
whitespace, no comments, upper case — see :func:`sim.firmware.filter_line`), validates it the
way GRBL 1.1's ``gc_execute_line`` does and returns GRBL's status code (0 = ok). Supported:
``G0 G1 G4 G17 G20 G21 G28 G54 G80 G90 G91 G92 G92.1 G94``, ``M0 M1 M2 M3 M4 M5 M7 M8 M9 M30``,
``M280 P S`` (servo angle — a sim extension for servo pens), words ``F N P S T X Y Z``. Other
G/M codes (arcs, probing, G53, G55–G59, inverse time) answer ``error:20``.

The pen is a :class:`PenModel`: a *spindle* pen is down while M3/M4 is on with S closer to the
profile's ``down`` than ``up``; a *z* pen while Z is closer to ``down``; a *servo* pen while
the last ``M280`` angle is. Moves are planned (:mod:`sim.planner`) and, as they complete,
pen-down moves become :attr:`Machine.strokes` (polylines, machine mm) and pen-up moves
:attr:`Machine.travel`.

Machine coordinates run from 0 to the bed size (negative if the profile inverts an axis);
with soft limits on (``$20=1``, the default here) a target outside raises :class:`MachineAlarm`.
The machine starts as if it had been homed at (0, 0, 0).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from sim.planner import Block, Planner

# GRBL 1.1 status codes used here (texts in firmware_protocol.grbl.ERRORS).
OK = 0
EXPECTED_LETTER, BAD_NUMBER, NEGATIVE = 1, 2, 4
UNSUPPORTED, MODAL_GROUP, UNDEFINED_FEED, NOT_INTEGER = 20, 21, 22, 23
AXIS_CONFLICT, REPEATED_WORD, NO_AXIS_WORDS, BAD_LINE_NUMBER = 24, 25, 26, 27
VALUE_MISSING, AXIS_WORDS_UNUSED, UNUSED_WORDS, TOOL_TOO_BIG = 28, 31, 36, 38
TRAVEL_EXCEEDED, INVALID_JOG = 15, 16
SOFT_LIMIT_ALARM = 2
_JOG_MODES = {(20, 0), (21, 0), (90, 0), (91, 0)}  # all a $J= line may set, for itself only

#: GRBL 1.1 factory settings; a profile overrides the machine-specific ones.
DEFAULT_SETTINGS: dict[int, float] = {
    0: 10, 1: 25, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 10: 1, 11: 0.010, 12: 0.002, 13: 0,
    20: 0, 21: 0, 22: 0, 23: 0, 24: 25.0, 25: 500.0, 26: 250, 27: 1.0, 30: 1000, 31: 0, 32: 0,
    100: 250.0, 101: 250.0, 102: 250.0, 110: 500.0, 111: 500.0, 112: 500.0,
    120: 10.0, 121: 10.0, 122: 10.0, 130: 200.0, 131: 200.0, 132: 200.0,
}

# (G number, hundredths as GRBL's mantissa) → modal group; GRBL's groups 0 (non-modal), 1 motion, 2 plane, 3
# distance, 5 feed mode, 6 units, 12 coordinate system.
_G_GROUPS = {
    (0, 0): 1, (1, 0): 1, (80, 0): 1, (4, 0): 0, (28, 0): 0, (92, 0): 0, (92, 10): 0,
    (17, 0): 2, (90, 0): 3, (91, 0): 3, (94, 0): 5, (20, 0): 6, (21, 0): 6, (54, 0): 12,
}
_G_KNOWN = {g for g, _ in _G_GROUPS}
_M_GROUPS = {0: 4, 1: 4, 2: 4, 30: 4, 3: 7, 4: 7, 5: 7, 7: 8, 8: 8, 9: 8, 280: 100}
_VALUE_WORDS = frozenset("FIJKLNPRSTXYZ")
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)")
_WORD = re.compile(r"([A-Z])([+-]?(?:\d+\.?\d*|\.\d+))")
_WELL_FORMED = re.compile(r"(?:[A-Z][+-]?(?:\d+\.?\d*|\.\d+))*")
_AXES = "XYZ"


class MachineAlarm(Exception):
    """Motion stopped with GRBL alarm ``code`` (e.g. 2: soft limit)."""

    def __init__(self, code: int):
        super().__init__(f"ALARM:{code}")
        self.code = code


@dataclass(frozen=True)
class PenModel:
    """How the profile moves the pen: ``kind`` and the ``up``/``down`` values."""

    kind: str = "spindle"
    up: float = 30.0
    down: float = 90.0

    def is_down(self, value: float) -> bool:
        return abs(value - self.down) < abs(value - self.up)


@dataclass(frozen=True)
class MachineConfig:
    """Bed (mm), axis directions, pen, and motion limits that seed GRBL's settings.

    ``origin`` is the bed corner where machine (0, 0) is, seen from above; ``invert_x`` /
    ``invert_y`` mean machine coordinates run negative into the bed.
    """

    width: float = 220.0
    height: float = 310.0
    origin: str = "bottom-left"
    invert_x: bool = False
    invert_y: bool = False
    pen: PenModel = field(default_factory=PenModel)
    max_rate: float = 6000.0  # mm/min, $110/$111
    acceleration: float = 800.0  # mm/s², $120/$121
    junction_deviation: float = 0.01  # mm, $11

    @classmethod
    def from_profile(cls, profile) -> MachineConfig:
        """From a :class:`pencilbot.gcode.profiles.Profile` (its bed, pen and motion tables)."""
        bed, motion, pen = profile.bed, profile.motion, profile.pen
        return cls(
            width=bed.width, height=bed.height, origin=bed.origin,
            invert_x=bed.invert_x, invert_y=bed.invert_y,
            pen=PenModel(pen.kind, float(pen.up), float(pen.down)),
            max_rate=max(motion.travel_feed, motion.draw_feed),
            acceleration=motion.acceleration, junction_deviation=motion.junction_deviation,
        )

    def settings(self) -> dict[int, float]:
        """GRBL settings for this machine: soft limits and homing on, rates, travel."""
        s = dict(DEFAULT_SETTINGS)
        s.update({
            11: self.junction_deviation, 20: 1, 22: 1,
            110: self.max_rate, 111: self.max_rate, 112: self.max_rate,
            120: self.acceleration, 121: self.acceleration, 122: self.acceleration,
            130: self.width, 131: self.height,
        })
        s[23] = (1 if self.invert_x else 0) | (2 if self.invert_y else 0)
        if self.pen.kind == "spindle":
            s[30] = max(s[30], self.pen.up, self.pen.down)
        return s

    def to_bed(self, points: np.ndarray) -> np.ndarray:
        """Machine XY (mm) → bed mm with origin at the bed's bottom-left, Y up."""
        pts = np.asarray(points, dtype=np.float64)[:, :2]
        into_x = -pts[:, 0] if self.invert_x else pts[:, 0]
        into_y = -pts[:, 1] if self.invert_y else pts[:, 1]
        x = into_x if self.origin.endswith("left") else self.width - into_x
        y = into_y if self.origin.startswith("bottom") else self.height - into_y
        return np.column_stack([x, y])


@dataclass
class Parsed:
    """One validated block: the commands and words it holds (values in the block's units)."""

    g: dict[int, tuple[int, int]] = field(default_factory=dict)  # modal group → (G, mantissa)
    m: dict[int, int] = field(default_factory=dict)  # modal group → M number
    words: dict[str, float] = field(default_factory=dict)
    axes: dict[str, float] = field(default_factory=dict)  # the X, Y, Z words


class Machine:
    """A GRBL 1.1-like G-code interpreter driving a planner and a virtual clock.

    Parameters
    ----------
    config : MachineConfig
        Bed, pen and motion limits.
    instant : bool
        True: whenever the machine has to wait for motion (planner full, a pen change, a
        dwell) the clock jumps ahead at once. False: the caller advances the clock with
        :meth:`advance` and applies a line only when :meth:`must_wait` says it can.
    """

    def __init__(self, config: MachineConfig | None = None, *, instant: bool = True):
        self.config = config or MachineConfig()
        self.instant = instant
        self.settings = self.config.settings()
        self.planner = Planner()
        self._strokes: list[np.ndarray] = []  # finished pen-down polylines, machine mm
        self.travel: list[np.ndarray] = []  # pen-up moves, machine mm
        self.messages: list[str] = []  # push messages for the firmware to print
        self.dwell_until = 0.0
        self.pause_requested = False  # M0 asks the firmware for a feed hold
        self._stroke: list[tuple[float, float]] = []
        self.position = (0.0, 0.0, 0.0)  # machine mm, where the parser believes the tool is
        self.reset_modes()

    # --- modal state ------------------------------------------------------------------------

    def reset_modes(self) -> None:
        """Power-on / soft-reset modal state: GRBL 1.1 keeps the machine position and clears
        the G92 offset; the pen ends up lifted (spindle off, servo at ``up``)."""
        self.motion = 0
        self.units_mm = True
        self.absolute = True
        self.feed = 0.0  # mm/min
        self.spindle = 5  # M3/M4/M5
        self.coolant = 9
        self.s = 0.0
        self.tool = 0
        self.servo_angle = self.config.pen.up
        self.line_number = 0
        self.g92 = (0.0, 0.0, 0.0)
        self.check_mode = False

    @property
    def pen_down(self) -> bool:
        pen = self.config.pen
        if pen.kind == "z":
            return pen.is_down(self.position[2])
        if pen.kind == "servo":
            return pen.is_down(self.servo_angle)
        return self.spindle in (3, 4) and pen.is_down(self._spindle_output())

    def _spindle_output(self) -> float:
        """S as the PWM delivers it: clamped to $31..$30."""
        return min(max(self.s, self.settings[31]), self.settings[30])

    def gcode_state(self) -> str:
        """The ``$G`` text: ``G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0``."""
        return (
            f"G{self.motion} G54 G17 G{21 if self.units_mm else 20} G{90 if self.absolute else 91} "
            f"G94 M{self.spindle} M{self.coolant} T{self.tool} F{self.feed:.0f} S{self.s:.0f}"
        )

    def work_position(self) -> tuple[float, float, float]:
        """Machine position minus the G92 offset (mm)."""
        return tuple(m - o for m, o in zip(self.machine_position(), self.g92))

    def machine_position(self) -> tuple[float, float, float]:
        """Where the tool physically is now (mid-move in real-time mode)."""
        p = self.planner
        if p.executing is not None:
            return p.executing.point_at(p.elapsed)
        if p.queue:
            return p.queue[0].start
        return self.position

    # --- parsing ----------------------------------------------------------------------------

    def parse(self, line: str) -> Parsed | int:
        """Validate one filtered line; return the block or GRBL's error code."""
        block = Parsed()
        if _WELL_FORMED.fullmatch(line):
            words = _WORD.findall(line)
        else:
            words = self._scan_words(line)
            if isinstance(words, int):
                return words
        for letter, number in words:
            value = float(number)
            int_value = math.trunc(value)
            mantissa = round(100 * abs(value - int_value))
            if letter == "G":
                if (int_value, 0) not in _G_GROUPS or value < 0:
                    return UNSUPPORTED
                if (int_value, mantissa) not in _G_GROUPS:
                    return NOT_INTEGER
                group = _G_GROUPS[(int_value, mantissa)]
                if group in block.g:
                    return MODAL_GROUP
                block.g[group] = (int_value, mantissa)
            elif letter == "M":
                if value != int_value:
                    return NOT_INTEGER
                if int_value not in _M_GROUPS:
                    return UNSUPPORTED
                group = _M_GROUPS[int_value]
                if group in block.m:
                    return MODAL_GROUP
                block.m[group] = int_value
            else:
                if letter not in _VALUE_WORDS:
                    return UNSUPPORTED
                if letter in block.words:
                    return REPEATED_WORD
                if letter in "FNPTS" and value < 0:
                    return NEGATIVE
                block.words[letter] = value
                if letter in _AXES:
                    block.axes[letter] = value
        return self._check(block)

    @staticmethod
    def _scan_words(line: str) -> list[tuple[str, str]] | int:
        """Word by word, to find the first malformed one as GRBL does (error 1 or 2)."""
        words, pos = [], 0
        while pos < len(line):
            letter = line[pos]
            if not "A" <= letter <= "Z":
                return EXPECTED_LETTER
            m = _NUMBER.match(line, pos + 1)
            if m is None:
                return BAD_NUMBER
            words.append((letter, m.group()))
            pos = m.end()
        return words

    def _check(self, block: Parsed) -> Parsed | int:
        words, g = block.words, block.g
        if words.get("N", 0) > 9_999_999:
            return BAD_LINE_NUMBER
        if words.get("T", 0) > 255:
            return TOOL_TOO_BIG
        non_modal = g.get(0)
        axes = block.axes
        if non_modal in ((28, 0), (92, 0)) and 1 in g and g[1] != (80, 0):
            return AXIS_CONFLICT
        if non_modal == (4, 0) and "P" not in words:
            return VALUE_MISSING
        if non_modal == (92, 0) and not axes:
            return NO_AXIS_WORDS
        if 100 in block.m and "S" not in words:
            return VALUE_MISSING
        motion = g[1][0] if 1 in g else self.motion
        if axes and non_modal not in ((28, 0), (92, 0)):
            if motion == 80:
                return AXIS_WORDS_UNUSED
            if motion == 1 and not words.get("F", self.feed):
                return UNDEFINED_FEED
        if "P" in words and non_modal != (4, 0) and 100 not in block.m:
            return UNUSED_WORDS
        if any(w in words for w in "IJKLR"):
            return UNUSED_WORDS
        return block

    # --- execution --------------------------------------------------------------------------

    def must_wait(self, block: Parsed) -> bool:
        """True if ``block`` cannot run yet: it needs the planner empty (pen change, dwell,
        program end) or a free planner slot (a move), or a dwell is still running."""
        if self.dwelling:
            return True
        if self._synchronizes(block):
            return self.planner.busy
        needed = 2 if block.g.get(0) == (28, 0) and block.axes else 1
        return self._moves(block) and self.planner.free_blocks < needed

    def _synchronizes(self, block: Parsed) -> bool:
        spindle = block.m.get(7, self.spindle)
        s_changes = "S" in block.words and block.words["S"] != self.s and spindle != 5 and 100 not in block.m
        # Spindle (pen) changes, servo moves, dwells and program stops wait for motion to end.
        return spindle != self.spindle or s_changes or 100 in block.m or 4 in block.m or block.g.get(0) == (4, 0)

    def _moves(self, block: Parsed) -> bool:
        return bool(block.axes) or block.g.get(0) == (28, 0)

    def apply(self, block: Parsed) -> None:
        """Carry out a validated block in GRBL's order of execution.

        Raises
        ------
        MachineAlarm
            A target lies outside the soft limits; the planner has been stopped.
        """
        w = block.words
        was_down = self.pen_down
        if "N" in w:
            self.line_number = int(w["N"])
        units = block.g.get(6)  # G20/G21 apply to this block's own words already
        units_mm = self.units_mm if units is None else units[0] == 21
        scale = 1.0 if units_mm else 25.4
        if "F" in w:
            self.feed = w["F"] * scale
        if "T" in w:
            self.tool = int(w["T"])
        if self._synchronizes(block):
            self.synchronize()
        if 100 in block.m:
            self.servo_angle = w["S"]  # M280's S is an angle, not the spindle speed
        elif "S" in w:
            self.s = w["S"]
        self.spindle = block.m.get(7, self.spindle)
        self.coolant = block.m.get(8, self.coolant)
        if block.g.get(0) == (4, 0):
            self._dwell(w["P"])
        self.units_mm = units_mm
        if 3 in block.g:
            self.absolute = block.g[3][0] == 90
        if 1 in block.g:
            self.motion = block.g[1][0]
        non_modal = block.g.get(0)
        if non_modal == (92, 0):
            self.g92 = tuple(
                self.position[i] - w[a] * scale if a in w else self.g92[i] for i, a in enumerate(_AXES)
            )
        elif non_modal == (92, 10):
            self.g92 = (0.0, 0.0, 0.0)
        elif non_modal == (28, 0):
            if block.axes:
                self._line(self._target(block.axes, scale), rapid=True)
            self._line((0.0, 0.0, 0.0), rapid=True)
        elif block.axes and self.motion in (0, 1):
            self._line(self._target(block.axes, scale), rapid=self.motion == 0)
        stop = block.m.get(4)
        if stop == 0 and not self.check_mode:
            self.pause_requested = True
        if stop in (2, 30):
            self.synchronize()
            # GRBL's program-end reset: G1 G17 G90 G94 G54 M5 M9 (units and offsets stay).
            self.motion, self.absolute = 1, True
            self.spindle, self.coolant = 5, 9
            self.messages.append("[MSG:Pgm End]")
        if was_down and not self.pen_down and not self.planner.busy:
            self._close_stroke()  # lifted in place: a later pen-down starts a new stroke

    def _target(self, axes: dict[str, float], scale: float, absolute: bool | None = None):
        """Machine target (mm) of axis words in the block's units and distance mode."""
        absolute = self.absolute if absolute is None else absolute
        target = list(self.position)
        for i, a in enumerate(_AXES):
            if a in axes:
                v = axes[a] * scale
                target[i] = v + self.g92[i] if absolute else target[i] + v
        return tuple(target)

    def jog(self, line: str) -> int:
        """``$J=`` body: a move at its own F that leaves the parser's modes untouched.

        Returns GRBL's status code: 16 for words a jog may not hold, 22 without F, 15 when
        the target is outside the soft limits (a jog is refused, not an alarm).
        """
        block = self.parse(line)
        if isinstance(block, int):
            return block
        if block.m or set(block.g.values()) - _JOG_MODES or set(block.words) - set("XYZF"):
            return INVALID_JOG
        if "F" not in block.words:
            return UNDEFINED_FEED
        units, distance = block.g.get(6), block.g.get(3)
        scale = 25.4 if (units or (21 if self.units_mm else 20, 0))[0] == 20 else 1.0
        absolute = self.absolute if distance is None else distance[0] == 90
        target = self._target(block.axes, scale, absolute)
        if self._soft_limit_exceeded(target):
            return TRAVEL_EXCEEDED
        self._line(target, rapid=False, feed=block.words["F"] * scale)
        return OK

    def _soft_limit_exceeded(self, target) -> bool:
        if not self.settings[20]:
            return False
        eps = 1e-6
        for value, travel, inverted in (
            (target[0], self.settings[130], self.config.invert_x),
            (target[1], self.settings[131], self.config.invert_y),
        ):
            lo, hi = (-travel, 0.0) if inverted else (0.0, travel)
            if not lo - eps <= value <= hi + eps:
                return True
        return False

    def _line(self, target: tuple[float, float, float], *, rapid: bool, feed: float | None = None) -> None:
        if self._soft_limit_exceeded(target):
            self.stop()
            raise MachineAlarm(SOFT_LIMIT_ALARM)
        start = self.position
        delta = (target[0] - start[0], target[1] - start[1], target[2] - start[2])
        length = math.hypot(*delta)
        pen_before = self.pen_down
        self.position = target
        if length < 1e-9 or self.check_mode:
            return
        unit = (delta[0] / length, delta[1] / length, delta[2] / length)
        # Per-axis limits along the move, as GRBL's limit_value_by_axis_maximum.
        rate = accel = math.inf
        settings = self.settings
        for i, u in enumerate(unit):
            if u:
                u = abs(u)
                if settings[110 + i] < rate * u:
                    rate = settings[110 + i] / u
                if settings[120 + i] < accel * u:
                    accel = settings[120 + i] / u
        rate /= 60.0
        nominal = rate if rapid else min((feed or self.feed) / 60.0, rate)
        pen = pen_before and (self.config.pen.kind != "z" or self.pen_down)
        if self.instant and self.planner.free_blocks == 0:
            self._complete([self.planner.finish_one()])
        self.planner.add(Block(start, target, length, unit, nominal, accel, pen), settings[11])

    @property
    def dwelling(self) -> bool:
        """Real-time mode: a G4 is still counting down."""
        return self.planner.clock < self.dwell_until

    def _dwell(self, seconds: float) -> None:
        if self.check_mode:
            return
        if self.instant:
            self.planner.clock += seconds
        else:
            self.dwell_until = self.planner.clock + seconds

    def synchronize(self) -> None:
        """Instant mode: finish every queued move now (GRBL's buffer synchronize)."""
        if self.instant and not self.check_mode:
            self._complete(self.planner.finish_all())

    def home(self) -> None:
        """``$H``: seek the home switches at ``$25`` and set machine (0, 0, 0) there."""
        self.synchronize()
        distance = math.dist(self.position, (0.0, 0.0, 0.0))
        self.planner.clock += distance / (self.settings[25] / 60.0)
        self.position = (0.0, 0.0, 0.0)

    def advance(self, seconds: float) -> None:
        """Real-time mode: let ``seconds`` of machine time pass."""
        self._complete(self.planner.advance(seconds))
        if not self.planner.busy and self.planner.clock < self.dwell_until:
            self.planner.clock = min(self.dwell_until, self.planner.clock + seconds)

    def stop(self) -> bool:
        """Halt at once (reset, alarm): drop planned moves. True if the machine was moving."""
        moving = self.planner.busy
        here = self.machine_position()  # moves not yet started are dropped, not reached
        cut = self.planner.discard()
        if cut is not None:
            self._complete([cut])
        self.position = here
        self.dwell_until = self.planner.clock
        self._close_stroke()
        return moving

    # --- what was drawn -------------------------------------------------------------------

    def _complete(self, blocks: list[Block]) -> None:
        for b in blocks:
            if b.pen_down:
                if not self._stroke or self._stroke[-1] != b.start[:2]:
                    self._close_stroke()
                    self._stroke.append(b.start[:2])
                self._stroke.append(b.end[:2])
            else:
                self._close_stroke()
                self.travel.append(np.array([b.start[:2], b.end[:2]]))

    def _close_stroke(self) -> None:
        """The pen has left the paper: the polyline being drawn is finished."""
        if len(self._stroke) >= 2:
            self._strokes.append(np.array(self._stroke))
        self._stroke = []

    def finish(self) -> None:
        """Complete all queued motion (instant mode)."""
        self.synchronize()

    @property
    def strokes(self) -> list[np.ndarray]:
        """Pen-down polylines drawn so far (machine mm), the one still being drawn last."""
        if len(self._stroke) >= 2:
            return self._strokes + [np.array(self._stroke)]
        return list(self._strokes)

    @property
    def clock(self) -> float:
        """Simulated seconds of motion and dwell since power-on."""
        return self.planner.clock

    def bed_strokes(self) -> list[np.ndarray]:
        """Pen-down polylines in bed mm (bottom-left origin, Y up) for :class:`pencilbot.render.Canvas`."""
        return [self.config.to_bed(s) for s in self.strokes]

    def bed_travel(self) -> list[np.ndarray]:
        return [self.config.to_bed(s) for s in self.travel]
