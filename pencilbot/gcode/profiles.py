"""Plotter profiles: what a machine is like, as TOML data in ``pencilbot/configs/plotters/*.toml``.

A profile names the firmware dialect, the bed and how its coordinates run, the feeds and
acceleration (for G-code and for the time estimate), how the pen goes up and down, and how G-code
is formatted. Shipped profiles live in the package ``pencilbot.configs`` (``plotters/<name>.toml``,
read with :mod:`importlib.resources`); any TOML file with the same schema works by path::

    name = "grbl-servo-a4"          # optional, defaults to the file name
    dialect = "grbl"                # "grbl" or "marlin"
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
    receive_buffer = 128            # bytes of the firmware's serial receive buffer
    header = "G21\\nG90"             # template, before the first move
    footer = ""                     # template, after the return home

Templates may use only the plain fields ``{up}``, ``{down}``, ``{draw_feed}``, ``{travel_feed}``,
``{bed_width}``, ``{bed_height}``, optionally with a precision (``{up:.1f}``); anything else is
refused when the profile loads (:mod:`pencilbot.gcode.templates`). Every mistake (unknown key,
wrong type, missing key, out-of-range value) is one :class:`~pencilbot.errors.ProfileError` that
names the file, the key and what is expected.

Where the paper sits on the bed is decided by :class:`pencilbot.gcode.writer.Placement`.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pencilbot.configs_io import read_config_text, shipped_names
from pencilbot.errors import ProfileError
from pencilbot.gcode.templates import TemplateError, check_template, fill_template

DIALECTS = ("grbl", "marlin")
ORIGINS = ("bottom-left", "top-left", "bottom-right", "top-right")
PEN_KINDS = ("spindle", "z", "servo")
MAX_LINE = 80  # GRBL's line buffer; the longest line the writer produces
FRAME_ROOM = 13  # "N1234567 " + "*255": what Marlin line numbering adds to a line
TEMPLATE_FIELDS = ("up", "down", "draw_feed", "travel_feed", "bed_width", "bed_height")
MAX_BED = 10_000  # mm; keeps every coordinate within five integer digits


@dataclass(frozen=True)
class Bed:
    """Drawable area: ``width`` × ``height`` mm from the ``origin`` corner, axis directions, and
    whether the firmware homes there and enforces the bed as soft limits."""

    width: float
    height: float
    origin: str = "bottom-left"
    invert_x: bool = False
    invert_y: bool = False
    homing: bool = False
    soft_limits: bool = False


@dataclass(frozen=True)
class Motion:
    """Feeds in mm/min, acceleration in mm/s², junction deviation in mm."""

    draw_feed: float
    travel_feed: float
    acceleration: float
    junction_deviation: float


@dataclass(frozen=True)
class Pen:
    """How the pen moves: ``kind``, ``up``/``down`` values, command templates, delays in s."""

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
    receive_buffer: int = 128
    header: str = ""
    footer: str = ""


@dataclass(frozen=True)
class Profile:
    """A validated plotter profile; ``source`` is where it was read from (for messages)."""

    name: str
    dialect: str
    description: str
    bed: Bed
    motion: Motion
    pen: Pen
    gcode: GcodeFormat
    source: str = "<profile>"

    def motion_settings(self):
        """The :class:`pencilbot.planning.motion.MotionSettings` for the time estimate (mm/s)."""
        from pencilbot.planning.motion import MotionSettings

        return MotionSettings(
            draw_speed=self.motion.draw_feed / 60.0,
            travel_speed=self.motion.travel_feed / 60.0,
            acceleration=self.motion.acceleration,
            junction_deviation=self.motion.junction_deviation,
            pen_up_delay=self.pen.up_delay,
            pen_down_delay=self.pen.down_delay,
        )

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

    def render(self, template: str) -> list[str]:
        """A template filled with this profile's values, as G-code lines (blank lines dropped)."""
        text = fill_template(template, self.template_values())
        return [line.strip() for line in text.splitlines() if line.strip()]


# --- schema: (table, key) -> (check, default or _REQUIRED) -------------------------------------
_REQUIRED = object()


