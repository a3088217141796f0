"""A sheet of paper on a pixel grid: a whole :class:`Canvas`, or :class:`Bands` of rows inked one
at a time, and :func:`render_paths` for a plan's darkness (the model of ink: :mod:`pencilbot.render`)."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.paths import Paths
from pencilbot.render.coverage import Grid, accumulate, darkness, ink, segments
from pencilbot.render.png import write_png_bands
from pencilbot.units import DEFAULT_PEN_WIDTH, MM_PER_INCH

#: Raster resolution (pixels per inch) of a preview or simulated plot when nothing says otherwise:
#: 100 dpi is about 0.25 mm per pixel, half a pen width.
DEFAULT_DPI = 100
TRAVEL_RGB = (220, 40, 40)  # pen-up overlay colour in previews
#: Pixels in one band of a banded render (:class:`Bands`): about 24 bytes each while it is
#: inked (its log-transmittance and two scratch buffers, float64), so about 100 MB a band.
BAND_PIXELS = 4_000_000


class Canvas:
    """A sheet of paper that accumulates pen strokes.

    Parameters
    ----------
    width_mm, height_mm : float
        Size of the sheet in mm.
    dpi : float, optional
        Raster resolution in pixels per inch (100 dpi ≈ 0.254 mm per pixel).
    pen_width : float, optional
        Width of the pen's line in mm.
    origin : (float, float), optional
        Page position (mm, Y up) of the canvas's bottom-left corner, to render a window of a
        page (for example an image's drawing box on the image's own pixel grid).

    Attributes
    ----------
    darkness : ndarray of float32, shape (H, W)
        Ink in [0, 1] (0 = paper); row 0 is the top of the page.
    """

    def __init__(
        self,
        width_mm: float,
        height_mm: float,
        *,
        dpi: float = DEFAULT_DPI,
        pen_width: float = DEFAULT_PEN_WIDTH,
        origin: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        self.mm_per_px, self.shape = sheet_pixels(width_mm, height_mm, dpi, pen_width)
        self.width_mm, self.height_mm = float(width_mm), float(height_mm)
        self.dpi, self.pen_width = float(dpi), float(pen_width)
        self.origin = (float(origin[0]), float(origin[1]))
        self._log_paper = np.zeros(self.shape, np.float64)  # Σ log(1 − coverage) of ink
        self._log_travel: np.ndarray | None = None

    @property
    def darkness(self) -> np.ndarray:
        return darkness(self._log_paper)

    def draw_paths(self, paths: Paths | Sequence[np.ndarray], pen_width: float | None = None) -> None:
        """Ink pen-down paths (mm, Y up) with the canvas's pen or ``pen_width`` mm."""
        accumulate(self._log_paper, Paths.of(paths), self._grid(pen_width))

    def draw_travel(self, paths: Paths | Sequence[np.ndarray]) -> None:
        """Overlay pen-up moves (thin, coloured in :meth:`to_image`); they never touch ``darkness``."""
        if self._log_travel is None:
            self._log_travel = np.zeros(self.shape, np.float64)
        # Half the pen width, but at least a pixel so the overlay shows in coarse previews.
        accumulate(
            self._log_travel, Paths.of(paths), self._grid(travel_width(self.pen_width, self.mm_per_px))
        )

    def to_image(self) -> np.ndarray:
        """The sheet as uint8 (255 = paper): gray (H, W), or RGB (H, W, 3) with a travel overlay."""
        return picture(self._log_paper, self._log_travel)

    def save_png(self, path: str | os.PathLike) -> None:
        """Write :meth:`to_image` as a PNG, atomically (a temporary file renamed into place)."""
        image = self.to_image()
        write_png_bands(path, image.shape, [image])

    def travel_share(self) -> np.ndarray | None:
        """How much of each pixel the pen-up overlay covers, (H, W) in [0, 1] (None: no overlay)."""
        return None if self._log_travel is None else -np.expm1(self._log_travel).astype(np.float32)

    def _grid(self, pen_width: float | None) -> Grid:
        width = self.pen_width if pen_width is None else float(pen_width)
        return Grid(self.shape, self.mm_per_px, self.origin, self.height_mm, width)


def sheet_pixels(
    width_mm: float, height_mm: float, dpi: float, pen_width: float
) -> tuple[float, tuple[int, int]]:
    """Millimetres per pixel and ``(rows, columns)`` of a sheet rendered at ``dpi``.

    Raises
    ------
    PencilbotError
        A size, the dpi or the pen width is not positive.
    """
    if not (width_mm > 0 and height_mm > 0 and dpi > 0 and pen_width > 0):
        raise PencilbotError(
            f"cannot make a canvas of {width_mm} x {height_mm} mm at {dpi} dpi with a "
            f"{pen_width} mm pen: sizes, dpi and pen width must all be positive"
        )
    mm_per_px = MM_PER_INCH / float(dpi)
    # A partial pixel at the edge still shows paper; 1e-6 absorbs float error in exact fits.
    shape = (int(np.ceil(height_mm / mm_per_px - 1e-6)), int(np.ceil(width_mm / mm_per_px - 1e-6)))
    return mm_per_px, shape


