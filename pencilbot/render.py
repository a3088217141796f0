"""The rasteriser: pen paths in millimetres onto a sheet of paper, antialiased.

One rasteriser serves plan previews, fidelity measurements and the simulator, so all three agree
on what a drawn line looks like. The model of ink:

* a pen of width ``w`` mm covers the points within ``w/2`` of its path (round caps and joins);
* a pixel's coverage by one segment is the fraction of the pixel's area inside the segment's band:
  from the distance ``d`` between the pixel centre and the segment, the share of the pixel's
  projection onto the segment's normal (a trapezoid, a box when axis-aligned) that falls in
  ``[d − w/2, d + w/2]``. Exact for the straight part at any angle, so ink is conserved and
  diagonal lines are not lighter or darker than straight ones, even for pens thinner than a pixel;
* within one path a pixel is inked once (the maximum over the path's segments: a polyline's
  joints are not darker than its middle);
* separate paths (and separate calls) stack like translucent layers:
  ``darkness = 1 − Π(1 − coverage)``, accumulated as a sum of ``log(1 − coverage)``.

Everything is vectorised: candidate pixels are generated per segment, column by column along the
segment's major axis, only as many per column as the pen's band can reach, so long diagonal hatch
lines cost what they ink, not their bounding box. Coverage is computed in float32 in each
segment's own frame (offsets of a few pixels, so float32 keeps ~1e-7 accuracy) on cache-sized
dense blocks. "Once per path" is a group-max per (path, pixel), found with one ``np.maximum.at``
into a page-sized buffer (sorting only where separate paths overlap). Work is chunked to bound
memory; a path longer than a chunk keeps its per-pixel maximum open until it ends.

A sheet too large to hold (an A0 bed at 600 dpi is 0.56 gigapixels) is inked a band of rows at a
time (:class:`Bands`, :func:`render_band`) and streamed into a PNG (:func:`save_drawing_png`):
each band's pixels sit where the whole sheet puts them, so they get the same coverage.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from pencilbot.colours import inks_on_paper
from pencilbot.errors import PencilbotError
from pencilbot.paths import Paths
from pencilbot.png import write_png_bands
from pencilbot.units import DEFAULT_PEN_WIDTH, MM_PER_INCH

#: Raster resolution (pixels per inch) of a preview or simulated plot when nothing says otherwise:
#: 100 dpi is about 0.25 mm per pixel, half a pen width.
DEFAULT_DPI = 100

# Candidates per chunk: its inked pixels (~30 bytes each) stay near 50 MB; larger chunks measured
# slower (temporaries fall out of cache), much smaller ones pay per-chunk overhead.
_CHUNK_CANDIDATES = 1_500_000
# Candidates per block of coverage arithmetic: a dozen float32 temporaries stay in the CPU cache.
_BATCH_CANDIDATES = 32_768
# Coverage is clipped below 1 so log(1 − c) stays finite; 1e-9 is far below 8-bit resolution.
_MAX_COVERAGE = 1.0 - 1e-9
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
        return _darkness(self._log_paper)

    def draw_paths(self, paths: Paths | Sequence[np.ndarray], pen_width: float | None = None) -> None:
        """Ink pen-down paths (mm, Y up) with the canvas's pen or ``pen_width`` mm."""
        _accumulate(self._log_paper, Paths.of(paths), self._grid(pen_width))

    def draw_travel(self, paths: Paths | Sequence[np.ndarray]) -> None:
        """Overlay pen-up moves (thin, coloured in :meth:`to_image`); they never touch ``darkness``."""
        if self._log_travel is None:
            self._log_travel = np.zeros(self.shape, np.float64)
        # Half the pen width, but at least a pixel so the overlay shows in coarse previews.
        _accumulate(self._log_travel, Paths.of(paths), self._grid(travel_width(self.pen_width, self.mm_per_px)))

    def to_image(self) -> np.ndarray:
        """The sheet as uint8 (255 = paper): gray (H, W), or RGB (H, W, 3) with a travel overlay."""
        return _image(self._log_paper, self._log_travel)

    def save_png(self, path: str | os.PathLike) -> None:
        """Write :meth:`to_image` as a PNG, atomically (a temporary file renamed into place)."""
        image = self.to_image()
        write_png_bands(path, image.shape, [image])

    def travel_share(self) -> np.ndarray | None:
        """How much of each pixel the pen-up overlay covers, (H, W) in [0, 1] (None: no overlay)."""
        return None if self._log_travel is None else -np.expm1(self._log_travel).astype(np.float32)

    def _grid(self, pen_width: float | None) -> _Grid:
        width = self.pen_width if pen_width is None else float(pen_width)
        return _Grid(self.shape, self.mm_per_px, self.origin, self.height_mm, width)


