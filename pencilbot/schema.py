"""Validation rules for configuration values: plotter profiles, styles and their overrides.

A :class:`Rule` says, once, what a value must be (in words, for the message) and how it is
stored. Profiles and styles are validated by tables of rules keyed by their TOML keys; defaults
live in the dataclasses the tables fill, so each default and each rule is written down once.
TOML (and ``float()`` on the command line) accept ``nan`` and ``inf``: no rule takes them as a
size.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pencilbot.errors import ProfileError


@dataclass(frozen=True)
class Rule:
    """What a configuration value must be.

    Attributes
    ----------
    expected : str
        The rule in words: "a number > 0 mm", "true or false".
    accepts : callable
        ``accepts(value) -> bool``.
    convert : callable
        How an accepted value is stored (e.g. ``float``); the value itself by default.
    """

    expected: str
    accepts: Callable[[Any], bool]
    convert: Callable[[Any], Any] = lambda value: value

    def apply(self, value, label: str, where: str):
        """``value`` converted, or :class:`ProfileError` naming ``where`` and ``label``."""
        if not self.accepts(value):
            raise ProfileError(f"{where}: {label} = {value!r} is invalid; expected {self.expected}")
        return self.convert(value)


def _is_number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def number(
    low: float | None = None,
    high: float | None = None,
    *,
    above: bool = False,
    below: bool = False,
    unit: str = "",
    as_given: bool = False,
) -> Rule:
    """A finite number in a range: ``≥ low`` (``> low`` when ``above``) and ``≤ high`` (``< high``
    when ``below``); stored as float, or ``as_given`` (an int a template prints stays an int)."""
    bounds = []
    if low is not None:
        bounds.append(f"{'>' if above else '≥'} {low:g}")
    if high is not None:
        bounds.append(f"{'<' if below else '≤'} {high:.10g}")

    def accepts(value) -> bool:
        if not _is_number(value):
            return False
        if low is not None and not (value > low if above else value >= low):
            return False
        return high is None or (value < high if below else value <= high)

    words = " ".join(["a number", " and ".join(bounds), unit]).replace("  ", " ").strip()
    return Rule(words, accepts, (lambda value: value) if as_given else float)


def any_number(unit: str) -> Rule:
    """Any finite number, kept as given (an int stays an int: a template prints ``S30``)."""
    return Rule(f"a number ({unit})", _is_number)


def whole(low: int, high: int | None = None, unit: str = "") -> Rule:
    """A whole number from ``low`` to ``high`` (no upper bound when None)."""
    span = f"from {low} to {high}" if high is not None else f"≥ {low}"
    words = f"a whole number {span}" + (f" ({unit})" if unit else "")

    def accepts(value) -> bool:
        ok = isinstance(value, int) and not isinstance(value, bool) and value >= low
        return ok and (high is None or value <= high)

    return Rule(words, accepts)


def choice(options: tuple[str, ...]) -> Rule:
    """One of ``options``."""
    return Rule(" or ".join(f'"{o}"' for o in options), lambda value: value in options)


def kind(typ: type, expected: str) -> Rule:
    """Any value of type ``typ``."""
    return Rule(expected, lambda value: isinstance(value, typ))


FLAG = kind(bool, "true or false")
TEXT = kind(str, "a string")
#: The most hatch families a style may have: each one is a pass over the page (1 000 took 150 s).
MAX_ANGLES = 8
ANGLES = Rule(
    f"a list of 1 to {MAX_ANGLES} angles in degrees, each from -360 to 360",
    lambda value: (
        isinstance(value, list)
        and 1 <= len(value) <= MAX_ANGLES
        and all(_is_number(v) and abs(v) <= 360 for v in value)
    ),
    lambda value: tuple(float(v) for v in value),
)


def has_default(cls: type, key: str) -> bool:
    """Whether dataclass ``cls`` gives field ``key`` a default (else the key is required)."""
    spec = {f.name: f for f in dataclasses.fields(cls)}[key]
    return spec.default is not dataclasses.MISSING or spec.default_factory is not dataclasses.MISSING
