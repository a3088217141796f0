"""Plotter profiles: what a machine is like, as TOML data in ``configs/plotters/*.toml``.

A profile names the firmware (its ``dialect``, a key of :mod:`pencilbot.firmware`), the bed and how its coordinates run, the feeds and
acceleration (for G-code and for the time estimate), how the pen goes up and down, and how G-code
is formatted. Shipped profiles live in ``configs/plotters/<name>.toml`` (found by :mod:`pencilbot.configs_io`
in a wheel and in a source checkout); any TOML file with the same schema works by path::

    name = "grbl-servo-a4"          # optional, defaults to the file name
    dialect = "grbl"                # the firmware: "grbl", "marlin", ... (pencilbot.firmware)
    description = "..."             # optional

    [bed]
    width = 220.0                   # mm of travel along machine X
    height = 310.0                  # mm of travel along machine Y
    origin = "bottom-left"          # corner of the bed where machine (0, 0) is, seen from above
    invert_x = false                # true: machine X runs negative into the bed (homed at +X)
    invert_y = false
    homing = false                  # limit switches at the origin corner, GRBL $22=1 (optional)
    soft_limits = false             # refuse moves off the bed, GRBL $20=1; needs homing (optional)

    [motion]
    draw_feed = 3000.0              # mm/min, pen down (G1 F)
    travel_feed = 6000.0            # mm/min, pen up (G0; GRBL uses its own max rate for G0)
    acceleration = 1000.0           # mm/s², for the time estimate
    junction_deviation = 0.01       # mm, for the time estimate

    [pen]
    kind = "spindle"                # "spindle" (servo on spindle PWM), "z" (Z axis) or "servo"
    up = 30                         # S value, Z height in mm, or servo angle in degrees
    down = 90
    up_command = "M3 S{up}"         # template, may span lines
    down_command = "M3 S{down}"
    up_delay = 0.15                 # s to wait after the pen command (dwell G4)
    down_delay = 0.15

    [gcode]
    decimals = 3                    # digits after the point in X/Y
    line_numbers = false            # Marlin only: N<n> ... *<checksum> on every command line
    receive_buffer = 128            # bytes of the board's serial receive buffer (default: the firmware's)
    header = "G21\\nG90"             # template, before the first move
    footer = ""                     # template, after the return home

    [paper]                         # optional: a plotter whose limits lie inside the sheet (HP-GL)
    offset = [10.0, 4.0]            # mm from the sheet's bottom-left corner to machine (0, 0)
    carousel = 6                    # pens the carousel holds (HP-GL SP 1..n; more pens pause)

    [pen_change]                    # optional: how a colour plan asks for the next pen
    command = "M0 (pen change: insert {pen})"   # template; also {pen} and {number} (1, 2, ...)
    park = [0.0, 0.0]               # optional: machine X, Y (mm) to move to, pen up, first

Templates may use only the plain fields ``{up}``, ``{down}``, ``{draw_feed}``, ``{travel_feed}``,
``{bed_width}``, ``{bed_height}``, optionally with a precision (``{up:.1f}``); anything else is
refused when the profile loads (:mod:`pencilbot.machine.templates`). Every mistake (unknown key,
wrong type, missing key, out-of-range value) is one :class:`~pencilbot.errors.ProfileError` that
names the file, the key and what is expected.

A profile is the neutral description of a machine: the G-code writer, the time estimate, the
driver and the virtual plotter all read it. Where the paper sits on the bed is decided by
:class:`pencilbot.machine.bed.Placement`; the pen is :attr:`Profile.pen_model`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from pencilbot import firmware as firmware_registry
from pencilbot import schema
from pencilbot.configs_io import config_names, read_config_table, user_setting
from pencilbot.errors import ProfileError
from pencilbot.firmware.base import Firmware
from pencilbot.firmware.ebb import EbbSetup
from pencilbot.machine.bed import MAX_BED, ORIGINS, Bed
from pencilbot.machine.motion import Motion
from pencilbot.machine.pen import PEN_KINDS, PenModel
from pencilbot.machine.profile_checks import MAX_LINE, PEN_CHANGE_FIELDS, TEMPLATE_FIELDS, check_consistency
from pencilbot.machine.templates import fill_template

#: A pen change when the profile gives no template: one program pause whose comment names the
#: pen (a sender reads it for its prompt and its journal; GRBL's M0 is a feed hold until ~).
PEN_CHANGE = "M0 (pen change: insert {pen})"
#: The plotter profile used when none is named.
DEFAULT_PROFILE = "grbl-servo-a4"


@dataclass(frozen=True)
class PenLift:
    """How the pen is lifted and lowered (``Profile.pen``): ``kind``, ``up``/``down`` values, command
    templates, delays in s. (A pen of a pen set, its ink and width, is :class:`pencilbot.machine.pens.Pen`.)"""

    kind: str
    up: float
    down: float
    up_command: str
    down_command: str
    up_delay: float = 0.0
    down_delay: float = 0.0


@dataclass(frozen=True)
class GcodeFormat:
    """Output format: decimals, Marlin line numbers, receive buffer bytes, header/footer."""

    decimals: int = 3
    line_numbers: bool = False
    receive_buffer: int | None = None  # bytes; None: the firmware's
    header: str = ""
    footer: str = ""


@dataclass(frozen=True)
class PenChange:
    """How the plotter asks for the next pen: a template (``{pen}``, ``{number}``), and where the
    carriage parks for it (machine mm; None: where the last layer ended)."""

    command: str = PEN_CHANGE
    park: tuple[float, float] | None = None


@dataclass(frozen=True)
class Paper:
    """Where the sheet lies against machine (0, 0): ``offset`` mm from its bottom-left corner
    (a plotter such as the HP 7475A whose hard-clip limits lie inside the sheet), and how many
    pens the plotter's ``carousel`` holds (HP-GL ``SP 1..n``; a plan with more pens pauses for
    each pen put in by hand), and the length of its plotter unit (``unit_mm``: HP-GL's 0.025 mm,
    the HP 7470A's; the HP 7475A's own manual gives 0.02488 mm, about 40.2 units per mm)."""

    offset: tuple[float, float] = (0.0, 0.0)
    carousel: int = 6
    unit_mm: float = 0.025


@dataclass(frozen=True)
class Profile:
    """A validated plotter profile; ``source`` is where it was read from (for messages)."""

    name: str
    dialect: str
    description: str
    bed: Bed
    motion: Motion
    pen: PenLift
    gcode: GcodeFormat
    pen_change: PenChange = PenChange()
    paper: Paper = Paper()
    source: str = "<profile>"
    ebb: EbbSetup = EbbSetup()  # an EBB machine's steps and servo ([ebb]); unused by others

    @cached_property
    def pen_model(self) -> PenModel:
        """The pen as the estimate, the driver and the simulator see it (commands filled in)."""
        pen = self.pen
        return PenModel(
            kind=pen.kind,
            up=float(pen.up),
            down=float(pen.down),
            up_lines=tuple(self.render(pen.up_command)),
            down_lines=tuple(self.render(pen.down_command)),
            up_delay=float(pen.up_delay),
            down_delay=float(pen.down_delay),
        )

    @property
    def firmware(self) -> Firmware:
        """The firmware the plotter runs, from the registry (what the writer, the driver and the
        simulator ask instead of comparing names)."""
        return firmware_registry.get(self.dialect)

    @property
    def receive_buffer(self) -> int:
        """Bytes of the board's serial receive buffer: the profile's, else the firmware's."""
        return self.gcode.receive_buffer or self.firmware.receive_buffer

    def template_values(self) -> dict[str, float]:
        """The values a template's ``{field}`` can name."""
        return {
            "up": self.pen.up,
            "down": self.pen.down,
            "draw_feed": self.motion.draw_feed,
            "travel_feed": self.motion.travel_feed,
            "bed_width": self.bed.width,
            "bed_height": self.bed.height,
        }

    def pen_change_lines(self, pen: str, number: int) -> list[str]:
        """The G-code that asks for pen ``pen``, the ``number``-th loaded (from 1)."""
        values = {**self.template_values(), "pen": pen, "number": number}
        text = fill_template(self.pen_change.command, values)
        return [line.strip() for line in text.splitlines() if line.strip()]

    def render(self, template: str) -> list[str]:
        """A template filled with this profile's values, as G-code lines (blank lines dropped)."""
        text = fill_template(template, self.template_values())
        return [line.strip() for line in text.splitlines() if line.strip()]


