"""Where the picture goes on the paper: page sizes, margins, fit, alignment, rotation.

This module holds the **one** mapping between image pixels and page millimetres, and with it the
one Y flip: image coordinates are ``(col, row)`` with rows growing downward and pixel ``(r, c)``
centred at ``(c, r)`` (so the image covers ``[-0.5, W − 0.5] × [-0.5, H − 0.5]``, the convention
of ``np.nonzero`` indices); page coordinates are mm from the page's bottom-left corner, Y up.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.paths import Paths
from pencilbot.planning.plan import DEFAULT_MARGIN, Page, Plan
from pencilbot.units import MM_PER_INCH

# Portrait sizes in mm (ISO 216 and US Letter).
PAGE_SIZES: dict[str, tuple[float, float]] = {
    "A5": (148.0, 210.0),
    "A4": (210.0, 297.0),
    "A3": (297.0, 420.0),
    "Letter": (215.9, 279.4),
}
ORIENTATIONS = ("portrait", "landscape", "auto")
_CUSTOM = re.compile(r"^\s*(\d+(?:\.\d*)?)\s*[xX×]\s*(\d+(?:\.\d*)?)\s*$")
_HORIZONTAL = {"left": 0.0, "center": 0.5, "right": 1.0}
_VERTICAL = {"bottom": 0.0, "center": 0.5, "top": 1.0}


def page_size(
    name: str,
    orientation: str | None = None,
    image_shape: tuple[int, int] | None = None,
    margin: float = DEFAULT_MARGIN,
) -> Page:
    """A page by name (``"A5"``, ``"A4"``, ``"A3"``, ``"Letter"``) or custom ``"WxH"`` in mm.

    Parameters
    ----------
    name : str
        Page name (case-insensitive) or ``"WIDTHxHEIGHT"`` in mm, e.g. ``"300x200"``.
    orientation : {"portrait", "landscape", "auto"} or None, optional
        ``portrait`` puts the long side vertical, ``landscape`` horizontal, ``auto`` follows the
        image (landscape when the image is wider than tall). None keeps the size as given: named
        pages in portrait, a custom size exactly as typed.
    image_shape : (H, W), optional
        Image size in pixels, needed for ``"auto"``.
    margin : float, optional
        Blank border on every side, mm.

    Returns
    -------
    Page
    """
    key = {n.lower(): n for n in PAGE_SIZES}.get(name.strip().lower())
    if key is not None:
        width, height = PAGE_SIZES[key]
    elif match := _CUSTOM.match(name):
        width, height = float(match[1]), float(match[2])
        key = f"{match[1]}x{match[2]}"
    else:
        raise PencilbotError(
            f"unknown page size {name!r}: use one of {', '.join(PAGE_SIZES)} "
            "or a custom size in mm such as 300x200"
        )
    if orientation not in (None, *ORIENTATIONS):
        raise PencilbotError(f"unknown orientation {orientation!r}: use {', '.join(ORIENTATIONS)}")
    if orientation == "auto":
        if image_shape is None:
            raise PencilbotError("orientation 'auto' needs the image size; pass image_shape")
        orientation = "landscape" if image_shape[1] > image_shape[0] else "portrait"
    if orientation == "portrait":
        width, height = min(width, height), max(width, height)
    elif orientation == "landscape":
        width, height = max(width, height), min(width, height)
    if not (width > 0 and height > 0):
        raise PencilbotError(f"page {name!r} has no area: both sides must be positive mm")
    if not 0 <= margin < min(width, height) / 2:
        raise PencilbotError(
            f"margin {margin} mm does not fit a {width:g} x {height:g} mm page: "
            f"use 0 to {min(width, height) / 2:g} mm (exclusive)"
        )
    return Page(width=width, height=height, margin=float(margin), name=key)


@dataclass(frozen=True)
class Layout:
    """An image of ``image_shape`` pixels placed on ``page``: uniform scale, rotation, offset.

    Use :meth:`fit` to make one. ``rotate`` turns the picture counter-clockwise on the page
    (degrees, a multiple of 90). ``drawing_box`` is the picture's rectangle on the page
    ``(x0, y0, x1, y1)`` in mm, inside the margins.
    """

    page: Page
    image_shape: tuple[int, int]
    mm_per_px: float
    rotate: int
    drawing_box: tuple[float, float, float, float]

    @classmethod
    def fit(cls, image_shape: tuple[int, int], page: Page, align: str = "center", rotate: int = 0) -> Layout:
        """Scale an image as large as fits inside the page margins, keeping its aspect ratio.

        Parameters
        ----------
        image_shape : (H, W)
            Image size in pixels.
        page : Page
        align : str, optional
            Where the picture sits in the free space: ``"center"``, or a side or corner such as
            ``"top"``, ``"left"``, ``"bottom-right"``, ``"top-left"``.
        rotate : int, optional
            Counter-clockwise rotation in degrees: 0, 90, 180 or 270.
        """
        h, w = int(image_shape[0]), int(image_shape[1])
        if h <= 0 or w <= 0:
            raise PencilbotError(f"cannot lay out an empty image of {w} x {h} pixels")
        if rotate % 90:
            raise PencilbotError(f"rotation {rotate}° is not supported: use 0, 90, 180 or 270")
        rotate = int(rotate) % 360
        fx, fy = _alignment(align)
        placed_w, placed_h = (h, w) if rotate in (90, 270) else (w, h)
        m = page.margin
        free_w, free_h = page.width - 2 * m, page.height - 2 * m
        scale = min(free_w / placed_w, free_h / placed_h)
        x0 = m + fx * (free_w - placed_w * scale)
        y0 = m + fy * (free_h - placed_h * scale)
        box = (x0, y0, x0 + placed_w * scale, y0 + placed_h * scale)
        return cls(page, (h, w), scale, rotate, box)

    def px_to_mm(self, pts: np.ndarray) -> np.ndarray:
        """Image ``(col, row)`` pixel coordinates (N, 2) → page mm (N, 2), Y up."""
        pts = np.asarray(pts, np.float64).reshape(-1, 2)
        h, w = self.image_shape
        # Centre the image, flip rows to Y up, scale, rotate, then move to the box centre.
        local = np.column_stack([pts[:, 0] - (w - 1) / 2, (h - 1) / 2 - pts[:, 1]]) * self.mm_per_px
        return local @ self._rotation().T + self._box_centre()

    def mm_to_px(self, pts: np.ndarray) -> np.ndarray:
        """Page mm (N, 2), Y up → image ``(col, row)`` pixel coordinates (N, 2); inverse of :meth:`px_to_mm`."""
        pts = np.asarray(pts, np.float64).reshape(-1, 2)
        h, w = self.image_shape
        local = (pts - self._box_centre()) @ self._rotation() / self.mm_per_px
        return np.column_stack([local[:, 0] + (w - 1) / 2, (h - 1) / 2 - local[:, 1]])

    def _rotation(self) -> np.ndarray:
        theta = np.deg2rad(self.rotate)
        c, s = round(np.cos(theta)), round(np.sin(theta))  # exact for multiples of 90°
        return np.array([[c, -s], [s, c]], np.float64)

    def _box_centre(self) -> np.ndarray:
        x0, y0, x1, y1 = self.drawing_box
        return np.array([(x0 + x1) / 2, (y0 + y1) / 2])


def fit_plan(plan: Plan, sheet: str, orientation: str = "auto", margin: float = DEFAULT_MARGIN) -> Plan:
    """A finished drawing scaled (uniformly) and centred to fill a sheet inside its margins.

    What is fitted is the drawing's own page together with anything drawn beyond it (some
    tools write a page smaller than their drawing), so the drawing keeps its place on its page.
    Pen widths stay: a pen does not grow with the picture.

    Parameters
    ----------
    plan : Plan
        The drawing on its page, mm.
    sheet : str
        A page name or ``"WxH"`` mm (see :func:`page_size`).
    orientation : {"portrait", "landscape", "auto"}, optional
        ``auto`` turns the sheet to suit the drawing.
    margin : float, optional
        Blank border on every side, mm.

    Returns
    -------
    Plan
        On the new page.
    """
    points = plan.paths().points
    low = np.minimum(points.min(axis=0), 0.0) if len(points) else np.zeros(2)
    high = (
        np.maximum(points.max(axis=0), (plan.page.width, plan.page.height))
        if len(points)
        else np.array([plan.page.width, plan.page.height])
    )
    size = np.maximum(high - low, 1e-9)
    page = page_size(sheet, orientation, (size[1], size[0]), margin)
    free = np.array([page.width, page.height]) - 2 * page.margin
    scale = float(np.min(free / size))
    offset = page.margin + (free - size * scale) / 2 - low * scale
    layers = [
        replace(layer, paths=layer.paths.with_points(layer.paths.points * scale + offset))
        for layer in plan.layers
    ]
    return replace(plan, page=page, layers=tuple(layers))


def _alignment(align: str) -> tuple[float, float]:
    """``"top-left"`` → (0, 1): fractions of free space to the left and below the picture."""
    fx = fy = 0.5
    words = align.strip().lower().replace("_", "-").replace(" ", "-").split("-")
    for word in words:
        if word in ("left", "right"):
            fx = _HORIZONTAL[word]
        elif word in ("top", "bottom"):
            fy = _VERTICAL[word]
        elif word not in ("center", "centre", "middle", ""):
            raise PencilbotError(
                f"unknown alignment {align!r}: use center, top, bottom, left, right or a corner "
                "such as top-left"
            )
    return fx, fy


def ink_on_image_grid(paths: Paths, layout: Layout, *, pen_width: float, coarsen: int = 1) -> np.ndarray:
    """Darkness of pen paths (page mm) rendered on the image's pixel grid, whatever the rotation.

    Parameters
    ----------
    paths : Paths
        Paths in page mm, Y up.
    layout : Layout
        The placement that produced them.
    pen_width : float
        Pen width, mm.
    coarsen : int
        Render on a grid this many times coarser, each cell a ``coarsen`` × ``coarsen`` block of
        image pixels from the top-left: for callers that blur the result anyway (the canvas
        conserves ink, so block values are the blocks' mean ink).

    Returns
    -------
    (⌈H / coarsen⌉, ⌈W / coarsen⌉) float32 in [0, 1]
        Ink per image pixel (or block), as the plotter's pen would lay it at plot scale.
    """
    from pencilbot.render import render_paths  # not at the top: the layout is light to import

    height, width = layout.image_shape
    # A canvas whose "mm" are image pixels: pixel (col, row) is centred at (col + ½, H − row − ½).
    points = layout.mm_to_px(paths.points)
    points[:, 1] = height - 0.5 - points[:, 1]
    points[:, 0] += 0.5
    return render_paths(
        paths.with_points(points),
        width,
        height,
        dpi=MM_PER_INCH / coarsen,
        pen_width=pen_width / layout.mm_per_px,
    )


def budget_area(layout: Layout, time_budget: float = 1.0) -> float:
    """The area a plan's plotting budgets are counted over, cm²: its sheet's, times the style's
    ``time_budget`` (each budget is so much per cm² of the sheet: pen-down, the faces' runs, the
    plot's cost and its pen-up travel, :mod:`pencilbot.planning.plot_budget`)."""
    return layout.page.width * layout.page.height / 100 * time_budget
