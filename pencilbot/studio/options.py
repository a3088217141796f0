"""What the page's controls may say, checked before anything runs.

Every name the page sends (style, pen set, profile) must be one the library lists: a name is
never taken as a file path. The controls become a :class:`~pencilbot.app.photo.PhotoRequest`
with the studio's :data:`~pencilbot.app.photo.INTERACTIVE` limits, checked by the application
layer as every front door's is (the style's schema, the sheet and pen caps, memory).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from pencilbot.app.photo import INTERACTIVE, PhotoRequest, Prepared, prepare
from pencilbot.configs_io import config_names
from pencilbot.errors import PencilbotError
from pencilbot.machine.pens import list_pen_sets
from pencilbot.machine.profile import Profile, default_profile, load_profile
from pencilbot.planning.style import Style, default_style, list_styles

#: Dots per inch of the page's previews: the full one shows the real pen width (0.3 mm ~ 1 px).
PREVIEW_DPI = 100.0


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
    face_lines : bool or None
        Whether a face's eyes, brows and mouth are also drawn in pen lines (the style's
        ``face_lines``).
    time_budget : float or None
        How long the plot may take, times the default (the style's ``time_budget``).
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
    face_lines: bool | None = None
    time_budget: float | None = None

    def request(self) -> PhotoRequest:
        """The request these controls make, with the studio's limits and its preview's memory."""
        overrides = {
            f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("style", "pens", "profile")
        }
        return PhotoRequest(
            style=self.style or default_style(),
            overrides=overrides,
            where="the studio page",
            pens=self.pens or None,
            preview_dpi=PREVIEW_DPI,
            limits=INTERACTIVE,
        )

    def prepared(self) -> Prepared:
        """The request resolved and checked (:func:`pencilbot.app.photo.prepare`)."""
        return prepare(self.request())

    def resolved_style(self) -> Style:
        """The style with the page's values applied, every guard passed."""
        return self.prepared().style

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
    for key in ("margin", "pen_width", "hatch_coverage", "line_length", "time_budget"):
        value = given.get(key)
        if value is not None and (
            isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value)
        ):
            raise PencilbotError(f"{key} must be a number, not {value!r}")
    options = DrawingOptions(**given)
    options.prepared()  # every value checked now, before a worker starts
    return options