def _number(low: float, high: float = float("inf"), *, open_low: bool, unit: str):
    bound = f"> {low:g}" if open_low else f"≥ {low:g}"
    upper = f" and ≤ {high:.10g}" if high != float("inf") else ""
    expected = f"a number {bound}{upper} ({unit})"

    def check(value):
        if isinstance(value, bool) or not isinstance(value, int | float):
            return None, expected
        ok = (value > low if open_low else value >= low) and value <= high
        return (value if ok else None), expected

    return check


def _choice(options: tuple[str, ...]):
    expected = " or ".join(f'"{o}"' for o in options)
    return lambda v: (v if v in options else None, expected)


def _kind(typ: type, expected: str):
    return lambda v: (v if isinstance(v, typ) else None, expected)


def _whole(low: int, high: int, unit: str):
    expected = f"a whole number from {low} to {high} ({unit})"

    def check(value):
        ok = isinstance(value, int) and not isinstance(value, bool) and low <= value <= high
        return (value if ok else None), expected

    return check


def _any_number(unit: str):
    expected = f"a number ({unit})"
    # ints stay ints so a template prints "S30", not "S30.0"
    return lambda v: (v if isinstance(v, int | float) and not isinstance(v, bool) else None, expected)


_TEXT = _kind(str, "a string")
_TEMPLATE = _kind(str, "a string of G-code (a template using " + ", ".join(
    f"{{{f}}}" for f in TEMPLATE_FIELDS) + ")")
_FLAG = _kind(bool, "true or false")
# Upper bounds keep every formatted line short (and catch unit mix-ups such as mm/s vs mm/min×1000).
_FEED = _number(0, 1e6, open_low=True, unit="mm/min")
_SECONDS = _number(0, 60, open_low=False, unit="seconds")
_BED = _number(0, MAX_BED, open_low=True, unit="mm")