def sheet_pixels(width_mm: float, height_mm: float, dpi: float, pen_width: float) -> tuple[float, tuple[int, int]]:
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
        grid = _Grid(*self._grid_args)
        paths = Paths.of(paths)
        if len(paths):
            a, b, self._path = _segments(paths)
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
        grid = _Grid(*self._grid_args, rows=(first, stop))
        log_paper = np.zeros(grid.band_shape, np.float64)
        near = np.flatnonzero((self._bottom >= first) & (self._top < stop))
        if len(near):
            owner = self._path[near]
            # Paths renumbered 0, 1, ... among those that reach the band (a chunk's path numbers
            # must stay small, see _Paper.ink_once_per_path).
            owner = np.cumsum(np.r_[0, owner[1:] != owner[:-1]])
            _ink(log_paper, self._a[near], self._b[near], owner, grid)
        return log_paper

    def darkness(self, first: int, stop: int) -> np.ndarray:
        """Darkness in [0, 1] of rows ``first:stop``, float32 ``(stop − first, W)``: the rows
        ``first:stop`` of :func:`render_paths` of the same paths."""
        return _darkness(self.log_transmittance(first, stop))


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


def save_drawing_png(
    path: str | os.PathLike,
    paths: Paths | Sequence[np.ndarray],
    width_mm: float,
    height_mm: float,
    *,
    dpi: float = DEFAULT_DPI,
    pen_width: float = DEFAULT_PEN_WIDTH,
    travel: Paths | Sequence[np.ndarray] | None = None,
    band_pixels: int | None = None,
) -> tuple[int, int]:
    """Render ``paths`` (and a pen-up ``travel`` overlay) band by band straight into a PNG.

    The same picture :meth:`Canvas.save_png` writes for a canvas with these paths drawn (and
    travel overlaid), with memory bounded by one band of ``band_pixels`` pixels
    (:data:`BAND_PIXELS`, about 100 MB) whatever the sheet's size. Written atomically.

    Returns
    -------
    (int, int)
        The PNG's (rows, columns).
    """
    ink = Bands(paths, width_mm, height_mm, dpi=dpi, pen_width=pen_width)
    moves = None if travel is None else Bands(
        travel, width_mm, height_mm, dpi=dpi, pen_width=travel_width(pen_width, ink.mm_per_px))
    rows, columns = ink.shape
    step = band_rows(columns, band_pixels)

    def bands():
        for first in range(0, rows, step):
            stop = min(first + step, rows)
            yield _image(ink.log_transmittance(first, stop), None if moves is None else moves.log_transmittance(first, stop))

    write_png_bands(path, ink.shape if travel is None else (rows, columns, 3), bands())
    return ink.shape


def colour_image(canvases: Sequence[Canvas], colors: Sequence[str]) -> np.ndarray:
    """The ink of one canvas per pen, stacked as transparent colour layers on white paper.

    Parameters
    ----------
    canvases : sequence of Canvas
        One per pen, all of one shape; a travel overlay on any of them is shown in
        :data:`TRAVEL_RGB` on top.
    colors : sequence of str
        Each pen's ink, ``#rrggbb``.

    Returns
    -------
    (H, W, 3) uint8
        sRGB (see :func:`pencilbot.colours.inks_on_paper`).
    """
    rgb = 255.0 * inks_on_paper([canvas.darkness for canvas in canvases], colors)
    for canvas in canvases:
        travel = canvas.travel_share()
        if travel is not None:
            rgb = rgb * (1.0 - travel[..., None]) + np.asarray(TRAVEL_RGB, np.float32) * travel[..., None]
    return np.rint(rgb).astype(np.uint8)


