"""Pen sets: the pens a plotter draws a colour plan with, as TOML data in ``configs/pens/*.toml``.

A pen set names its pens in any order; each has a name (what the plotter asks for at a pen
change), an sRGB colour and the width of the line it draws::

    description = "process colours"   # optional

    [[pen]]
    name = "cyan"                     # letters, digits, spaces and - _ . + (at most 24)
    color = "#009fe3"                 # sRGB, #rrggbb
    width = 0.5                       # mm

Shipped sets live in ``configs/pens/`` (``black``, ``cmyk``, ``primaries``, ``fineliner6``), the
user's own in the ``pens`` folder of their pencilbot folder (found first); a path to any TOML
file works too. Every mistake (unknown key, a colour that is not ``#rrggbb``, a width out of
range, two pens of one name) is one :class:`~pencilbot.errors.ProfileError` naming the file, the
pen and the key. A plan draws the pens in :attr:`PenSet.load_order`: lightest first, darkest
last, so a dark ink never smears under a light one and the contours (drawn in the darkest
pen) come last.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pencilbot import schema
from pencilbot.colors import LUMINANCE, hex_to_rgb, srgb_to_linear
from pencilbot.configs_io import config_names, read_config_table
from pencilbot.errors import ProfileError

#: Thinnest and widest pen a set may hold, mm (a plan's hatch spacing follows the width).
PEN_WIDTH_RANGE = (0.05, 5.0)
#: The most pens a set may hold (60 took 150 s and 6 GB to plan, 12 took 49 s).
MAX_PENS = 8
#: What a pen's name may be: it goes into G-code comments (``M0 (pen change: insert NAME)``),
#: which allow no parentheses and must stay within GRBL's 80-character line.
LONGEST_PEN_NAME = 24
PEN_NAME = re.compile(rf"[A-Za-z0-9][A-Za-z0-9 _.+-]{{0,{LONGEST_PEN_NAME - 1}}}")
_COLOR = re.compile(r"#[0-9a-fA-F]{6}")


@dataclass(frozen=True)
class Pen:
    """One pen: ``name``, sRGB ``color`` as ``#rrggbb``, line ``width`` in mm."""

    name: str
    color: str
    width: float

    @property
    def rgb(self) -> np.ndarray:
        """The colour as sRGB floats in [0, 1], shape (3,)."""
        return hex_to_rgb(self.color)

    @property
    def luminance(self) -> float:
        """Relative luminance of the ink in [0, 1] (0 = black), from linear light."""
        return float(srgb_to_linear(self.rgb) @ LUMINANCE)


@dataclass(frozen=True)
class PenSet:
    """A set of pens (as listed in its file) and where it was read from."""

    name: str
    pens: tuple[Pen, ...]
    description: str = ""
    source: str = "<pens>"

    @property
    def load_order(self) -> tuple[Pen, ...]:
        """The pens in the order a plan draws them: lightest ink first, the darkest last."""
        return tuple(sorted(self.pens, key=lambda pen: -pen.luminance))

    @property
    def darkest(self) -> Pen:
        """The pen the contours are drawn with."""
        return self.load_order[-1]

    def pen(self, name: str) -> Pen:
        """The pen called ``name`` (``KeyError`` if the set has none)."""
        for pen in self.pens:
            if pen.name == name:
                return pen
        raise KeyError(name)


def load_pens(name_or_path: str | Path) -> PenSet:
    """Read a pen set by shipped name (e.g. ``"cmyk"``) or from a TOML file path.

    Raises
    ------
    ProfileError
        No such set, not TOML, or a key, pen name, colour or width that is not as documented.
    """
    table, where, stem = read_config_table(
        "pens", str(name_or_path), kind="pen set", file_kind="pen set file"
    )
    return pens_from_mapping(table, where=where, name=stem)


def list_pen_sets() -> list[str]:
    """Names of the pen sets there are: the user's and those shipped in ``configs/pens``."""
    return list(config_names("pens"))


def pens_from_mapping(table: dict, *, where: str = "<pens>", name: str = "custom") -> PenSet:
    """Validate a parsed TOML table into a :class:`PenSet` (``where`` names it in errors)."""
    context = f"pen set {where}"
    for key in table:
        if key not in ("description", "pen"):
            raise ProfileError(f"{context}: unknown key {key}; expected description and [[pen]] tables")
    description = schema.TEXT.apply(table.get("description", ""), "description", context)
    found = table.get("pen")
    if not isinstance(found, list) or not found or not all(isinstance(p, dict) for p in found):
        raise ProfileError(f"{context}: expected one [[pen]] table per pen (name, color, width); found none")
    if len(found) > MAX_PENS:
        raise ProfileError(
            f"{context}: {len(found)} pens; a set holds at most {MAX_PENS} (each pen is a pass "
            "of planning and a pen change at the plotter)"
        )
    pens = [_pen(entry, number, context) for number, entry in enumerate(found, start=1)]
    names = [pen.name for pen in pens]
    for pen in pens:
        if names.count(pen.name) > 1:
            raise ProfileError(f"{context}: two pens are called {pen.name!r}; give each pen its own name")
    return PenSet(name=name, pens=tuple(pens), description=description, source=where)


_PEN_RULES = {
    "name": schema.Rule(
        f"a name of letters, digits, spaces and - _ . + (at most {LONGEST_PEN_NAME}, starting with a letter or digit)",
        lambda value: isinstance(value, str) and PEN_NAME.fullmatch(value) is not None,
    ),
    "color": schema.Rule(
        'an sRGB colour written #rrggbb, e.g. "#009fe3"',
        lambda value: isinstance(value, str) and _COLOR.fullmatch(value) is not None,
        lambda value: value.lower(),
    ),
    "width": schema.number(*PEN_WIDTH_RANGE, unit="mm"),
}


def _pen(entry: dict, number: int, context: str) -> Pen:
    label = f"pen {number}" + (f" ({entry['name']!r})" if isinstance(entry.get("name"), str) else "")
    for key in entry:
        if key not in _PEN_RULES:
            raise ProfileError(f"{context}: {label} has unknown key {key}; expected {', '.join(_PEN_RULES)}")
    for key, rule in _PEN_RULES.items():
        if key not in entry:
            raise ProfileError(f"{context}: {label} has no {key}; expected {rule.expected}")
    return Pen(**{key: rule.apply(entry[key], f"{label} {key}", context) for key, rule in _PEN_RULES.items()})