_SCHEMA: dict[str, dict[str, tuple[Any, Any]]] = {
    "": {
        "name": (_TEXT, None),  # None: the file name
        "dialect": (_choice(DIALECTS), _REQUIRED),
        "description": (_TEXT, ""),
    },
    "bed": {
        "width": (_BED, _REQUIRED),
        "height": (_BED, _REQUIRED),
        "origin": (_choice(ORIGINS), _REQUIRED),
        "invert_x": (_FLAG, False),
        "invert_y": (_FLAG, False),
        "homing": (_FLAG, False),
        "soft_limits": (_FLAG, False),
    },
    "motion": {
        "draw_feed": (_FEED, _REQUIRED),
        "travel_feed": (_FEED, _REQUIRED),
        "acceleration": (_number(0, open_low=True, unit="mm/s²"), _REQUIRED),
        "junction_deviation": (_number(0, open_low=False, unit="mm"), _REQUIRED),
    },
    "pen": {
        "kind": (_choice(PEN_KINDS), _REQUIRED),
        "up": (_any_number("S value, Z mm or servo degrees"), _REQUIRED),
        "down": (_any_number("S value, Z mm or servo degrees"), _REQUIRED),
        "up_command": (_TEMPLATE, _REQUIRED),
        "down_command": (_TEMPLATE, _REQUIRED),
        "up_delay": (_SECONDS, 0.0),
        "down_delay": (_SECONDS, 0.0),
    },
    "gcode": {
        "decimals": (_whole(0, 6, "digits after the decimal point"), 3),
        "line_numbers": (_FLAG, False),
        # one whole line (80 characters + newline) must fit, or a sender could never send it
        "receive_buffer": (_whole(MAX_LINE + 1, 1 << 20, "bytes"), 128),
        "header": (_TEMPLATE, ""),
        "footer": (_TEMPLATE, ""),
    },
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
    text, where, stem = read_config_text("plotters", str(name_or_path), kind="plotter profile", file_kind="plotter profile")
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(f"plotter profile {where} is not valid TOML ({exc}); fix the syntax") from None
    return profile_from_mapping(table, where=where, default_name=stem)


def list_profiles() -> list[str]:
    """Names of the profiles shipped in ``pencilbot/configs/plotters``, sorted."""
    return shipped_names("plotters")


def profile_from_mapping(table: dict, *, where: str = "<profile>", default_name: str = "custom") -> Profile:
    """Validate a parsed TOML table into a :class:`Profile` (``where`` names it in errors)."""
    values = {section: _section(table, section, where) for section in _SCHEMA}
    top = values[""]
    profile = Profile(
        name=top["name"] or default_name,
        dialect=top["dialect"],
        description=top["description"],
        bed=Bed(**values["bed"]),
        motion=Motion(**values["motion"]),
        pen=Pen(**values["pen"]),
        gcode=GcodeFormat(**values["gcode"]),
        source=where,
    )
    _check_consistency(profile, where)
    return profile


def _section(table: dict, section: str, where: str) -> dict:
    schema = _SCHEMA[section]
    if section:
        if section not in table:
            raise ProfileError(
                f"plotter profile {where}: missing table [{section}]; expected keys "
                f"{', '.join(schema)}"
            )
        found = table[section]
        if not isinstance(found, dict):
            raise ProfileError(
                f"plotter profile {where}: {section} = {found!r} is invalid; expected a table "
                f"[{section}] with keys {', '.join(schema)}"
            )
    else:
        found = {k: v for k, v in table.items() if k not in _SCHEMA}
    for key in found:
        if key not in schema:
            raise ProfileError(
                f"plotter profile {where}: unknown key {_label(section, key)}; "
                f"expected one of: {', '.join(schema)}"
                + ("" if section else " (or the tables " + ", ".join(f"[{s}]" for s in _SCHEMA if s) + ")")
            )
    values = {}
    for key, (check, default) in schema.items():
        if key not in found:
            if default is _REQUIRED:
                raise ProfileError(
                    f"plotter profile {where}: missing key {_label(section, key)}; "
                    f"expected {check(None)[1]}"
                )
            values[key] = default
            continue
        value, expected = check(found[key])
        if value is None:
            raise ProfileError(
                f"plotter profile {where}: {_label(section, key)} = {found[key]!r} is invalid; "
                f"expected {expected}"
            )
        values[key] = value
    return values


def _check_consistency(profile: Profile, where: str) -> None:
    """Rules that involve more than one key: templates, line numbers, pen direction, limits."""
    if profile.bed.soft_limits and not profile.bed.homing:
        raise ProfileError(
            f"plotter profile {where}: [bed] soft_limits = true is invalid without homing = true; "
            "soft limits need a homed machine (GRBL refuses $20=1 while $22=0)"
        )
    if profile.gcode.line_numbers and profile.dialect != "marlin":
        raise ProfileError(
            f"plotter profile {where}: [gcode] line_numbers = true is invalid for dialect "
            f'"{profile.dialect}"; expected false (only Marlin reads N…*checksum lines)'
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
    ):
        if not text.isascii():
            raise ProfileError(
                f"plotter profile {where}: {_label(section, key)} = {text!r} is invalid; expected "
                "plain ASCII G-code (firmware reads bytes; write comments without accents)"
            )
        try:
            check_template(text, TEMPLATE_FIELDS)
            lines = profile.render(text)
        except TemplateError as exc:
            raise ProfileError(
                f"plotter profile {where}: {_label(section, key)} = {text!r} is invalid: {exc}"
            ) from None
        if section == "pen" and not lines:
            raise ProfileError(
                f"plotter profile {where}: {_label(section, key)} is empty; expected the G-code "
                f"that moves the pen, e.g. \"M3 S{{{key[:-8]}}}\""
            )
        limit = MAX_LINE - (FRAME_ROOM if profile.gcode.line_numbers else 0)
        for line in lines:
            if len(line) > limit:
                raise ProfileError(
                    f"plotter profile {where}: {_label(section, key)} gives a line of {len(line)} "
                    f"characters; expected at most {limit} per line"
                )


def _label(section: str, key: str) -> str:
    return f"[{section}] {key}" if section else key
