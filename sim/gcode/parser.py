"""GRBL 1.1h's g-code parser: one filtered line → a checked :class:`Block`, or a status code.

This is the checking half of GRBL's ``gc_execute_line`` (its steps 1–3), written from the
order of checks in ``gcode.c``: words are read left to right (unsupported letter or command,
modal group clash, repeated word, negative F/N/P/S/T fail at the word), then the block is
checked as a whole in GRBL's order: line number, feed mode and feed, dwell, plane, units,
tool length offset, coordinate system, the non-modal commands (G10, G28/G30, G53, G92), the
motion mode (G0/G1, arcs, probes) and last the unused words. The first failure is the answer,
as on the board; nothing of a failing block changes the parser state.

Numbers are read as GRBL's ``read_float`` does (sign, digits, one point, at most 8 significant
digits) and command numbers as its ``uint8`` integer part and hundredths "mantissa": ``M280``
wraps to 24 with a mantissa and fails as not an integer (error 23), ``G59.1`` likewise.

What the board accepts: ``G0 G1 G2 G3 G4 G10 L2/L20 G17 G18 G19 G20 G21 G28 G28.1 G30 G30.1
G38.2-G38.5 G40 G43.1 G49 G53 G54-G59 G61 G80 G90 G91 G91.1 G92 G92.1 G93 G94``,
``M0 M1 M2 M3 M4 M5 M8 M9 M30`` (no ``M7``: mist is a build option, off by default) and the
words ``F I J K L N P R S T X Y Z``. Positions in a :class:`Block` are machine millimetres.
"""

from __future__ import annotations

import math
import re

from sim.gcode.checks import check_block

# isort: off
from sim.gcode.state import (  # noqa: F401 (the parser's names, read as gcode_parser.X by the machine)
    ARC_RADIUS,
    AXIS_CONFLICT,
    AXIS_WORDS_UNUSED,
    BAD_LINE_NUMBER,
    BAD_NUMBER,
    CCW_ARC,
    COORD_SYSTEMS,
    CW_ARC,
    END_M2,
    END_M30,
    EXPECTED_LETTER,
    G28_INDEX,
    G30_INDEX,
    G53_MOTION,
    INVALID_JOG,
    INVALID_TARGET,
    LINEAR,
    MAX_LINE_NUMBER,
    MAX_TOOL,
    MODAL_GROUP,
    MOTION_AXES,
    NEGATIVE,
    NO_AXIS_COMMAND,
    NO_AXIS_IN_PLANE,
    NO_AXIS_WORDS,
    NO_MOTION,
    NO_OFFSETS_IN_PLANE,
    NON_MODAL_AXES,
    NOT_INTEGER,
    OK,
    PAUSE,
    PROBES,
    REPEATED_WORD,
    RUNNING,
    SEEK,
    TOOL_LENGTH_AXES,
    TOOL_LENGTH_AXIS,
    TOOL_TOO_BIG,
    UNDEFINED_FEED,
    UNSUPPORTED,
    UNSUPPORTED_COORD,
    UNUSED_WORDS,
    VALUE_MISSING,
    Block,
    Modal,
    ParserState,
)
# isort: on

_MAX_DIGITS = 8  # read_float keeps 8 significant digits
_AXES = "XYZ"
_VALUE_LETTERS = frozenset("FIJKLNPRSTXYZ")
_WORD = re.compile(r"([A-Z])([+-]?(?:\d+\.?\d*|\.\d+))")
_WELL_FORMED = re.compile(r"(?:[A-Z][+-]?(?:\d+\.?\d*|\.\d+))*")
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)")


def parse_block(line: str, state: ParserState, *, jog: bool = False, servo: bool = False) -> Block | int:
    """Check one filtered line as GRBL 1.1h does; the block, or GRBL's status code.

    Parameters
    ----------
    line : str
        Upper case, no whitespace or comments (what GRBL's protocol loop stores). For a jog,
        the text after ``$J=``.
    state : ParserState
        The parser state the line is checked against (not changed).
    jog : bool
        Check as a ``$J=`` jog: G1 and G94 enforced, F required, only G20/G21, G90/G91 and
        G53 allowed (error 16), S and T unused (error 36).
    servo : bool
        Accept ``M280 P<n> S<angle>`` (a servo-pen extension real GRBL refuses with error 23).

    Returns
    -------
    Block or int
    """
    words = _words(line)
    if isinstance(words, int):
        return words
    modal = state.modal.copy()
    block = Block(modal)
    if jog:
        modal.motion, modal.inverse_time = LINEAR, False
    groups: set[str] = set()
    values: dict[str, float] = block.words
    axes: dict[int, float] = {}
    ijk: dict[int, float] = {}
    for letter, number in words:
        value = _grbl_float(number)
        if letter in "GM":
            code = _command(letter, value, modal, block, groups, servo)
            if code:
                return code
            continue
        if letter not in _VALUE_LETTERS:
            return UNSUPPORTED
        if letter == "T" and value > MAX_TOOL:
            return TOOL_TOO_BIG
        if letter in values:
            return REPEATED_WORD
        if letter in "FNPTS" and value < 0:
            return NEGATIVE
        values[letter] = value
        if letter in _AXES:
            axes[_AXES.index(letter)] = value
        elif letter in "IJK":
            ijk["IJK".index(letter)] = value
    return check_block(block, state, groups, values, axes, ijk, jog)