def write_png(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write a uint8 grey (H, W) or RGB (H, W, 3) image as a PNG, atomically."""
    write_png_bands(path, image.shape, [image])


def save_colour_png(
    path: str | os.PathLike,
    inks: Sequence[tuple[Paths | Sequence[np.ndarray], str, float]],
    width_mm: float,
    height_mm: float,
    *,
    dpi: float = DEFAULT_DPI,
    travel: Paths | Sequence[np.ndarray] | None = None,
    travel_pen: float = DEFAULT_PEN_WIDTH,
    band_pixels: int | None = None,
) -> tuple[int, int]:
    """Render each pen's paths as a transparent layer of its ink, band by band into a PNG.

    The picture :func:`colour_image` makes of one :class:`Canvas` per pen, with memory bounded
    by one band of every pen (as :func:`save_drawing_png` for one pen). Written atomically.

    Parameters
    ----------
    inks : sequence of (paths, colour, pen width mm)
        One entry per pen, in the order they were drawn; colour ``#rrggbb``.
    travel : paths, optional
        Pen-up moves, overlaid in :data:`TRAVEL_RGB` (drawn as :class:`Canvas` draws travel
        for a ``travel_pen`` pen).

    Returns
    -------
    (int, int)
        The PNG's (rows, columns).
    """
    layers = [Bands(paths, width_mm, height_mm, dpi=dpi, pen_width=width) for paths, _, width in inks]
    colors = [color for _, color, _ in inks]
    mm_per_px, (rows, columns) = sheet_pixels(width_mm, height_mm, dpi, travel_pen)
    moves = None if travel is None else Bands(
        travel, width_mm, height_mm, dpi=dpi, pen_width=travel_width(travel_pen, mm_per_px))
    step = band_rows(columns * max(1, len(layers)), band_pixels)

    def bands():
        for first in range(0, rows, step):
            stop = min(first + step, rows)
            rgb = 255.0 * inks_on_paper([layer.darkness(first, stop) for layer in layers], colors)
            if moves is not None:
                share = -np.expm1(moves.log_transmittance(first, stop)).astype(np.float32)[..., None]
                rgb = rgb * (1.0 - share) + np.asarray(TRAVEL_RGB, np.float32) * share
            yield np.rint(rgb).astype(np.uint8)

    write_png_bands(path, (rows, columns, 3), bands())
    return rows, columns


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


def _darkness(log_paper: np.ndarray) -> np.ndarray:
    return np.abs(np.expm1(log_paper)).astype(np.float32)  # abs: no -0.0 on paper


def _image(log_paper: np.ndarray, log_travel: np.ndarray | None) -> np.ndarray:
    """uint8 picture (255 = paper) of log-transmittances: grey, or RGB with the travel overlay."""
    paper = 255.0 * (1.0 - _darkness(log_paper))
    if log_travel is None:
        return np.rint(paper).astype(np.uint8)
    travel = -np.expm1(log_travel)[..., None]
    rgb = paper[..., None] * (1.0 - travel) + np.asarray(TRAVEL_RGB, np.float64) * travel
    return np.rint(rgb).astype(np.uint8)


class _Grid:
    """Where page millimetres land on the pixel grid, and how wide the pen is in pixels.

    ``rows`` = (first, stop) is the band of the sheet's rows being inked (default: all of them);
    pixel positions stay those of the whole sheet, so a band's pixels get exactly the coverage
    they get in a whole-sheet render.
    """

    def __init__(self, shape, mm_per_px, origin, height_mm, pen_width, rows=None) -> None:
        self.shape = shape
        self.rows = (0, shape[0]) if rows is None else (int(rows[0]), int(rows[1]))
        self.band_shape = (self.rows[1] - self.rows[0], shape[1])
        self.mm_per_px = mm_per_px
        self.origin = origin
        self.top = origin[1] + height_mm
        self.radius = pen_width / 2 / mm_per_px  # px

    def to_px(self, pts: np.ndarray) -> np.ndarray:
        """mm (x, y up) → continuous (col, row) with pixel centres at integers."""
        col = (pts[:, 0] - self.origin[0]) / self.mm_per_px - 0.5
        row = (self.top - pts[:, 1]) / self.mm_per_px - 0.5
        return np.column_stack([col, row])


def _accumulate(log_paper: np.ndarray, paths: Paths, grid: _Grid) -> None:
    """Add ``Σ log(1 − coverage)`` of every path to ``log_paper`` (in place)."""
    if not len(paths):
        return
    a, b, seg_path = _segments(paths)
    _ink(log_paper, grid.to_px(a), grid.to_px(b), seg_path, grid)


def _ink(log_paper: np.ndarray, a: np.ndarray, b: np.ndarray, seg_path: np.ndarray, grid: _Grid) -> None:
    """Add ``Σ log(1 − coverage)`` of segments ``a → b`` (pixels, whole-sheet frame; consecutive
    segments of one path share a non-decreasing ``seg_path``) to the band ``log_paper``."""
    if not len(a):
        return
    frames = _Frames(a, b, grid.radius)
    # Chunks of about _CHUNK_CANDIDATES candidates (at least one segment each) bound memory.
    cum = np.cumsum(frames.candidates)
    cuts = np.searchsorted(cum, np.arange(_CHUNK_CANDIDATES, cum[-1], _CHUNK_CANDIDATES), side="right")
    bounds = np.unique(np.concatenate([[0], cuts, [len(cum)]])).tolist()
    paper = _Paper(log_paper)
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        pixel, cover, segment = _chunk_coverage(frames, lo, hi, grid)
        path = seg_path[lo:hi][segment] - seg_path[lo]
        # A path cut by chunk boundaries keeps its per-pixel maximum open until its last chunk.
        last = seg_path[hi - 1] - seg_path[lo]
        continued = lo > 0 and seg_path[lo] == seg_path[lo - 1]
        runs_on = hi < len(seg_path) and seg_path[hi] == seg_path[hi - 1]
        complete = np.ones(len(path), bool)
        if continued:
            mine = path == 0
            paper.extend_open(pixel[mine], cover[mine])
            complete &= ~mine
            if not (runs_on and last == 0):
                paper.close_open()
        if runs_on and not (continued and last == 0):
            mine = path == last
            paper.extend_open(pixel[mine], cover[mine])
            complete &= ~mine
        paper.ink_once_per_path(pixel[complete], cover[complete], path[complete])


class _Frames:
    """Per segment (pixel units): its own frame and the columns of pixels that can take its ink.

    A segment is walked along its major axis ``u`` one pixel column at a time; ``v`` is the minor
    axis. A pixel gets ink when its centre is closer than ``reach = radius + (cos + sin)/2`` to the
    segment (the pen's radius plus half the pixel's extent across the segment), so a column holds
    at most ``k = ⌈2·reach / cos⌉`` candidates around the line: as tight as a per-column walk gets,
    and long diagonal lines cost what they ink, not their bounding box.
    """

    def __init__(self, a: np.ndarray, b: np.ndarray, radius: float) -> None:
        self.radius = radius
        self.steep = np.abs(b[:, 1] - a[:, 1]) > np.abs(b[:, 0] - a[:, 0])
        u0, v0 = np.where(self.steep, a[:, 1], a[:, 0]), np.where(self.steep, a[:, 0], a[:, 1])
        u1, v1 = np.where(self.steep, b[:, 1], b[:, 0]), np.where(self.steep, b[:, 0], b[:, 1])
        flip = u1 < u0
        self.u0, self.v0 = np.where(flip, u1, u0), np.where(flip, v1, v0)
        self.du = np.abs(u1 - u0)
        dv = np.where(flip, v0 - v1, v1 - v0)
        self.length = np.hypot(self.du, dv)
        dot = self.length == 0  # a dot is inked like a horizontal zero-length segment
        self.cos = np.where(dot, 1.0, self.du / np.where(dot, 1.0, self.length))
        self.sin = np.where(dot, 0.0, dv / np.where(dot, 1.0, self.length))  # signed
        self.slope = self.sin / self.cos
        self.reach = radius + (self.cos + np.abs(self.sin)) / 2
        self.half = self.reach / self.cos  # half-height of the band in a column
        self.k = np.ceil(2 * self.half).astype(np.int64)
        self.first = np.floor(self.u0 - self.reach) + 1
        self.columns = np.maximum(np.ceil(self.u0 + self.du + self.reach) - self.first, 0).astype(np.int64)
        self.candidates = self.columns * self.k


def _chunk_coverage(frames: _Frames, lo: int, hi: int, grid: _Grid):
    """Inked pixels of segments ``lo:hi``: flat pixel index, coverage (< 1), segment (from ``lo``).

    One segment inks each of its pixels once. Segments are grouped by (candidates per column,
    steep) so a block of columns is a dense ``(k, columns)`` array; blocks are cache-sized.
    """
    w = grid.shape[1]
    first, stop = grid.rows
    pixels, covers, segments = [], [], []
    segs = np.arange(lo, hi)
    group = frames.k[segs] * 2 + frames.steep[segs]
    for key in np.unique(group):
        k, steep = int(key) // 2, bool(key % 2)
        # A steep segment walks rows (u) across columns (v); a flat one the other way round.
        u_span, (v_lo, v_hi) = ((first, stop), (0, w)) if steep else ((0, w), (first, stop))
        col = _Columns(frames, segs[group == key], u_span)
        j = np.arange(k, dtype=np.float32)[:, None]
        jv = np.arange(k)[:, None]
        step = max(1, _BATCH_CANDIDATES // k)
        for s in range(0, len(col.segment), step):
            c = col.block(s, s + step)
            cover = _capsule_coverage(j, c, frames.radius)
            inked = cover > 0
            if c["v"].min() < v_lo or c["v"].max() + k > v_hi:  # columns cut by the band's edge
                v = c["v"] + jv
                inked &= (v >= v_lo) & (v < v_hi)
            # Flat index into the band: rows counted from its first.
            if steep:
                pixel = (c["u"] - first) * w + (c["v"] + jv)
            else:
                pixel = c["u"] + (c["v"] + jv - first) * w
            pixels.append(pixel[inked])
            covers.append(np.minimum(cover[inked], _MAX_COVERAGE, dtype=np.float64))
            segments.append(np.broadcast_to(c["segment"], inked.shape)[inked])
    if not pixels:
        return np.zeros(0, np.intp), np.zeros(0), np.zeros(0, np.intp)
    return np.concatenate(pixels), np.concatenate(covers), np.concatenate(segments) - lo


class _Columns:
    """The pixel columns of some segments inside ``span`` (their major axis's pixel range: the
    band's rows for steep segments, the sheet's columns for flat ones), in each column's own
    frame (float32)."""

    def __init__(self, f: _Frames, segs: np.ndarray, span: tuple[int, int]) -> None:
        n = f.columns[segs]
        seg = np.repeat(segs, n)
        u = f.first[seg] + (np.arange(len(seg)) - np.repeat(np.cumsum(n) - n, n))
        on = (u >= span[0]) & (u < span[1])
        seg, u = seg[on], u[on]
        x = u - f.u0[seg]  # along the major axis from the segment's start
        # Endcaps: beyond the segment's ends a column is centred on the nearest end.
        centre = f.v0[seg] + np.clip(x, 0.0, f.du[seg]) * f.slope[seg]
        v = np.floor(centre - f.half[seg]) + 1  # first candidate's minor coordinate
        y = v - f.v0[seg]
        along = x * f.cos[seg] + y * f.sin[seg]
        self.segment = seg
        self.u = u.astype(np.int64)
        self.v = v.astype(np.int64)
        # Candidate j of a column lies at along + j·sin, across + j·cos in the segment's frame.
        # Distances beyond each end are kept separately so float32 stays exact near the caps.
        self.f32 = {name: arr.astype(np.float32) for name, arr in {
            "before": -along, "after": along - f.length[seg], "across": y * f.cos[seg] - x * f.sin[seg],
            "sin": f.sin[seg], "cos": f.cos[seg], "outer": (f.cos[seg] + np.abs(f.sin[seg])) / 2,
            "inner": (f.cos[seg] - np.abs(f.sin[seg])) / 2, "inv_cos": 1.0 / f.cos[seg],
            "inv_2cs": 0.5 / (f.cos[seg] * np.maximum(np.abs(f.sin[seg]), 1e-12)),
        }.items()}

    def block(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Columns ``start:stop`` as row vectors (float32 geometry, int64 positions)."""
        out = {name: arr[None, start:stop] for name, arr in self.f32.items()}
        out.update(u=self.u[None, start:stop], v=self.v[None, start:stop], segment=self.segment[None, start:stop])
        return out


def _capsule_coverage(j: np.ndarray, c: dict[str, np.ndarray], radius: float) -> np.ndarray:
    """Coverage (k, columns) of candidates ``j`` (column vector) in columns ``c``.

    The pixel centre's distance ``d`` to the segment (to its nearest end beyond the ends) gives the
    share of the pixel's projection onto the segment's normal inside ``[d − r, d + r]``.
    """
    shift = j * c["sin"]
    beyond = np.maximum(np.maximum(c["before"] - shift, c["after"] + shift), 0.0)
    across = c["across"] + j * c["cos"]
    d = np.sqrt(across * across + beyond * beyond)
    return _projected_share(d + radius, c) - _projected_share(d - radius, c)


def _projected_share(x: np.ndarray, c: dict[str, np.ndarray]) -> np.ndarray:
    """Signed share of the pixel's projection between its centre and offset ``x`` (in [−½, ½]).

    The projection is a trapezoid (a unit box seen at angle φ: boxes of widths cos φ and sin φ
    convolved): flat top up to ``inner = (cos − sin)/2``, quadratic shoulder up to ``outer``.
    """
    y = np.minimum(np.abs(x), c["outer"])
    shoulder = np.maximum(y - c["inner"], 0.0)
    return np.copysign(y * c["inv_cos"] - shoulder * shoulder * c["inv_2cs"], x)


class _Paper:
    """The canvas's log-transmittance plus page-sized scratch buffers for inking paths once."""

    def __init__(self, log_paper: np.ndarray) -> None:
        self.log = log_paper.reshape(-1)  # a view: writes land on the canvas
        self.best = np.zeros(log_paper.size)  # path + 1 + coverage of a pixel's top entry, 0 = free
        self.open = np.zeros(log_paper.size)  # coverage so far of a path that spans chunks
        self.open_pixels: list[np.ndarray] = []

    def ink_once_per_path(self, pixel: np.ndarray, cover: np.ndarray, path: np.ndarray) -> None:
        """Stack the maximum coverage per (path, pixel) of complete paths onto the paper.

        Most pixels are touched by one path of a chunk: one ``np.maximum.at`` over values packed as
        ``path + 1 + coverage`` finds each pixel's highest-numbered path and its maximum coverage
        there. Entries of other paths at the same pixels (overlapping paths) are reduced by sorting.
        """
        packed = path + 1.0 + cover  # cover ≤ 1 − 1e-9 stays below the next integer (chunks hold < 1e6 paths)
        np.maximum.at(self.best, pixel, packed)
        best = self.best[pixel]
        top = packed == best
        # The top entry may repeat (a path retracing itself): the repeats carry the same value,
        # and `log[won] += …` with repeated indices adds it once.
        won, value = pixel[top], packed[top]
        self.best[won] = 0.0
        self.log[won] += np.log1p(-(value - np.floor(value)))
        below = packed < np.floor(best)
        if below.any():
            key, cover = _max_per_key(path[below] * self.log.size + pixel[below], cover[below])
            np.add.at(self.log, key % self.log.size, np.log1p(-cover))

    def extend_open(self, pixel: np.ndarray, cover: np.ndarray) -> None:
        """Add pixels of the open path (keeping each pixel's maximum)."""
        self.open_pixels.append(pixel[self.open[pixel] == 0.0])
        np.maximum.at(self.open, pixel, cover)

    def close_open(self) -> None:
        """Ink the open path; repeated pixels in the list add once (same value, one `+=`)."""
        touched = np.concatenate(self.open_pixels) if self.open_pixels else np.zeros(0, np.intp)
        self.log[touched] += np.log1p(-self.open[touched])
        self.open[touched] = 0.0
        self.open_pixels = []


def _max_per_key(key: np.ndarray, cover: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group-max of coverage per key."""
    order = np.argsort(key)
    key, cover = key[order], cover[order]
    first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    return key[first], np.maximum.reduceat(cover, first)


def _segments(paths: Paths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Segment start points, end points and owning path index; a 1-point path is a dot."""
    lengths = paths.lengths
    pts = paths.points
    owner = paths.owners()
    last = paths.offsets[1:] - 1
    is_last = np.zeros(len(pts), bool)
    is_last[last] = True
    is_first = np.zeros(len(pts), bool)
    is_first[last - lengths + 1] = True
    dot = is_first & is_last
    # Segments are p[i] → p[i+1] within a path; dots become zero-length segments.
    starts = np.flatnonzero(~is_last | dot)
    ends = np.where(dot[starts], starts, starts + 1)
    return pts[starts], pts[ends], owner[starts]
