"""How large another tool's SVG is on paper: its ``width`` and ``height`` in physical units, or
user units at a given dpi, and its ``viewBox`` (both readers of :mod:`pencilbot.export.svg_read`)."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from pencilbot.errors import PencilbotError
from pencilbot.export.svg_checks import MAX_DRAWING_MM
from pencilbot.units import CSS_PX_PER_INCH, MM_PER_INCH

NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")

UNITS_TO_MM = {
    "mm": 1.0,
    "cm": 10.0,
    "q": 0.25,
    "in": MM_PER_INCH,
    "pt": MM_PER_INCH / 72,
    "pc": MM_PER_INCH / 6,
    "px": MM_PER_INCH / CSS_PX_PER_INCH,
}


def size_unit(root: ET.Element) -> str | None:
    """The physical unit both ``width`` and ``height`` are given in, or None."""
    width, height = (
        re.fullmatch(rf"\s*{NUMBER.pattern}\s*([a-zA-Z]*)\s*", root.get(attr, ""))
        for attr in ("width", "height")
    )
    if width and height and width[1].lower() in UNITS_TO_MM and height[1].lower() in UNITS_TO_MM:
        return width[1].lower()
    return None


def px_per_inch(root: ET.Element, dpi: float | None) -> float:
    """User units per inch: CSS pixels where width and height are physical sizes, else ``dpi``
    (given: without it, :func:`svg_size` has refused the file)."""
    if size_unit(root):
        return CSS_PX_PER_INCH
    assert dpi is not None
    return dpi


def svg_size(root: ET.Element, path, dpi: float | None) -> tuple[float, float | None, float]:
    """Page width and height in mm (None if the file gives no size at all) and mm per user unit."""
    box = [float(v) for v in NUMBER.findall(root.get("viewBox", ""))]
    view = box if len(box) == 4 and box[2] > 0 and box[3] > 0 else None
    if (unit_given := size_unit(root)) is not None:
        sizes = []
        for attr in ("width", "height"):
            given_number = NUMBER.search(root.get(attr, ""))
            assert given_number is not None  # _size_unit found one
            number = float(given_number[0]) * UNITS_TO_MM[unit_given]
            if not 0 < number <= MAX_DRAWING_MM:
                raise PencilbotError(
                    f"{path}: the SVG's {attr} {root.get(attr)!r} is not a size; give width and height in mm"
                )
            sizes.append(number)
        return sizes[0], sizes[1], sizes[0] / view[2] if view else UNITS_TO_MM[unit_given]
    given = (
        f"width {root.get('width')!r} and height {root.get('height')!r}"
        if root.get("width")
        else "no width or height"
    )
    if dpi is None:
        raise PencilbotError(
            f"{path} gives {given}, no size on paper (no mm, cm, in, pt or px), so how large to draw it is "
            "unknown; add --svg-dpi 96 to read its units as CSS pixels (as Inkscape does), or --page A4 "
            "to fit it onto a sheet"
        )
    unit = MM_PER_INCH / dpi
    given_width, given_height = (
        NUMBER.fullmatch((root.get(attr) or "").strip()) for attr in ("width", "height")
    )
    if (
        given_width
        and given_height
        and all(0 < float(n[0]) * unit <= MAX_DRAWING_MM for n in (given_width, given_height))
    ):
        width, height = (float(n[0]) * unit for n in (given_width, given_height))
        return width, height, width / view[2] if view else unit
    if view:
        return view[2] * unit, view[3] * unit, unit
    return 0.0, None, unit
