"""What GRBL 1.1h's g-code parser works with: its status codes, the modal state it keeps between
lines (``gc_state``) and the checked :class:`Block` it hands to execution (machine mm, mm/min).

The parser that fills them is :mod:`sim.gcode.parser`; :mod:`sim.gcode.machine` executes the blocks.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TypeVar

T = TypeVar("T")

# GRBL 1.1 status codes (texts in firmware_protocol.grbl.ERRORS).
OK = 0
EXPECTED_LETTER, BAD_NUMBER, NEGATIVE = 1, 2, 4
INVALID_JOG = 16
UNSUPPORTED, MODAL_GROUP, UNDEFINED_FEED, NOT_INTEGER = 20, 21, 22, 23
AXIS_CONFLICT, REPEATED_WORD, NO_AXIS_WORDS, BAD_LINE_NUMBER = 24, 25, 26, 27
VALUE_MISSING, UNSUPPORTED_COORD, G53_MOTION, AXIS_WORDS_UNUSED = 28, 29, 30, 31
NO_AXIS_IN_PLANE, INVALID_TARGET, ARC_RADIUS, NO_OFFSETS_IN_PLANE = 32, 33, 34, 35
UNUSED_WORDS, TOOL_LENGTH_AXIS, TOOL_TOO_BIG = 36, 37, 38

MAX_LINE_NUMBER = 10_000_000
MAX_TOOL = 255
COORD_SYSTEMS = 6  # G54..G59; stored data also holds G28 (index 6) and G30 (index 7)
G28_INDEX, G30_INDEX = 6, 7

# What a command asks the interpreter to do with the block's axis words (GRBL's axis_command).
NO_AXIS_COMMAND, NON_MODAL_AXES, MOTION_AXES, TOOL_LENGTH_AXES = 0, 1, 2, 3
# Motion modes; the probes are 38.2–38.5 as GRBL prints them.
SEEK, LINEAR, CW_ARC, CCW_ARC, NO_MOTION = 0, 1, 2, 3, 80
PROBES = (38.2, 38.3, 38.4, 38.5)
# Program flow (M4 group): 0 running, M0 pause, M2 / M30 end.
RUNNING, PAUSE, END_M2, END_M30 = 0, 3, 2, 30
PLANE_AXES = ((0, 1, 2), (2, 0, 1), (1, 2, 0))  # G17 XY, G18 ZX, G19 YZ: (axis 0, axis 1, linear)


@dataclass
class Modal:
    """The modal groups GRBL keeps (gc_state.modal), with GRBL's power-on defaults."""

    motion: float = SEEK  # 0 1 2 3 80 or a probe 38.x
    plane: int = 0  # 0 G17, 1 G18, 2 G19
    units_mm: bool = True  # G21 / G20
    absolute: bool = True  # G90 / G91
    inverse_time: bool = False  # G93 / G94
    coord_select: int = 0  # G54 + n
    tool_length: bool = False  # G43.1 active (G49 cancels)
    spindle: int = 5  # M3 / M4 / M5
    coolant: int = 9  # M8 / M9
    program_flow: int = RUNNING

    def copy(self) -> Modal:
        twin = Modal.__new__(Modal)
        twin.__dict__.update(self.__dict__)  # several times faster than dataclasses.replace
        return twin


@dataclass
class ParserState:
    """What GRBL's parser remembers between lines (gc_state), in mm and mm/min.

    ``coord_data`` is the non-volatile store (EEPROM) of G54–G59, G28 and G30 positions in
    machine mm; it is shared, not copied, so it survives resets.
    """

    coord_data: list[tuple[float, ...]]
    modal: Modal = field(default_factory=Modal)
    feed: float = 0.0  # mm/min (G94) or the last inverse-time F (G93)
    spindle_speed: float = 0.0
    tool: int = 0
    line_number: int = 0
    position: tuple[float, ...] = (0.0, 0.0, 0.0)  # machine mm
    coord_system: tuple[float, ...] = (0.0, 0.0, 0.0)  # the active G54–G59 offset
    coord_offset: tuple[float, ...] = (0.0, 0.0, 0.0)  # G92
    tool_length_offset: float = 0.0  # G43.1, on Z

    def work_offset(self) -> tuple[float, ...]:
        """WCO: machine minus work position (coordinate system + G92 + tool length on Z)."""
        wco = [c + o for c, o in zip(self.coord_system, self.coord_offset)]
        wco[2] += self.tool_length_offset
        return tuple(wco)


@dataclass
class Block:
    """A line that passed every check, ready to execute in GRBL's order (machine mm, mm/min)."""

    modal: Modal
    non_modal: float = 0  # 0 none, or 4 10 28 28.1 30 30.1 53 92 92.1
    axis_command: int = NO_AXIS_COMMAND
    feed: float = 0.0  # mm/min, or the inverse-time F in G93
    spindle_speed: float = 0.0
    tool: int = 0
    line_number: int = 0
    dwell: float = 0.0  # s, for G4
    target: tuple[float, ...] | None = None  # motion target, G28/G30 via point
    home: tuple[float, ...] | None = None  # G28/G30 stored position to go to
    coord_system: tuple[float, ...] = (0.0, 0.0, 0.0)  # offset in force for this block
    coord_write: tuple[int, tuple[float, ...]] | None = None  # G10: (index, offset)
    coord_offset: tuple[float, ...] | None = None  # new G92 offset
    tool_length_offset: float | None = None  # new G43.1 / G49 offset
    arc: tuple[tuple[float, ...], float, bool] | None = None  # (centre offset, radius, cw)
    words: dict[str, float] = field(default_factory=dict)
    servo_angle: float | None = None  # M280 (only with the servo extension)

    @property
    def axes(self) -> tuple[int, int, int]:
        """(axis 0, axis 1, linear axis) of the block's plane."""
        return PLANE_AXES[self.modal.plane]


def given(value: T | None) -> T:
    """``value``, which the block's own command guarantees is set (a G10's ``coord_write``, a
    G92's ``coord_offset``, an arc's ``arc``): said once for the type checker."""
    assert value is not None
    return value