# --- schema: what every key must be; defaults are the dataclasses' -----------------------------

_TEMPLATE = schema.kind(
    str, "a string of G-code (a template using " + ", ".join(f"{{{f}}}" for f in TEMPLATE_FIELDS) + ")"
)
# Upper bounds keep every formatted line short (and catch unit mix-ups such as mm/s vs mm/min×1000).
_FEED = schema.number(1, 1e6, unit="mm/min", as_given=True)  # under 1 mm/min a plot takes years
_SECONDS = schema.number(0, 60, unit="seconds", as_given=True)
_BED = schema.number(0, MAX_BED, above=True, unit="mm", as_given=True)
_PEN_VALUE = schema.any_number("S value, Z mm or servo degrees")

_TOP: dict[str, schema.Rule] = {
    "name": schema.TEXT,
    "dialect": schema.choice(firmware_registry.names()),
    "description": schema.TEXT,
}
_TABLES: dict[str, tuple[type, dict[str, schema.Rule]]] = {
    "bed": (
        Bed,
        {
            "width": _BED,
            "height": _BED,
            "origin": schema.choice(ORIGINS),
            "invert_x": schema.FLAG,
            "invert_y": schema.FLAG,
            "homing": schema.FLAG,
            "soft_limits": schema.FLAG,
        },
    ),
    "motion": (
        Motion,
        {
            "draw_feed": _FEED,
            "travel_feed": _FEED,
            "acceleration": schema.number(1, 1e6, unit="mm/s²", as_given=True),
            "junction_deviation": schema.number(0, 10, unit="mm", as_given=True),
        },
    ),
    "pen": (
        PenLift,
        {
            "kind": schema.choice(PEN_KINDS),
            "up": _PEN_VALUE,
            "down": _PEN_VALUE,
            "up_command": _TEMPLATE,
            "down_command": _TEMPLATE,
            "up_delay": _SECONDS,
            "down_delay": _SECONDS,
        },
    ),
    "gcode": (
        GcodeFormat,
        {
            "decimals": schema.whole(0, 6, "digits after the decimal point"),
            "line_numbers": schema.FLAG,
            # one whole line (80 characters + newline) must fit, or a sender could never send it
            "receive_buffer": schema.whole(MAX_LINE + 1, 1 << 20, "bytes"),
            "header": _TEMPLATE,
            "footer": _TEMPLATE,
        },
    ),
    "paper": (
        Paper,
        {
            "offset": schema.Rule(
                "a list of two numbers, mm from the sheet's bottom-left corner to machine (0, 0)",
                lambda value: (
                    isinstance(value, list)
                    and len(value) == 2
                    and all(schema.any_number("mm").accepts(v) for v in value)
                ),
                lambda value: (float(value[0]), float(value[1])),
            ),
            "carousel": schema.whole(1, 32, "pens the carousel holds"),
            "unit_mm": schema.number(0.001, 1.0, unit="mm per plotter unit", as_given=True),
        },
    ),
    "pen_change": (
        PenChange,
        {
            "command": schema.kind(
                str,
                "a string of G-code (a template using "
                + ", ".join(f"{{{f}}}" for f in PEN_CHANGE_FIELDS)
                + ")",
            ),
            "park": schema.Rule(
                "a list of two numbers, machine X and Y in mm",
                lambda value: (
                    isinstance(value, list)
                    and len(value) == 2
                    and all(schema.any_number("mm").accepts(v) for v in value)
                ),
                lambda value: (float(value[0]), float(value[1])),
            ),
        },
    ),
    "ebb": (
        EbbSetup,
        {
            "kinematics": schema.choice(("corexy", "xy")),
            # under a step a mm, a drawing is a staircase of millimetre steps (1e-9 drew nothing)
            "steps_per_mm": schema.number(1, 1e5, unit="motor steps per mm", as_given=True),
            "microstep_mode": schema.whole(1, 5, "EM mode (1: 1/16 step .. 5: full step)"),
            "servo_min": schema.whole(1, 65535, "servo units of 83.3 ns"),
            "servo_max": schema.whole(1, 65535, "servo units of 83.3 ns"),
            "servo_rate_up": schema.whole(0, 65535, "servo units per PWM period"),
            "servo_rate_down": schema.whole(0, 65535, "servo units per PWM period"),
            "min_move_ms": schema.number(0, 100, unit="ms", as_given=True),
            "servo_pin": schema.whole(0, 7, "port B pin of the pen servo (1 standard, 2 narrow-band)"),
            "servo_channels": schema.whole(1, 8, "servo channels (SC,8): 8 standard, 1 narrow-band"),
        },
    ),
}


