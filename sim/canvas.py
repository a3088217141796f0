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
segment's major axis (a ragged array built with ``np.repeat``), so long diagonal hatch lines cost
what they ink, not their bounding box. Work is chunked to bound memory; a path longer than a chunk
carries its pixels over so it still inks each pixel once.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence

import cv2
import numpy as np

from pencilbot.errors import PencilbotError

MM_PER_INCH = 25.4
# Candidates per chunk: ~10 float64 arrays of this length stay below ~100 MB.
_CHUNK_CANDIDATES = 1_500_000
# Coverage is clipped below 1 so log(1 − c) stays finite; 1e-9 is far below 8-bit resolution.
_MAX_COVERAGE = 1.0 - 1e-9
TRAVEL_RGB = (220, 40, 40)  # pen-up overlay colour in previews


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
        dpi: float = 100,
        pen_width: float = 0.5,
        origin: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        if not (width_mm > 0 and height_mm > 0 and dpi > 0 and pen_width > 0):
            raise PencilbotError(
                f"cannot make a canvas of {width_mm} x {height_mm} mm at {dpi} dpi with a "
                f"{pen_width} mm pen: sizes, dpi and pen width must all be positive"
            )
        self.width_mm = float(width_mm)
        self.height_mm = float(height_mm)
        self.dpi = float(dpi)
        self.pen_width = float(pen_width)
        self.origin = (float(origin[0]), float(origin[1]))
        self.mm_per_px = MM_PER_INCH / self.dpi
        # A partial pixel at the edge still shows paper; 1e-6 absorbs float error in exact fits.
        self.shape = (
            int(np.ceil(self.height_mm / self.mm_per_px - 1e-6)),
            int(np.ceil(self.width_mm / self.mm_per_px - 1e-6)),
        )
        self._log_paper = np.zeros(self.shape, np.float64)  # Σ log(1 − coverage) of ink
        self._log_travel: np.ndarray | None = None

    @property
    def darkness(self) -> np.ndarray:
        return np.abs(np.expm1(self._log_paper)).astype(np.float32)  # abs: no -0.0 on paper

    def draw_paths(self, paths: Sequence[np.ndarray], pen_width: float | None = None) -> None:
        """Ink pen-down paths (each an ``(N, 2)`` array of mm, Y up) with the canvas's pen."""
        _accumulate(self._log_paper, paths, self._grid(pen_width))

    def draw_travel(self, paths: Sequence[np.ndarray]) -> None:
        """Overlay pen-up moves (thin, coloured in :meth:`to_image`); they never touch ``darkness``."""
        if self._log_travel is None:
            self._log_travel = np.zeros(self.shape, np.float64)
        # Half the pen width, but at least a pixel so the overlay shows in coarse previews.
        _accumulate(self._log_travel, paths, self._grid(max(self.pen_width / 2, self.mm_per_px)))

    def to_image(self) -> np.ndarray:
        """The sheet as uint8 (255 = paper): gray (H, W), or RGB (H, W, 3) with a travel overlay."""
        paper = 255.0 * (1.0 - self.darkness)
        if self._log_travel is None:
            return np.rint(paper).astype(np.uint8)
        travel = -np.expm1(self._log_travel)[..., None]
        rgb = paper[..., None] * (1.0 - travel) + np.asarray(TRAVEL_RGB, np.float64) * travel
        return np.rint(rgb).astype(np.uint8)

    def save_png(self, path: str | os.PathLike) -> None:
        """Write :meth:`to_image` as a PNG, atomically (a temporary file renamed into place)."""
        image = self.to_image()
        if image.ndim == 3:
            image = image[..., ::-1]  # OpenCV writes BGR
        ok, data = cv2.imencode(".png", image)
        if not ok:  # pragma: no cover - encoding a uint8 array only fails on OOM
            raise PencilbotError(f"could not encode the preview for {path}")
        write_atomic(path, data.tobytes())

    def _grid(self, pen_width: float | None) -> _Grid:
        width = self.pen_width if pen_width is None else float(pen_width)
        return _Grid(self.shape, self.mm_per_px, self.origin, self.height_mm, width)


