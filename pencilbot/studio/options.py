"""What the page's controls may say, checked before anything runs.

Every name the page sends (style, pen set, profile) must be one the library lists: a name is
never taken as a file path. Numbers and the page go through the style's own schema
(:func:`~pencilbot.planning.style.with_overrides`), as a style file's would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from pencilbot.configs_io import config_names
from pencilbot.errors import PencilbotError
from pencilbot.machine.pens import PenSet, list_pen_sets, load_pens
from pencilbot.machine.profile import Profile, default_profile, load_profile
from pencilbot.planning.layout import page_size
from pencilbot.planning.style import Style, default_style, list_styles, load_style, with_overrides

#: The largest sheet side the page may ask for (mm): planning memory grows with the page's area
#: over the pen width, and the studio plans on every change.
MAX_SHEET_MM = 1200.0
#: The thinnest pen the page may ask for (mm), for the same reason.
MIN_STUDIO_PEN = 0.1


@dataclass(frozen=True)
class DrawingOptions:
    """The controls of the page. ``None``: the style's own value.

    Attributes
    ----------
    style, pens, profile : str
        Names from :func:`list_styles`, :func:`list_pen_sets` (``""``: one black pen) and the
        plotter profiles.
    page, orientation : str or None
        As ``pencilbot plan --page/--orientation``.
    margin, pen_width : float or None
        mm.
    line_length : int or None
        Stroke length of the line drawing, image pixels.
    hatch_coverage : float or None
        Hatch density: paper share one hatch family covers at its densest, (0, 1).
    hatch : bool or None
        Whether tone is hatched.
    """

    style: str = ""
    pens: str = ""
    profile: str = ""
    page: str | None = None
    orientation: str | None = None
    margin: float | None = None
    pen_width: float | None = None
    line_length: int | None = None
    hatch_coverage: float | None = None
    hatch: bool | None = None

    def resolved_style(self) -> Style:
        """The style with the page's values applied (checked by the style schema)."""
        overrides = {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if f.name not in ("style", "pens", "profile") and getattr(self, f.name) is not None
        }
        style = with_overrides(load_style(self.style or default_style()), overrides, where="the studio page")
        sheet = page_size(style.page, None, margin=style.margin)
        if max(sheet.width, sheet.height) > MAX_SHEET_MM:
            raise PencilbotError(
                f"page {style.page} is larger than the studio plans ({MAX_SHEET_MM:g} mm a side)"
            )
        if style.pen_width < MIN_STUDIO_PEN:
            raise PencilbotError(
                f"pen width {style.pen_width:g} mm is below the studio's {MIN_STUDIO_PEN:g} mm"
            )
        return style

    def pen_set(self) -> PenSet | None:
        return load_pens(self.pens) if self.pens else None

    def plotter(self) -> Profile:
        return load_profile(self.profile or default_profile())


def parse_options(values: dict) -> DrawingOptions:
    """:class:`DrawingOptions` from the page's JSON, every value checked.

    Raises
    ------
    PencilbotError
        An unknown control, a name that is not listed (a path, say), or a value the style refuses.
    """
    if not isinstance(values, dict):
        raise PencilbotError("the drawing options must be a JSON object")
    known = {f.name for f in fields(DrawingOptions)}
    if unknown := sorted(set(values) - known):
        raise PencilbotError(
            f"unknown drawing option {', '.join(unknown)}; known: {', '.join(sorted(known))}"
        )
    given = {key: value for key, value in values.items() if value not in (None, "")}
    for key, listing in (
        ("style", list_styles),
        ("pens", list_pen_sets),
        ("profile", lambda: config_names("plotters")),
    ):
        name = given.get(key)
        if name is not None and (not isinstance(name, str) or name not in listing()):
            raise PencilbotError(f"{key} {name!r} is not one of {', '.join(listing())}")
    for key in ("margin", "pen_width", "hatch_coverage", "line_length"):
        value = given.get(key)
        if value is not None and (
            isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value)
        ):
            raise PencilbotError(f"{key} must be a number, not {value!r}")
    options = DrawingOptions(**given)
    options.resolved_style()  # every value checked now, before a worker starts
    options.pen_set()
    return options
