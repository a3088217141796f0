"""What a profile's values and template lines must be for its firmware to draw correctly.

:mod:`pencilbot.machine.profile` checks each key alone (types, units, plain bounds); these checks
need the family too, and are run when a profile loads, so that no value that cannot draw correctly
gets as far as a plot, and ``export`` never writes a line the board rejects:

- pen values by what reads them: an EBB board's servo heights are percent (0 to 100; ``up = 200``
  drove the servo past its range and lost strokes); a spindle's ``S`` is 0 to 100 000 (GRBL refuses
  a negative ``S``); a servo's angle 0 to 180 degrees; a Z height within ±1 000 mm;
- an HP-GL plotter's draw feed is a ``VS`` speed the plotter takes (at most 128 cm/s);
- the EBB servo range runs from ``servo_min`` up to ``servo_max``;
- template lines: no realtime byte or ``%``, no system command (a ``$RST=*`` pen lift), no number
  in exponent form (``S1e+308``: G-code has none), each template leaves the G90 G21 the writer's
  moves assume (a header's ``G91`` or ``G20`` made every move after it wrong), no absolute X or Y
  off the bed.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from pencilbot.errors import ProfileError
from pencilbot.machine.pens import LONGEST_PEN_NAME
from pencilbot.machine.templates import TemplateError, check_template

if TYPE_CHECKING:
    from pencilbot.machine.profile import Profile

MAX_LINE = 80  # the longest line the writer produces: GRBL's line buffer, so every firmware takes it
TEMPLATE_FIELDS = ("up", "down", "draw_feed", "travel_feed", "bed_width", "bed_height")
#: A pen change's template may also name the pen asked for and its place in the load order.
PEN_CHANGE_FIELDS = (*TEMPLATE_FIELDS, "pen", "number")
#: The range of a pen's ``up`` and ``down`` by what reads them (unit in words).
PEN_RANGES = {
    "ebb": (0.0, 100.0, "percent of the servo's range"),
    "spindle": (0.0, 1e5, "spindle S value"),
    "servo": (0.0, 180.0, "servo degrees"),
    "z": (-1000.0, 1000.0, "mm of Z"),
}
#: The fastest ``VS`` an HP-GL plotter takes (cm/s): ``draw_feed`` / 600.
MAX_HPGL_SPEED = 128.0
_COMMENTS = re.compile(r"\([^)]*\)|;.*")
_AXIS_WORD = re.compile(r"([XY])\s*([-+]?(?:\d+\.?\d*|\.\d+))", re.IGNORECASE)
_EXPONENT = re.compile(r"\d\s*[eE]\s*[-+]?\s*\d")
_MODES = re.compile(r"G\s*0*(9[01]|2[01])(?![\d.])", re.IGNORECASE)


def check_values(profile: Profile, where: str) -> None:
    """Refuse pen, feed and servo values the profile's family cannot draw with, naming the key.

    Raises
    ------
    ProfileError
    """
    fw = profile.firmware
    family = "ebb" if fw.capabilities.host_motion else profile.pen.kind
    low, high, unit = PEN_RANGES[family]
    for key in ("up", "down"):
        value = getattr(profile.pen, key)
        if not low <= value <= high:
            raise ProfileError(
                f"plotter profile {where}: [pen] {key} = {value!r} is invalid; expected a number "
                f"from {low:g} to {high:g} ({unit})"
            )
    if fw.program_language == "hpgl" and profile.motion.draw_feed / 600 > MAX_HPGL_SPEED:
        raise ProfileError(
            f"plotter profile {where}: [motion] draw_feed = {profile.motion.draw_feed!r} is invalid; expected at most "
            f"{MAX_HPGL_SPEED * 600:g} mm/min (VS {MAX_HPGL_SPEED:g} cm/s, the fastest an HP-GL plotter takes)"
        )
    if fw.capabilities.host_motion and not profile.ebb.servo_min < profile.ebb.servo_max:
        raise ProfileError(
            f"plotter profile {where}: [ebb] servo_max = {profile.ebb.servo_max} is invalid; expected more than "
            f"servo_min = {profile.ebb.servo_min} (pen heights are percent of the range between them)"
        )


def check_sendable(profile: Profile, where: str, label: str, lines: list[str]) -> None:
    """Refuse template lines the board would not take as G-code: a realtime byte (GRBL's ``!``,
    ``~``, ``?``, Ctrl-X), a ``%`` tape marker, a system command, a number in exponent form, a
    template that leaves relative or inch mode in force, and, while it moves in absolute
    millimetres, an X or Y off the bed. ``draw`` refuses such a file; ``export`` must not write it.

    Raises
    ------
    ProfileError
    """
    relative = inches = False
    (x0, x1), (y0, y1) = profile.bed.machine_range()
    fw = profile.firmware
    for line in lines:
        command = _COMMENTS.sub("", line)
        problem = None
        if "%" in command:
            problem = "a '%', which GRBL refuses and senders take for a tape marker"
        elif command.strip().startswith("$"):
            name = fw.system_command(command.replace(" ", "").upper()) or command.strip()
            problem = (
                f"{name} is a system command for the board, not G-code: a plot must not change the board's "
                "settings or state (draw refuses it in a file)"
            )
        elif _EXPONENT.search(command):
            problem = "a number in exponent form, which G-code has not (keep the value in range)"
        elif command.strip() and not fw.capabilities.host_motion:  # (EBB: the host reads it)
            try:
                fw.frame(command.strip(), 1)
            except ValueError as exc:  # firmware_protocol.ProtocolError: the board cannot take it
                problem = str(exc)
        for code in _MODES.findall(command):
            relative = code == "91" if code in ("90", "91") else relative
            inches = code == "20" if code in ("20", "21") else inches
        if problem is None and not (relative or inches):
            for axis, value in _AXIS_WORD.findall(command):
                low, high = (x0, x1) if axis.upper() == "X" else (y0, y1)
                if not low - 1e-6 <= float(value) <= high + 1e-6:
                    problem = (
                        f"{axis.upper()}{value} lies off the bed (X {x0:g} .. {x1:g}, Y {y0:g} .. {y1:g} mm)"
                    )
                    break
        if problem:
            raise ProfileError(f"plotter profile {where}: {label} line {line!r} is invalid: {problem}")
    if relative or inches:
        mode = "G91 (relative)" if relative else "G20 (inches)"
        back = "G90" if relative else "G21"
        raise ProfileError(
            f"plotter profile {where}: {label} leaves {mode} in force, and every move pencilbot writes after it is "
            f"absolute millimetres; end it with {back}"
        )


def check_consistency(profile: Profile, where: str) -> None:
    """Rules that involve more than one key: templates, line numbers, pen direction, limits."""
    if profile.bed.soft_limits and not profile.bed.homing:
        raise ProfileError(
            f"plotter profile {where}: [bed] soft_limits = true is invalid without homing = true; "
            "soft limits need a homed machine (GRBL refuses $20=1 while $22=0)"
        )
    if profile.gcode.line_numbers and not profile.firmware.capabilities.line_numbers:
        raise ProfileError(
            f"plotter profile {where}: [gcode] line_numbers = true is invalid for dialect "
            f'"{profile.dialect}"; expected false ({profile.firmware.title} reads no N…*checksum lines)'
        )
    check_values(profile, where)
    if profile.pen.up == profile.pen.down:
        raise ProfileError(
            f"plotter profile {where}: [pen] up = {profile.pen.up:g} is invalid; expected a value other than "
            f"down = {profile.pen.down:g} (with both the same the pen never lifts)"
        )
    if profile.pen.kind == "z" and not profile.pen.up > profile.pen.down:
        raise ProfileError(
            f"plotter profile {where}: [pen] up = {profile.pen.up:g} is invalid for a Z pen; "
            f"expected a Z height above down = {profile.pen.down:g} mm"
        )
    for section, key, text in (
        ("pen", "up_command", profile.pen.up_command),
        ("pen", "down_command", profile.pen.down_command),
        ("gcode", "header", profile.gcode.header),
        ("gcode", "footer", profile.gcode.footer),
        ("pen_change", "command", profile.pen_change.command),
    ):
        if not text.isascii():
            raise ProfileError(
                f"plotter profile {where}: {_label(section, key)} = {text!r} is invalid; expected "
                "plain ASCII G-code (firmware reads bytes; write comments without accents)"
            )
        try:
            if section == "pen_change":  # measured with the longest name a pen may have
                check_template(text, PEN_CHANGE_FIELDS)
                lines = profile.pen_change_lines("W" * LONGEST_PEN_NAME, 99)
            else:
                check_template(text, TEMPLATE_FIELDS)
                lines = profile.render(text)
        except TemplateError as exc:
            raise ProfileError(
                f"plotter profile {where}: {_label(section, key)} = {text!r} is invalid: {exc}"
            ) from None
        if section == "pen" and not lines:
            raise ProfileError(
                f"plotter profile {where}: {_label(section, key)} is empty; expected the G-code "
                f'that moves the pen, e.g. "M3 S{{{key[:-8]}}}"'
            )
        check_sendable(profile, where, _label(section, key), lines)
        limit = MAX_LINE - (profile.firmware.frame_room if profile.gcode.line_numbers else 0)
        for line in lines:
            if len(line) > limit:
                raise ProfileError(
                    f"plotter profile {where}: {_label(section, key)} gives a line of {len(line)} "
                    f"characters; expected at most {limit} per line"
                )


def _label(section: str, key: str) -> str:
    return f"[{section}] {key}" if section else key
