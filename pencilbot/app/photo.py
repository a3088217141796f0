"""A photo's way to a plan, the same for every front door: a :class:`PhotoRequest` says what
the door was given (the style, the values that override it, the pens, a sheet, how large a
photo may be, whether a preview follows, the door's own :class:`Limits`); :func:`prepare`
resolves it and applies every guard that needs no photo; :func:`sketch_and_plan` reads the
photo at the size the plan needs and plans it.

The guards, each once, here:

* the style and every override through the style's schema (:func:`with_overrides`);
* the pen set found and valid (:func:`load_pens`);
* the door's limits on the sheet and the pen (the studio plans on every change: :data:`INTERACTIVE`);
* the memory planning (and a preview) would take, before anything is allocated (:func:`check_memory`);
* the photo file's size before it is decoded (``max_pixels``), and a picture thinner than the pen
  (:func:`pencilbot.planning.build.sketch_and_plan`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.fileio import available_memory as fileio_available_memory
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS, LoadedImage, image_from_array, load_image
from pencilbot.machine.pens import PenSet, load_pens
from pencilbot.planning.layout import page_size
from pencilbot.planning.plan import Page, Plan
from pencilbot.planning.style import DEFAULT_STYLE, Style, load_style, with_overrides
from pencilbot.units import MM_PER_INCH

ImageLike = str | Path | np.ndarray | LoadedImage

#: Share of the memory the system says is available that pencilbot plans to use.
MEMORY_SHARE = 0.75
# Peak bytes of planning a photo per mm² of page and mm of pen width (the shading grids follow
# the pen, ~1/width), measured with /usr/bin/time: camera at 256 px on 500x500 and 1000x1000 mm
# pages with 0.5 and 1 mm pens (594 MB, 2.2 GB, 367 MB).
_PLAN_BYTES_PER_MM2_MM = 1100
#: Peak bytes per pixel of a picture rendered band by band (pencilbot.render.Bands): the float64
#: ink sums, the per-path maxima, the uint8 rows and their PNG filter.
RENDER_BYTES_PER_PIXEL = 40


@dataclass(frozen=True)
class Limits:
    """What a front door allows beyond what memory does: the longest sheet side and the
    thinnest pen (mm)."""

    max_sheet_mm: float = math.inf
    min_pen_width: float = 0.0
    who: str = ""  # the words for the door in a refusal: "the studio"


#: The studio plans on every change: planning memory and time grow with the page's area over the
#: pen width, so it keeps to an A0 sheet's side and a 0.1 mm pen.
INTERACTIVE = Limits(max_sheet_mm=1200.0, min_pen_width=0.1, who="the studio")


@dataclass(frozen=True)
class PhotoRequest:
    """What a front door was given to plan a photo.

    Attributes
    ----------
    style : str, Path or Style
        A style's name, a style file or a Style (each door names its default: the CLI and the
        studio the user's, the library ``"default"``).
    overrides : mapping
        Style keys and values given beside it (page, orientation, margin, pen_width, hatch, ...),
        checked by the style's schema; ``where`` names who gave them in a refusal.
    pens : str, Path, PenSet or None
        A pen set (None: the plotter's one black pen); the darkest pen's width is the plan's.
    page : Page or None
        A sheet given whole (the library's ``page=Page(...)``); None: from the style.
    max_pixels, downscale
        A photo file larger than ``max_pixels`` is refused before it is decoded, or shrunk with
        ``downscale``.
    preview_dpi : float or None
        A preview the door renders after planning, whose memory is checked with the planning's.
    limits : Limits
        The door's own caps.
    draft : bool
        A plan only to be looked at, never plotted (the studio's first preview): its paths left
        unordered and unjoined, its colour separation unpolished
        (:func:`pencilbot.planning.build.plan_from_sketch`).
    """

    style: str | Path | Style = DEFAULT_STYLE
    overrides: Mapping[str, object] = field(default_factory=dict)
    where: str = "the options"
    pens: str | Path | PenSet | None = None
    page: Page | None = None
    max_pixels: int = DEFAULT_MAX_PIXELS
    downscale: bool = False
    preview_dpi: float | None = None
    limits: Limits = Limits()
    draft: bool = False


@dataclass(frozen=True)
class Prepared:
    """A request resolved and checked: the style as given (``style``), the style the plan is
    drawn with (``drawn``: the pens' width applied), the pens."""

    request: PhotoRequest
    style: Style
    drawn: Style
    pens: PenSet | None

    def sheet(self, shape: tuple[int, int]) -> Page:
        """The page a photo of ``shape`` (H, W) is planned on."""
        if self.request.page is not None:
            return self.request.page
        return page_size(self.drawn.page, self.drawn.orientation, shape, self.drawn.margin)


def resolved_style(request: PhotoRequest) -> Style:
    """The request's style with its overrides applied (checked by the style's schema)."""
    chosen = request.style if isinstance(request.style, Style) else load_style(request.style)
    overrides = {key: value for key, value in request.overrides.items() if value is not None}
    return with_overrides(chosen, overrides, where=request.where) if overrides else chosen


def prepare(request: PhotoRequest) -> Prepared:
    """Resolve ``request`` and apply every guard that needs no photo (see the module).

    Raises
    ------
    PencilbotError
        A style, override or pen set that is not valid, a sheet or pen beyond the door's limits, or
        a page whose planning would need more memory than is free.
    """
    from pencilbot.planning.build import with_pens

    style = resolved_style(request)
    pens = (
        request.pens if request.pens is None or isinstance(request.pens, PenSet) else load_pens(request.pens)
    )
    drawn = style if pens is None else with_pens(style, pens)
    prepared = Prepared(request, style, drawn, pens)
    page = request.page or page_size(drawn.page, None, margin=drawn.margin)
    check_limits(page, drawn, request.limits)
    check_memory(page, drawn.pen_width, request.preview_dpi)
    return prepared


def check_limits(page: Page, style: Style, limits: Limits) -> None:
    """Refuse a sheet or a pen beyond a door's :class:`Limits`."""
    if max(page.width, page.height) > limits.max_sheet_mm:
        raise PencilbotError(
            f"page {style.page} is larger than {limits.who or 'allowed'} plans ({limits.max_sheet_mm:g} mm a side)"
        )
    if style.pen_width < limits.min_pen_width:
        raise PencilbotError(
            f"pen width {style.pen_width:g} mm is below {limits.who or 'the allowed'}'s {limits.min_pen_width:g} mm"
        )


def check_memory(page: Page, pen_width: float, preview_dpi: float | None = None) -> None:
    """Refuse planning on ``page`` with a ``pen_width`` mm pen whose grids (and, with
    ``preview_dpi``, its preview picture) would need more memory than is free, before anything is
    allocated (a 100 m sheet asked for 584 GB).

    Raises
    ------
    PencilbotError
        Saying how much the page would need and how much there is.
    """
    planning = _PLAN_BYTES_PER_MM2_MM / pen_width  # both grow with the page's area
    picture = (preview_dpi / MM_PER_INCH) ** 2 * RENDER_BYTES_PER_PIXEL if preview_dpi is not None else 0.0
    per_mm2 = planning + picture
    need = page.width * page.height * per_mm2
    budget = MEMORY_SHARE * available_memory()
    if need > budget:
        side = math.sqrt(budget / per_mm2)
        raise PencilbotError(
            f"a {page.width:g} x {page.height:g} mm page with a {pen_width:g} mm pen needs about "
            f"{need / 1e9:.0f} GB to plan{' and preview' if preview_dpi else ''}, more than "
            f"{memory_share(budget)}; use a page of at most about {side:.0f} x {side:.0f} mm"
            + (" (or a wider pen)" if planning > picture else "")
        )


def available_memory() -> int:
    """Bytes this process can allocate now: the machine's free memory, the container's and the
    process's own limits considered (:func:`pencilbot.fileio.available_memory`)."""
    return fileio_available_memory()[0]


def memory_share(budget: float) -> str:
    """Words for a memory ``budget`` (bytes, the share of :func:`available_memory` pencilbot
    uses): ``"the 18.2 GB pencilbot may use (75 % of the 24.3 GB this machine has free)"``."""
    return (
        f"the {_size_text(budget)} pencilbot may use ({MEMORY_SHARE:.0%} of the "
        f"{_size_text(budget / MEMORY_SHARE)} {fileio_available_memory()[1]})"
    )


def _size_text(size: float) -> str:
    """``"18.2 GB"``, ``"38 MB"``."""
    return f"{size / 1e9:.1f} GB" if size >= 1e9 else f"{size / 1e6:.0f} MB"


def load_photo(photo: ImageLike, prepared: Prepared) -> LoadedImage:
    """The photo as a :class:`LoadedImage`: a file decoded at the size the plan needs (refused
    past ``max_pixels`` before decoding), an array or a LoadedImage as it is."""
    from pencilbot.planning.resolution import plot_shape

    if isinstance(photo, LoadedImage):
        return photo
    if isinstance(photo, np.ndarray):
        return image_from_array(photo, source="array")
    return load_image(
        photo,
        max_pixels=prepared.request.max_pixels,
        downscale=prepared.request.downscale,
        shrink_to=lambda shape: plot_shape(shape, prepared.sheet(shape), prepared.drawn.pen_width),
    )


def sketch_and_plan(photo: ImageLike, request: PhotoRequest | Prepared):
    """The pencil sketch of ``photo`` and its plan, every guard applied first: a
    ``(Sketch, Plan)`` as :func:`pencilbot.planning.build.sketch_and_plan` makes them."""
    from pencilbot.planning.build import sketch_and_plan as build_sketch_and_plan

    prepared = request if isinstance(request, Prepared) else prepare(request)
    image = load_photo(photo, prepared)
    return build_sketch_and_plan(
        image,
        page=prepared.sheet(image.shape),
        style=prepared.style,
        pens=prepared.pens,
        draft=prepared.request.draft,
    )


def plan_photo(photo: ImageLike, request: PhotoRequest | Prepared) -> Plan:
    """The plan of ``photo`` (see :func:`sketch_and_plan`)."""
    return sketch_and_plan(photo, request)[1]
