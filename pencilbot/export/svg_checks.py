"""Another tool's SVG checked at the door: numbers finite and of a sane size, ``<use>`` bounded.

Run on the parsed tree before vpype reads it, so a coordinate of ``1e308`` or ``nan``, a
``scale(1e308)`` or a page ``1e308mm`` wide is one message naming the element, not a traceback
or a path dropped without a word later, and a file whose ``<use>`` elements copy copies of copies
(24 doublings of a 1.7 KB file: 16 million shapes) is refused before it is expanded.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np

from pencilbot.errors import PencilbotError

#: The largest coordinate or size a drawing may have (mm): a kilometre, beyond any plotter's bed
#: and far inside float64's exact range, so lengths and times stay finite.
MAX_DRAWING_MM = 1e6
#: The most a file's ``<use>`` elements may expand its shapes (in bytes of geometry, copies
#: counted): four times the file itself, and never less than this.
MIN_EXPANSION_BYTES = 20_000_000

# Attributes that hold coordinates, sizes or transforms.
_GEOMETRY = (
    "d",
    "points",
    "x",
    "y",
    "x1",
    "y1",
    "x2",
    "y2",
    "cx",
    "cy",
    "r",
    "rx",
    "ry",
    "width",
    "height",
    "transform",
    "viewBox",
    "stroke-width",
    "style",
)
# NaN or infinity spelt out; an exponent of 10 or more; an integer part of ten digits or more.
# Any of these in a coordinate is more than MAX_DRAWING_MM in any unit.
_WORDS = re.compile(r"(?<![a-z-])(?:nan|inf(?:inity)?)(?![a-z-])", re.I)
_EXPONENT = re.compile(r"[\d.][eE]\+?0*[1-9]\d")
# The same, found from its letter: a scan for two letters is three times faster than one for a
# digit or a dot (0.2 s instead of 0.7 s over 40 MB).
_EXPONENT_AT_E = re.compile(r"[eE](?<=[\d.][eE])\+?0*[1-9]\d")
_LONG = re.compile(r"(?<![\d.])\d{10,}")
_DIGITS = bytes(48 if 48 <= c <= 57 else 32 for c in range(256))


def _insane(text: str) -> re.Match | None:
    """The first insane number in ``text``. Each pattern runs only where a quick scan (``in``,
    a byte translation) says it may match: 50 MB of path data in about a second, not ten."""
    lower = text.lower()
    if ("nan" in lower or "inf" in lower) and (found := _WORDS.search(text)):
        return found
    if "e" in lower and (found := _EXPONENT_AT_E.search(text)):
        return _EXPONENT.search(text, found.start() - 1)  # the match as the pattern names it
    if b"0" * 10 not in text.encode("ascii", "replace").translate(_DIGITS):
        return None
    return _LONG.search(text)


_XLINK_HREF = "{http://www.w3.org/1999/xlink}href"
_SVG_NS = "http://www.w3.org/2000/svg"


def check_numbers(root: ET.Element, path, text: str | None = None) -> None:
    """Refuse an SVG whose coordinates, sizes or transforms hold NaN, infinity or a number too
    large to draw (see :data:`MAX_DRAWING_MM`), naming the element and the attribute. ``text``,
    the whole file's, is scanned first: where it holds no such number at all, no element is
    looked at one by one (a million of them cost seconds).

    Raises
    ------
    PencilbotError
    """
    if text is not None and _insane(text) is None:
        return
    for element in root.iter():
        for attribute in _GEOMETRY:
            if element is root and attribute in ("width", "height"):
                continue  # the page's size: read and bounded where it is read, with its unit
            text = element.get(attribute)
            if text is None:
                continue
            found = _insane(text)
            if found:
                raise PencilbotError(
                    f"{path}: the {attribute} of {describe(element)} holds {_around(text, found)!r}, not a finite "
                    f"number of a size a plotter draws (at most {MAX_DRAWING_MM:.0e} mm); fix or remove it"
                )


def check_uses(root: ET.Element, path, file_bytes: int) -> None:
    """Refuse an SVG whose ``<use>`` elements would expand it beyond
    ``max(4 × file_bytes, MIN_EXPANSION_BYTES)`` bytes of geometry, or refer to themselves.

    Each element costs its geometry's length (plus a little for being there); a ``<use>`` costs
    what it refers to, copies of copies multiplied out. Worked out once per element, without
    expanding anything.

    Raises
    ------
    PencilbotError
    """
    if next(root.iter(f"{{{_SVG_NS}}}use"), None) is None and next(root.iter("use"), None) is None:
        return
    by_id = {element.get("id"): element for element in root.iter() if element.get("id") is not None}
    limit = max(4 * file_bytes, MIN_EXPANSION_BYTES)
    cost: dict[int, int] = {}
    busy: set[int] = set()
    stack = [(root, False)]
    while stack:  # depth first, children before their parent, without recursion
        element, done = stack.pop()
        key = id(element)
        if key in cost:
            continue
        target = by_id.get(_href(element)) if local_name(element.tag) == "use" else None
        parts = [*element, *([target] if target is not None else [])]
        if not done:
            if key in busy:
                raise PencilbotError(
                    f"{path}: {describe(element)} contains itself through <use>; fix the reference"
                )
            busy.add(key)
            stack.append((element, True))
            stack.extend((part, False) for part in parts if id(part) not in cost)
            continue
        for part in parts:
            if id(part) not in cost:  # reached through a <use> of its own ancestor
                raise PencilbotError(
                    f"{path}: {describe(element)} contains itself through <use>; fix the reference"
                )
        busy.discard(key)
        total = (
            16
            + sum(len(element.get(name, "")) for name in ("d", "points"))
            + sum(cost[id(part)] for part in parts)
        )
        if total > limit:
            raise PencilbotError(
                f"{path}: its <use> elements repeat its shapes to more than {limit / 1e6:.0f} MB of geometry "
                f"(at {describe(element)}); flatten the clones first (Inkscape: Edit > Clone > Unlink Clone)"
            )
        cost[key] = total


def check_drawing(points: np.ndarray, path) -> None:
    """Refuse read coordinates (mm) that are not finite or lie beyond :data:`MAX_DRAWING_MM`
    (transforms can multiply sane numbers into insane ones).

    Raises
    ------
    PencilbotError
    """
    if not len(points):
        return
    with np.errstate(invalid="ignore"):
        reach = float(np.abs(points).max())
    if not np.isfinite(points).all() or not reach <= MAX_DRAWING_MM:
        raise PencilbotError(
            f"{path}: the drawing reaches {'beyond any number' if not np.isfinite(reach) else f'{reach:.3g} mm'} "
            f"from its origin, more than the {MAX_DRAWING_MM:.0e} mm a plotter drawing may; check its transforms "
            "and sizes"
        )


def describe(element: ET.Element) -> str:
    """``<path id="p3">`` or ``<path>``: an element as a message names it."""
    name = element.get("id")
    return f"<{local_name(element.tag)} id={name!r}>" if name else f"<{local_name(element.tag)}>"


def _around(text: str, found: re.Match) -> str:
    start = max(0, found.start() - 12)
    return text[start : found.end() + 12]


def _href(element: ET.Element) -> str:
    return (element.get("href") or element.get(_XLINK_HREF) or "").lstrip("#")


def local_name(tag) -> str:
    """An element's tag without its namespace: ``path``."""
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""