def _words(line: str) -> list[tuple[str, str]] | int:
    if _WELL_FORMED.fullmatch(line):
        return _WORD.findall(line)
    words, pos = [], 0
    while pos < len(line):  # word by word, to fail where GRBL fails
        letter = line[pos]
        if not "A" <= letter <= "Z":
            return EXPECTED_LETTER
        m = _NUMBER.match(line, pos + 1)
        if m is None:
            return BAD_NUMBER
        words.append((letter, m.group()))
        pos = m.end()
    return words


def _grbl_float(text: str) -> float:
    """The number as read_float gives it: digits past the 8th significant one are dropped."""
    value = float(text)
    if len(text) - ("." in text) - (text[0] in "+-") <= _MAX_DIGITS:
        return value
    sign = -1.0 if text.startswith("-") else 1.0
    body = text.lstrip("+-")
    whole, _, frac = body.partition(".")
    digits = whole + frac
    kept = digits[:_MAX_DIGITS]
    exponent = len(whole) - len(kept) if len(whole) > _MAX_DIGITS else -(len(kept) - len(whole))
    return sign * int(kept) * 10.0**exponent


def _c_round(x: float) -> int:
    """C's round(): halves away from zero."""
    return int(math.floor(x + 0.5)) if x >= 0 else -int(math.floor(-x + 0.5))


def _command(letter: str, value: float, modal: Modal, block: Block, groups: set[str], servo: bool) -> int:
    """One G or M word into ``block`` (GRBL's step 2 for commands); a status code, 0 if fine."""
    int_value = math.trunc(value) % 256  # GRBL stores the integer part in a uint8
    mantissa = 0 if value == int_value else _c_round(100 * (value - int_value)) % 65536
    if letter == "M":
        return _m_command(value, int_value, mantissa, modal, groups, servo)
    if int_value in (10, 28, 30, 92, 4, 53):
        if int_value in (10, 28, 30, 92) and mantissa == 0:
            if block.axis_command:
                return AXIS_CONFLICT
            block.axis_command = NON_MODAL_AXES
        group = "G0"
        block.non_modal = int_value
        if int_value in (28, 30, 92):
            if mantissa not in (0, 10):
                return UNSUPPORTED
            block.non_modal = int_value + mantissa / 100
            mantissa = 0
    elif int_value in (0, 1, 2, 3, 38, 80):
        if int_value != 80:
            if block.axis_command:
                return AXIS_CONFLICT
            block.axis_command = MOTION_AXES
        group = "G1"
        modal.motion = int_value
        if int_value == 38:
            if mantissa not in (20, 30, 40, 50):
                return UNSUPPORTED
            modal.motion = 38 + mantissa / 100
            mantissa = 0
    elif int_value in (17, 18, 19):
        group, modal.plane = "G2", int_value - 17
    elif int_value in (90, 91):
        if mantissa == 0:
            group, modal.absolute = "G3", int_value == 90
        else:
            if mantissa != 10 or int_value == 90:  # G90.1 absolute arc centres: not supported
                return UNSUPPORTED
            group, mantissa = "G4", 0  # G91.1: incremental arc centres, always so
    elif int_value in (93, 94):
        group, modal.inverse_time = "G5", int_value == 93
    elif int_value in (20, 21):
        group, modal.units_mm = "G6", int_value == 21
    elif int_value == 40:
        group = "G7"  # cutter compensation off: the only mode GRBL has
    elif int_value in (43, 49):
        if block.axis_command:
            return AXIS_CONFLICT
        block.axis_command = TOOL_LENGTH_AXES
        if int_value == 49:
            modal.tool_length = False
        elif mantissa == 10:
            modal.tool_length = True
        else:
            return UNSUPPORTED  # G43 with an H table: not supported
        group, mantissa = "G8", 0
    elif 54 <= int_value <= 59:
        group, modal.coord_select = "G12", int_value - 54
    elif int_value == 61:
        if mantissa != 0:
            return UNSUPPORTED  # G61.1
        group = "G13"
    else:
        return UNSUPPORTED
    if mantissa > 0:
        return NOT_INTEGER
    if group in groups:
        return MODAL_GROUP
    groups.add(group)
    return OK


def _m_command(
    value: float, int_value: int, mantissa: int, modal: Modal, groups: set[str], servo: bool
) -> int:
    """One M word (program flow, spindle, coolant; M280 on a servo build); a status code."""
    if servo and value == 280:
        group = "M280"
    else:
        if mantissa > 0:
            return NOT_INTEGER
        if int_value in (0, 1, 2, 30):
            group = "M4"
            if int_value == 0:
                modal.program_flow = PAUSE
            elif int_value != 1:  # M1: optional stop, ignored
                modal.program_flow = END_M2 if int_value == 2 else END_M30
        elif int_value in (3, 4, 5):
            group, modal.spindle = "M7", int_value
        elif int_value in (8, 9):
            group, modal.coolant = "M8", int_value
        else:
            return UNSUPPORTED
    if group in groups:
        return MODAL_GROUP
    groups.add(group)
    return OK