def travel_width(pen_width: float, mm_per_px: float) -> float:
    """Line width (mm) of the pen-up overlay: half the pen, but at least a pixel so it shows."""
    return max(pen_width / 2, mm_per_px)


class Bands:
    """Pen paths on a sheet, inked one band of rows at a time: memory follows a band, not the sheet.

    The paths' segments are placed on the whole sheet's pixel grid once; each band inks only
    those that reach it. A band's pixels get the coverage a whole-sheet :class:`Canvas` gives
    them (the same arithmetic on the same positions; only the order in which separate paths'
    log-transmittances are added can differ, by float64 rounding).

    Parameters
    ----------
    paths : Paths or sequence of (N, 2) arrays
        Pen-down paths, mm, Y up.
    width_mm, height_mm, dpi, pen_width, origin
        As for :class:`Canvas`.

    Attributes
    ----------
    shape : (int, int)
        The whole sheet's (rows, columns).
    """

    def __init__(
        self,
        paths: Paths | Sequence[np.ndarray],
        width_mm: float,
        height_mm: float,
        *,
        dpi: float = DEFAULT_DPI,
        pen_width: float = DEFAULT_PEN_WIDTH,
        origin: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        self.mm_per_px, self.shape = sheet_pixels(width_mm, height_mm, dpi, pen_width)
        origin = (float(origin[0]), float(origin[1]))
        self._grid_args = (self.shape, self.mm_per_px, origin, float(height_mm), float(pen_width))
        grid = Grid(*self._grid_args)
        paths = Paths.of(paths)
        if len(paths):
            a, b, self._path = segments(paths)
            self._a, self._b = grid.to_px(a), grid.to_px(b)
        else:
            self._a = self._b = np.zeros((0, 2))
            self._path = np.zeros(0, np.intp)
        # Rows a segment can ink: its ends' rows widened by the pen's radius and a pixel.
        reach = grid.radius + 1.0
        self._top = np.minimum(self._a[:, 1], self._b[:, 1]) - reach
        self._bottom = np.maximum(self._a[:, 1], self._b[:, 1]) + reach

    def log_transmittance(self, first: int, stop: int) -> np.ndarray:
        """``Σ log(1 − coverage)`` of rows ``first:stop``, float64 ``(stop − first, W)``."""
        if not 0 <= first < stop <= self.shape[0]:
            raise ValueError(f"rows {first}:{stop} are not a band of the sheet's {self.shape[0]} rows")
        grid = Grid(*self._grid_args, rows=(first, stop))
        log_paper = np.zeros(grid.band_shape, np.float64)
        near = np.flatnonzero((self._bottom >= first) & (self._top < stop))
        if len(near):
            owner = self._path[near]
            # Paths renumbered 0, 1, ... among those that reach the band (a chunk's path numbers
            # must stay small, see _Paper.ink_once_per_path).
            owner = np.cumsum(np.r_[0, owner[1:] != owner[:-1]])
            ink(log_paper, self._a[near], self._b[near], owner, grid)
        return log_paper

    def darkness(self, first: int, stop: int) -> np.ndarray:
        """Darkness in [0, 1] of rows ``first:stop``, float32 ``(stop − first, W)``: the rows
        ``first:stop`` of :func:`render_paths` of the same paths."""
        return darkness(self.log_transmittance(first, stop))


def band_rows(columns: int, band_pixels: int | None = None) -> int:
    """Rows per band so that a band holds about ``band_pixels`` (default :data:`BAND_PIXELS`)."""
    return max(1, (BAND_PIXELS if band_pixels is None else band_pixels) // max(1, columns))


def render_band(
    paths: Paths | Sequence[np.ndarray],
    rows: tuple[int, int],
    width_mm: float,
    height_mm: float,
    *,
    dpi: float = DEFAULT_DPI,
    pen_width: float = DEFAULT_PEN_WIDTH,
    origin: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """Darkness (float32 in [0, 1]) of rows ``rows = (first, stop)`` of :func:`render_paths` of
    the same arguments, without the rest of the sheet (see :class:`Bands` to render many bands
    of the same paths)."""
    return Bands(paths, width_mm, height_mm, dpi=dpi, pen_width=pen_width, origin=origin).darkness(*rows)


def render_paths(
    paths: Paths | Sequence[np.ndarray],
    width_mm: float,
    height_mm: float,
    *,
    dpi: float = DEFAULT_DPI,
    pen_width: float = DEFAULT_PEN_WIDTH,
    origin: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """Darkness (H, W) float32 in [0, 1] of ``paths`` drawn on a fresh canvas (see :class:`Canvas`)."""
    canvas = Canvas(width_mm, height_mm, dpi=dpi, pen_width=pen_width, origin=origin)
    canvas.draw_paths(paths)
    return canvas.darkness


def picture(log_paper: np.ndarray, log_travel: np.ndarray | None) -> np.ndarray:
    """uint8 picture (255 = paper) of log-transmittances: grey, or RGB with the travel overlay."""
    paper = 255.0 * (1.0 - darkness(log_paper))
    if log_travel is None:
        return np.rint(paper).astype(np.uint8)
    travel = -np.expm1(log_travel)[..., None]
    rgb = paper[..., None] * (1.0 - travel) + np.asarray(TRAVEL_RGB, np.float64) * travel
    return np.rint(rgb).astype(np.uint8)