def render_paths(
    paths: Sequence[np.ndarray],
    width_mm: float,
    height_mm: float,
    *,
    dpi: float = 100,
    pen_width: float = 0.5,
    origin: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """Darkness (H, W) float32 in [0, 1] of ``paths`` drawn on a fresh canvas (see :class:`Canvas`)."""
    canvas = Canvas(width_mm, height_mm, dpi=dpi, pen_width=pen_width, origin=origin)
    canvas.draw_paths(paths)
    return canvas.darkness


def write_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder, then rename."""
    folder = os.path.dirname(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", dir=folder)
    except OSError as exc:
        raise PencilbotError(f"cannot write {path}: {exc.strerror}; check the folder exists") from exc
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp, path)
    except OSError as exc:
        os.unlink(tmp)
        raise PencilbotError(f"cannot write {path}: {exc.strerror}") from exc


class _Grid:
    """Where page millimetres land on the pixel grid, and how wide the pen is in pixels."""

    def __init__(self, shape, mm_per_px, origin, height_mm, pen_width) -> None:
        self.shape = shape
        self.mm_per_px = mm_per_px
        self.origin = origin
        self.top = origin[1] + height_mm
        self.radius = pen_width / 2 / mm_per_px  # px

    def to_px(self, pts: np.ndarray) -> np.ndarray:
        """mm (x, y up) → continuous (col, row) with pixel centres at integers."""
        col = (pts[:, 0] - self.origin[0]) / self.mm_per_px - 0.5
        row = (self.top - pts[:, 1]) / self.mm_per_px - 0.5
        return np.column_stack([col, row])


def _accumulate(log_paper: np.ndarray, paths: Sequence[np.ndarray], grid: _Grid) -> None:
    """Add ``Σ log(1 − coverage)`` of every path to ``log_paper`` (in place)."""
    arrays = [np.asarray(p, np.float64).reshape(-1, 2) for p in paths]
    arrays = [p for p in arrays if len(p)]
    if not arrays:
        return
    a, b, seg_path = _segments(arrays)
    a, b = grid.to_px(a), grid.to_px(b)
    counts, plan = _candidate_counts(a, b, grid.radius)
    hw = grid.shape[0] * grid.shape[1]
    # Chunks of about _CHUNK_CANDIDATES candidates (at least one segment each). A path that spans
    # chunks collects its per-pixel maximum in `running` and inks the paper once it is complete.
    cum = np.cumsum(counts)
    cuts = np.searchsorted(cum, np.arange(_CHUNK_CANDIDATES, cum[-1], _CHUNK_CANDIDATES), side="right")
    bounds = np.unique(np.concatenate([[0], cuts, [len(counts)]])).tolist()
    running = np.zeros(hw) if len(bounds) > 2 else None
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        key, cover = _chunk_coverage(a[lo:hi], b[lo:hi], counts[lo:hi], plan[:, lo:hi], grid)
        key, cover = _max_per_key(seg_path[lo:hi][key // hw] * hw + key % hw, cover)
        path, pixel = key // hw, key % hw
        continued = seg_path[lo] if lo > 0 and seg_path[lo] == seg_path[lo - 1] else -1
        runs_on = seg_path[hi - 1] if hi < len(counts) and seg_path[hi] == seg_path[hi - 1] else -1
        if continued >= 0:
            mine = path == continued
            np.maximum.at(running, pixel[mine], cover[mine])
            if continued != runs_on:  # it ends in this chunk: ink it
                touched = np.flatnonzero(running)
                _ink(log_paper, touched, running[touched])
                running[touched] = 0.0
        if runs_on >= 0 and runs_on != continued:
            mine = path == runs_on
            np.maximum.at(running, pixel[mine], cover[mine])
        whole = (path != continued) & (path != runs_on)
        _ink(log_paper, pixel[whole], cover[whole])


def _ink(log_paper: np.ndarray, pixel: np.ndarray, cover: np.ndarray) -> None:
    """Stack coverages onto the paper (flat pixel indices; repeats stack as separate paths)."""
    log_ink = np.log1p(-np.minimum(cover, _MAX_COVERAGE))
    log_paper += np.bincount(pixel, weights=log_ink, minlength=log_paper.size).reshape(log_paper.shape)


def _segments(arrays: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Segment start points, end points and owning path index; a 1-point path is a dot."""
    lengths = np.array([len(p) for p in arrays])
    pts = np.concatenate(arrays)
    owner = np.repeat(np.arange(len(arrays)), lengths)
    last = np.cumsum(lengths) - 1
    is_last = np.zeros(len(pts), bool)
    is_last[last] = True
    is_first = np.zeros(len(pts), bool)
    is_first[last - lengths + 1] = True
    dot = is_first & is_last
    # Segments are p[i] → p[i+1] within a path; dots become zero-length segments.
    starts = np.flatnonzero(~is_last | dot)
    ends = np.where(dot[starts], starts, starts + 1)
    return pts[starts], pts[ends], owner[starts]


def _candidate_counts(a: np.ndarray, b: np.ndarray, radius: float):
    """Per segment: number of candidate pixels, and the geometry to enumerate them.

    Each segment is walked along its major axis ``u`` one pixel column at a time; in each column
    ``k`` pixels along the minor axis ``v`` cover the band (radius + half a pixel) around the line.
    """
    reach = radius + 0.75  # px: beyond radius + half a pixel diagonal (√2/2) a pixel gets no ink
    steep = np.abs(b[:, 1] - a[:, 1]) > np.abs(b[:, 0] - a[:, 0])
    u0 = np.where(steep, a[:, 1], a[:, 0])
    v0 = np.where(steep, a[:, 0], a[:, 1])
    u1 = np.where(steep, b[:, 1], b[:, 0])
    v1 = np.where(steep, b[:, 0], b[:, 1])
    flip = u1 < u0
    u0, u1 = np.where(flip, u1, u0), np.where(flip, u0, u1)
    v0, v1 = np.where(flip, v1, v0), np.where(flip, v0, v1)
    du = u1 - u0
    slope = np.divide(v1 - v0, du, out=np.zeros_like(du), where=du > 0)
    half = reach * np.sqrt(1.0 + slope * slope)  # vertical half-extent of the band in a column
    first_col = np.ceil(u0 - reach)
    n_cols = np.floor(u1 + reach) - first_col + 1
    k = np.ceil(2 * half) + 1
    counts = (n_cols * k).astype(np.int64)
    # The pixel's projection onto the segment's normal: boxes of widths cos φ and sin φ convolved.
    across = 1.0 / np.sqrt(1.0 + slope * slope)
    return counts, np.stack([steep, u0, v0, du, slope, half, first_col, k, across, np.abs(slope) * across])


def _chunk_coverage(a, b, counts, plan, grid: _Grid) -> tuple[np.ndarray, np.ndarray]:
    """Inked pixels of segments a→b: keys ``segment × H·W + pixel`` and coverages (unreduced)."""
    steep, u0, v0, du, slope, half, first_col, k, wide, narrow = plan
    total = int(counts.sum())
    seg = np.repeat(np.arange(len(counts)), counts)
    local = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
    kk = k[seg].astype(np.int64)
    u = first_col[seg] + local // kk
    along = np.clip(u - u0[seg], 0.0, du[seg])  # endcaps: the column's nearest point on the segment
    v = np.ceil(v0[seg] + along * slope[seg] - half[seg]) + local % kk
    is_steep = steep[seg].astype(bool)
    col = np.where(is_steep, v, u)
    row = np.where(is_steep, u, v)
    h, w = grid.shape
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    seg, col, row = seg[inside], col[inside], row[inside]
    cover = _coverage(_distance(col, row, a[seg], b[seg]), grid.radius, wide[seg], narrow[seg])
    inked = cover > 0
    flat = row[inked].astype(np.int64) * w + col[inked].astype(np.int64)
    return seg[inked] * (h * w) + flat, cover[inked]


def _max_per_key(key: np.ndarray, cover: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group-max of coverage per (path, pixel) key: a path inks each pixel once."""
    if not len(key):
        return key, cover
    order = np.argsort(key, kind="stable")
    key, cover = key[order], cover[order]
    first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    return key[first], np.maximum.reduceat(cover, first)


def _distance(col, row, a, b) -> np.ndarray:
    """Distance (px) from pixel centres to segments a→b."""
    d = b - a
    length2 = np.einsum("ij,ij->i", d, d)
    px = col - a[:, 0]
    py = row - a[:, 1]
    t = np.divide(px * d[:, 0] + py * d[:, 1], length2, out=np.zeros_like(px), where=length2 > 0)
    t = np.clip(t, 0.0, 1.0)
    return np.hypot(px - t * d[:, 0], py - t * d[:, 1])


def _coverage(distance, radius: float, wide, narrow) -> np.ndarray:
    """Share of a unit pixel inside a band of half-width ``radius`` whose centre line is ``distance`` away.

    ``wide ≥ narrow`` are |cos|, |sin| of the band's direction: the pixel projects onto the band's
    normal as a trapezoid of total width ``wide + narrow``.
    """
    return _projected_cdf(distance + radius, wide, narrow) - _projected_cdf(distance - radius, wide, narrow)


def _projected_cdf(x, wide, narrow) -> np.ndarray:
    """Share of the pixel's projected trapezoid below ``x`` (0 at the pixel centre's projection)."""
    t = np.maximum((wide + narrow) / 2 - np.abs(x), 0.0)  # depth inside the trapezoid from its near end
    ramp = t * t / (2 * wide * np.maximum(narrow, 1e-12))
    tail = np.where(t <= narrow, ramp, narrow / (2 * wide) + (t - narrow) / wide)
    return np.where(x < 0, tail, 1.0 - tail)
