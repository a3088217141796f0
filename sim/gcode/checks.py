"""GRBL 1.1h's step 3 of ``gc_execute_line``: a block whose words were read
(:func:`sim.gcode.parser.parse_block`) checked as a whole, in GRBL's order — line number, feed,
dwell, units, tool length, coordinate systems and the non-modal commands (G10, G28/G30, G53,
G92), the motion mode (G0/G1, arcs by radius or centre offsets, probes), the unused words — with
the machine targets filled in. The first failure is the answer, as on the board."""

from __future__ import annotations

import math

from pencilbot.units import MM_PER_INCH
from sim.gcode.state import (
    ARC_RADIUS,
    AXIS_WORDS_UNUSED,
    BAD_LINE_NUMBER,
    CCW_ARC,
    COORD_SYSTEMS,
    CW_ARC,
    G28_INDEX,
    G30_INDEX,
    G53_MOTION,
    INVALID_JOG,
    INVALID_TARGET,
    LINEAR,
    MAX_LINE_NUMBER,
    MOTION_AXES,
    NO_AXIS_COMMAND,
    NO_AXIS_IN_PLANE,
    NO_AXIS_WORDS,
    NO_MOTION,
    NO_OFFSETS_IN_PLANE,
    OK,
    SEEK,
    TOOL_LENGTH_AXES,
    TOOL_LENGTH_AXIS,
    UNDEFINED_FEED,
    UNSUPPORTED,
    UNSUPPORTED_COORD,
    UNUSED_WORDS,
    VALUE_MISSING,
    Block,
    ParserState,
)

_AXES = "XYZ"


def check_block(
    block: Block,
    state: ParserState,
    groups: set[str],
    values: dict[str, float],
    axes: dict[int, float],
    ijk: dict[int, float],
    jog: bool,
) -> Block | int:
    """GRBL's step 3: the block as a whole, in GRBL's order; fills in the machine targets."""
    modal = block.modal
    unused = set(values)
    if axes and not block.axis_command:
        block.axis_command = MOTION_AXES  # axis words alone move in the current motion mode
    if math.trunc(values.get("N", 0)) > MAX_LINE_NUMBER:
        return BAD_LINE_NUMBER
    inch = not modal.units_mm
    code = _check_feed(block, state, values, jog, inch)
    if code:
        return code
    block.spindle_speed = values.get("S", state.spindle_speed)
    block.tool = math.trunc(values["T"]) % 256 if "T" in values else state.tool
    block.line_number = math.trunc(values.get("N", 0))
    if block.non_modal == 4:
        if "P" not in values:
            return VALUE_MISSING
        block.dwell = values["P"]
        unused.discard("P")
    if inch:
        axes = {i: v * MM_PER_INCH for i, v in axes.items()}
    if block.axis_command == TOOL_LENGTH_AXES and modal.tool_length and set(axes) != {2}:
        return TOOL_LENGTH_AXIS
    block.coord_system = state.coord_system
    if "G12" in groups and modal.coord_select != state.modal.coord_select:
        block.coord_system = state.coord_data[modal.coord_select]

    position = state.position
    target = [0.0, 0.0, 0.0]  # GRBL leaves the target zeroed when a block has no axis words
    code = _check_coords(block, state, axes, values, unused, target)
    if code:
        return code
    if block.axis_command == TOOL_LENGTH_AXES:
        block.tool_length_offset = axes.get(2, 0.0) if modal.tool_length else 0.0

    code = _check_motion(block, position, target, axes, ijk, values, unused, inch)
    if code:
        return code
    unused -= {"N", "F"} if jog else {"N", "F", "S", "T"}
    if block.axis_command:
        unused -= set(_AXES)
    if "M280" in groups:
        if "S" not in values:
            return VALUE_MISSING
        block.servo_angle = values["S"]
        block.spindle_speed = state.spindle_speed  # M280's S is an angle, not a speed
        unused.discard("P")
    if unused:
        return UNUSED_WORDS
    if jog and (groups - {"G3", "G6", "G0"} or block.non_modal not in (0, 53)):
        return INVALID_JOG
    block.target = tuple(target)
    return block


def _check_feed(block: Block, state: ParserState, values: dict[str, float], jog: bool, inch: bool) -> int:
    """The block's feed, in GRBL's order; 0 or GRBL's error."""
    modal = block.modal
    # Feed: jogs need their own F; G93 needs F on every feed move; G94 keeps the last F.
    if jog:
        if "F" not in values:
            return UNDEFINED_FEED
        block.feed = values["F"] * (MM_PER_INCH if inch else 1.0)
    elif modal.inverse_time:
        if block.axis_command == MOTION_AXES and modal.motion not in (NO_MOTION, SEEK) and "F" not in values:
            return UNDEFINED_FEED
        block.feed = values.get("F", 0.0)
    elif not state.modal.inverse_time:
        block.feed = values["F"] * (MM_PER_INCH if inch else 1.0) if "F" in values else state.feed
    else:  # G93 to G94: the F of this block as written (GRBL converts no inches here), else 0
        block.feed = values.get("F", 0.0)
    return OK


