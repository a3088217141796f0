"""The library API for scripts: photo → sketch → plan → G-code → plotter.

>>> import pencilbot
>>> drawing = pencilbot.sketch("photo.jpg")              # raster pencil drawing (Sketch)
>>> plan = pencilbot.plan("photo.jpg", page="A4")        # pen strokes on a page (Plan)
>>> pencilbot.export_gcode(plan, "grbl-servo-a4", "drawing.gcode")  # G-code for a plotter
>>> pencilbot.draw("drawing.gcode", "/dev/ttyUSB0")      # stream it (or port="sim://")
>>> options = pencilbot.DrawOptions(profile="axidraw-v3", progress="bar")   # the same for many jobs
>>> pencilbot.draw("drawing.gcode", "/dev/ttyACM0", options)
>>> with pencilbot.open_control("/dev/ttyACM0", "axidraw-v3") as plotter:   # at the plotter
...     plotter.pen("toggle"); plotter.motors(False); plotter.walk(10, 0); plotter.home()
>>> lines = pencilbot.gcode(plan, "grbl-servo-a4")       # the G-code as lines

Images may be a path, a numpy array (grey or RGB, uint8 or float in [0, 1]) or a
:class:`~pencilbot.imaging.io.LoadedImage`. User mistakes raise
:class:`~pencilbot.errors.PencilbotError` with a plain message.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import overload

import numpy as np

from pencilbot.app.photo import ImageLike, PhotoRequest
from pencilbot.app.photo import sketch_and_plan as app_sketch_and_plan
from pencilbot.driver import DrawOptions, DrawResult  # noqa: F401 (the library API: draw's options)
from pencilbot.driver import draw as _draw
from pencilbot.errors import PencilbotError
from pencilbot.export.gcode import GcodeSummary, gcode_lines, write_gcode
from pencilbot.export.svg import write_svg  # noqa: F401 (the library API)
from pencilbot.export.svg_read import read_svg  # noqa: F401 (the library API)
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS, LoadedImage, image_from_array, load_image
from pencilbot.imaging.pencil import Sketch
from pencilbot.imaging.pencil import sketch as _sketch
from pencilbot.machine.pens import PenSet
from pencilbot.machine.profile import DEFAULT_PROFILE, Profile, load_profile
from pencilbot.planning.plan import Page, Plan
from pencilbot.planning.style import DEFAULT_STYLE, Style


def as_image(image: ImageLike) -> LoadedImage:
    """A :class:`LoadedImage` from a path, an array or a LoadedImage."""
    if isinstance(image, LoadedImage):
        return image
    if isinstance(image, np.ndarray):
        return image_from_array(image, source="array")
    return load_image(image)


def sketch(
    image: ImageLike,
    *,
    color: bool = False,
    line_length: int | None = None,
    stroke_gamma: float = 1.0,
    stroke_width: float = 1.0,
    texture: str | Path | np.ndarray | None = None,
    texture_seed: int = 0,
    lines_only: bool = False,
) -> Sketch:
    """The GMED pencil drawing of an image; ``.result`` is the picture in [0, 1].

    ``texture`` is a hand-drawn pencil texture (image file or grey array), default synthesised;
    see :func:`pencilbot.imaging.pencil.sketch` for the other options.
    """
    return _sketch(
        as_image(image),
        color=color,
        line_length=line_length,
        stroke_gamma=stroke_gamma,
        stroke_width=stroke_width,
        texture=texture,
        texture_seed=texture_seed,
        lines_only=lines_only,
    )


def plan(
    image: ImageLike,
    *,
    page: str | Page | None = None,
    orientation: str | None = None,
    margin: float | None = None,
    style: str | Path | Style | None = None,
    pen_width: float | None = None,
    pens: str | Path | PenSet | None = None,
) -> Plan:
    """Plan the pen drawing of an image on a page (``"A4"``, ``"300x200"`` mm or a Page).

    Unset options come from the style (``"default"`` unless given). ``pens`` (a shipped set's
    name such as ``"cmyk"``, a pen set file or a PenSet) draws the colour sketch with those pens,
    one run of layers per pen in load order; their widths replace ``pen_width``.
    """
    return sketch_and_plan(
        image, page=page, orientation=orientation, margin=margin, style=style, pen_width=pen_width, pens=pens
    )[1]


def sketch_and_plan(
    image: ImageLike,
    *,
    page: str | Page | None = None,
    orientation: str | None = None,
    margin: float | None = None,
    style: str | Path | Style | None = None,
    pen_width: float | None = None,
    pens: str | Path | PenSet | None = None,
    max_pixels: int = DEFAULT_MAX_PIXELS,
) -> tuple[Sketch, Plan]:
    """:func:`plan`, also returning the pencil sketch the plan was made from (at the resolution
    it was planned at); an image file larger than ``max_pixels`` is refused before decoding.

    Planned through the application layer (:mod:`pencilbot.app.photo`), as the CLI, the studio and
    the vpype plugin plan: the same guards (the style's rules for every value, a page too large for
    memory refused before anything is allocated).
    """
    request = PhotoRequest(
        style=style or DEFAULT_STYLE,
        overrides={"page": page, "orientation": orientation, "margin": margin, "pen_width": pen_width}
        if not isinstance(page, Page)
        else {"pen_width": pen_width},
        where="pencilbot.plan",
        pens=pens,
        page=page if isinstance(page, Page) else None,
        max_pixels=max_pixels,
    )
    return app_sketch_and_plan(image, request)


def _profile(profile: str | Path | Profile) -> Profile:
    return profile if isinstance(profile, Profile) else load_profile(profile)


@overload
def export_gcode(
    plan: Plan, profile: str | Path | Profile, path: str | Path, *, source: str = ""
) -> GcodeSummary: ...


@overload
def export_gcode(
    plan: Plan, profile: str | Path | Profile = DEFAULT_PROFILE, path: None = None, *, source: str = ""
) -> list[str]: ...


def export_gcode(
    plan: Plan,
    profile: str | Path | Profile = DEFAULT_PROFILE,
    path: str | Path | None = None,
    *,
    source: str = "",
) -> GcodeSummary | list[str]:
    """Write the G-code of ``plan`` for a plotter profile (a name, a TOML path or a loaded
    ``Profile``) to ``path``, atomically, and return its
    :class:`~pencilbot.export.gcode.GcodeSummary`. (The lines themselves: :func:`gcode`.)
    """
    if path is None:  # the old spelling for the lines: kept for one release
        warnings.warn(
            "export_gcode(plan, profile) without a path is deprecated; use gcode(plan, profile)",
            DeprecationWarning,
            stacklevel=2,
        )
        return gcode(plan, profile, source=source)
    return write_gcode(plan, _profile(profile), path, source=source)


def gcode(plan: Plan, profile: str | Path | Profile = DEFAULT_PROFILE, *, source: str = "") -> list[str]:
    """The G-code lines of ``plan`` for a plotter profile, as :func:`export_gcode` writes them."""
    return gcode_lines(plan, _profile(profile), source=source)


@functools.wraps(_draw)
def draw(*args, **kwargs) -> DrawResult:
    # The driver's own signature and docstring (functools.wraps): its options are said once, there.
    # This front door only makes ``port="sim://…"`` reach the virtual plotter.
    import sim

    sim.register()
    return _draw(*args, **kwargs)


def open_control(port: str, profile: str | Path | Profile = DEFAULT_PROFILE, **kwargs):
    """The plotter on ``port`` at hand: pen, motors, walk, home (see
    :func:`pencilbot.driver.control.open_control`; ``sim://…`` reaches the virtual plotter)."""
    import sim
    from pencilbot.driver.control import open_control as _open_control

    sim.register()
    return _open_control(port, profile if isinstance(profile, Profile) else str(profile), **kwargs)


def save_to_user_profile(profile: Profile, changes: Mapping[str, Mapping[str, object]]) -> Path:
    """Keep ``changes`` in the user's copy of ``profile`` and return its path.

    A profile read from a file the user gave, or from the user's folder, is changed in place; a
    shipped one is copied into the user's ``plotters/`` folder first (a name is looked up there
    first, so every later run gets the change). Only the changed keys' lines are rewritten: the
    comments and everything else stay as they were.
    """
    from pencilbot.configs_io import config_folder, user_folder
    from pencilbot.fileio import write_atomic
    from pencilbot.machine.profile_edit import profile_with, toml_with_key

    profile_with(profile, changes, where=f"plotter profile {profile.source}")  # refused before any write
    if profile.source == f"plotters/{profile.name}.toml":  # shipped: the user's copy starts as it
        own = user_folder() / "plotters" / f"{profile.name}.toml"
        text = (config_folder("plotters") / f"{profile.name}.toml").read_text(encoding="utf-8")
    else:
        own = Path(profile.source)
        text = own.read_text(encoding="utf-8")
    for table, values in changes.items():
        for key, value in values.items():
            text = toml_with_key(text, table, key, value)
    try:
        own.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(own, text.encode("utf-8"))
    except OSError as exc:
        raise PencilbotError(f"cannot save the profile to {own} ({exc.strerror or exc})") from None
    return own