def load_profile(name_or_path: str | Path) -> Profile:
    """Read and validate a plotter profile by shipped name or TOML file path.

    Parameters
    ----------
    name_or_path : str or Path
        A shipped profile name (see :func:`list_profiles`), or a path to a ``.toml`` file.

    Returns
    -------
    Profile

    Raises
    ------
    ProfileError
        The profile does not exist, is not TOML, or has an unknown key, a missing key, a value
        of the wrong type or range, or a template that uses anything but plain named fields.
    """
    table, where, stem = read_config_table(
        "plotters", str(name_or_path), kind="plotter profile", file_kind="plotter profile"
    )
    return profile_from_mapping(table, where=where, default_name=stem)


def list_profiles() -> list[str]:
    """Names of the profiles there are, the user's and those shipped in ``configs/plotters``, sorted."""
    return list(config_names("plotters"))


def default_profile() -> str:
    """The profile used when none is named: ``$PENCILBOT_PROFILE``, else the user's ``profile``
    setting, else :data:`DEFAULT_PROFILE`.

    Raises
    ------
    ProfileError
        The user's settings file is not valid.
    """
    return os.environ.get("PENCILBOT_PROFILE") or user_setting("profile") or DEFAULT_PROFILE


def profile_from_mapping(table: dict, *, where: str = "<profile>", default_name: str = "custom") -> Profile:
    """Validate a parsed TOML table into a :class:`Profile` (``where`` names it in errors)."""
    context = f"plotter profile {where}"
    top = {k: v for k, v in table.items() if k not in _TABLES}
    for key in top:
        if key not in _TOP:
            raise ProfileError(
                f"{context}: unknown key {key}; expected one of: {', '.join(_TOP)} "
                "(or the tables " + ", ".join(f"[{s}]" for s in _TABLES) + ")"
            )
    if "dialect" not in top:
        raise ProfileError(f"{context}: missing key dialect; expected {_TOP['dialect'].expected}")
    values = {key: rule.apply(top[key], key, context) for key, rule in _TOP.items() if key in top}
    sections = {name: _section(table, name, cls, rules, context) for name, (cls, rules) in _TABLES.items()}
    profile = Profile(
        name=values.get("name") or default_name,
        dialect=values["dialect"],
        description=values.get("description", ""),
        **sections,
        source=where,
    )
    check_consistency(profile, where)
    return profile


def _section(table: dict, name: str, cls: type, rules: dict[str, schema.Rule], context: str):
    """Table ``[name]`` of the profile validated into a ``cls``."""
    if name not in table and not all(schema.has_default(cls, key) for key in rules):
        raise ProfileError(f"{context}: missing table [{name}]; expected keys {', '.join(rules)}")
    found = table.get(name, {})
    if not isinstance(found, dict):
        raise ProfileError(
            f"{context}: {name} = {found!r} is invalid; expected a table [{name}] with keys {', '.join(rules)}"
        )
    for key in found:
        if key not in rules:
            raise ProfileError(f"{context}: unknown key [{name}] {key}; expected one of: {', '.join(rules)}")
    for key, rule in rules.items():
        if key not in found and not schema.has_default(cls, key):
            raise ProfileError(f"{context}: missing key [{name}] {key}; expected {rule.expected}")
    return cls(
        **{
            key: rule.apply(found[key], f"[{name}] {key}", context)
            for key, rule in rules.items()
            if key in found
        }
    )