def _check_coords(
    block: Block,
    state: ParserState,
    axes: dict[int, float],
    values: dict[str, float],
    unused: set[str],
    target: list[float],
) -> int:
    """G10 and G92 (the offsets they write), else the machine target of the axis words (G53, the
    work offsets, relative moves) and G28/G30's home; 0 or GRBL's error."""
    position = state.position
    modal = block.modal
    if block.non_modal == 10:
        if not axes:
            return NO_AXIS_WORDS
        if "P" not in values and "L" not in values:
            return VALUE_MISSING
        select = math.trunc(values.get("P", 0)) % 256
        if select > COORD_SYSTEMS:
            return UNSUPPORTED_COORD
        l_value = math.trunc(values.get("L", 0)) % 256
        if l_value != 20 and (l_value != 2 or "R" in values):
            return UNSUPPORTED
        unused -= {"L", "P"}
        index = select - 1 if select > 0 else modal.coord_select
        offset = list(state.coord_data[index])
        for i, v in axes.items():
            if l_value == 20:  # the offset that makes the current position read v
                offset[i] = (
                    position[i] - state.coord_offset[i] - v - (state.tool_length_offset if i == 2 else 0.0)
                )
            else:
                offset[i] = v
        block.coord_write = (index, tuple(offset))
    elif block.non_modal == 92:
        if not axes:
            return NO_AXIS_WORDS
        block.coord_offset = tuple(
            position[i] - block.coord_system[i] - axes[i] - (state.tool_length_offset if i == 2 else 0.0)
            if i in axes
            else state.coord_offset[i]
            for i in range(3)
        )
    else:
        if block.axis_command != TOOL_LENGTH_AXES and axes:
            for i in range(3):
                if i not in axes:
                    target[i] = position[i]
                elif block.non_modal == 53:
                    target[i] = axes[i]
                elif modal.absolute:
                    target[i] = axes[i] + block.coord_system[i] + state.coord_offset[i]
                    if i == 2:
                        target[i] += state.tool_length_offset
                else:
                    target[i] = axes[i] + position[i]
        if block.non_modal in (28, 30):
            home = list(state.coord_data[G28_INDEX if block.non_modal == 28 else G30_INDEX])
            if axes:
                for i in range(3):
                    if i not in axes:
                        home[i] = position[i]  # only the named axes go home
            else:
                block.axis_command = NO_AXIS_COMMAND  # no via point
            block.home = tuple(home)
        elif block.non_modal == 53 and modal.motion not in (SEEK, LINEAR):
            return G53_MOTION
    return OK


def _check_motion(
    block: Block,
    position,
    target: list[float],
    axes: dict[int, float],
    ijk: dict[int, float],
    values: dict[str, float],
    unused: set[str],
    inch: bool,
) -> int:
    """The motion mode's checks (G0/G1, arcs, probes); 0 or GRBL's error."""
    modal = block.modal
    if modal.motion == NO_MOTION:
        if axes:
            return AXIS_WORDS_UNUSED
    elif block.axis_command == MOTION_AXES:
        if modal.motion == SEEK:
            if not axes:
                block.axis_command = NO_AXIS_COMMAND
        else:
            if block.feed == 0.0:
                return UNDEFINED_FEED
            if modal.motion == LINEAR:
                if not axes:
                    block.axis_command = NO_AXIS_COMMAND
            elif modal.motion in (CW_ARC, CCW_ARC):
                code = _check_arc(block, position, target, axes, ijk, values, unused, inch)
                if code:
                    return code
            else:  # probes
                if not axes:
                    return NO_AXIS_WORDS
                if tuple(target) == tuple(position):
                    return INVALID_TARGET

    return OK


def _check_arc(
    block: Block,
    position,
    target: list[float],
    axes: dict[int, float],
    ijk: dict[int, float],
    values: dict[str, float],
    unused: set[str],
    inch: bool,
) -> int:
    """G2/G3 checks and the centre offset (GRBL's radius and centre-offset formats)."""
    axis_0, axis_1, _ = block.axes
    if not axes:
        return NO_AXIS_WORDS
    if axis_0 not in axes and axis_1 not in axes:
        return NO_AXIS_IN_PLANE
    x = target[axis_0] - position[axis_0]
    y = target[axis_1] - position[axis_1]
    offset = [0.0, 0.0, 0.0]
    clockwise = block.modal.motion == CW_ARC
    if "R" in values:
        unused.discard("R")
        if tuple(target) == tuple(position):
            return INVALID_TARGET
        r = values["R"] * (MM_PER_INCH if inch else 1.0)
        h2 = 4.0 * r * r - x * x - y * y
        if h2 < 0:
            return ARC_RADIUS
        chord = math.hypot(x, y)
        if chord == 0:
            # The target differs from the start only along the linear axis. GRBL divides by
            # this zero chord in float: its centre offsets come out NaN and mc_arc's segment
            # count 0, so the board moves straight to the target. A zero offset and radius
            # give arc_chords that one straight move.
            block.arc = ((0.0, 0.0, 0.0), 0.0, clockwise)
            return OK
        # Centre on the perpendicular bisector of the chord; the sign picks the side: the
        # short way round for R > 0, the long way (more than 180°) for R < 0.
        h_x2_div_d = -math.sqrt(h2) / chord
        if not clockwise:
            h_x2_div_d = -h_x2_div_d
        if r < 0:
            h_x2_div_d, r = -h_x2_div_d, -r
        offset[axis_0] = 0.5 * (x - y * h_x2_div_d)
        offset[axis_1] = 0.5 * (y + x * h_x2_div_d)
        radius = r
    else:
        if axis_0 not in ijk and axis_1 not in ijk:
            return NO_OFFSETS_IN_PLANE
        unused -= {"I", "J", "K"}
        for i, v in ijk.items():
            offset[i] = v * (MM_PER_INCH if inch else 1.0)
        radius = math.hypot(offset[axis_0], offset[axis_1])
        target_r = math.hypot(x - offset[axis_0], y - offset[axis_1])
        delta_r = abs(target_r - radius)
        if delta_r > 0.005 and (delta_r > 0.5 or delta_r > 0.001 * radius):
            return INVALID_TARGET  # start and end are not on one circle
    block.arc = (tuple(offset), radius, clockwise)
    return OK
