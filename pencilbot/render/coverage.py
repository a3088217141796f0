"""The exact-area coverage kernel: how much of each pixel a pen's band covers.

A pixel's coverage by one segment is the share of its area inside the segment's band (see
:mod:`pencilbot.render`); within a path a pixel is inked once (the maximum over its segments),
separate paths stack as ``Σ log(1 − coverage)``. Candidate pixels are generated per segment,
column by column along its major axis; coverage is computed in float32 in each segment's own
frame on cache-sized blocks; work is chunked to bound memory.
"""

from __future__ import annotations

import numpy as np

from pencilbot.paths import Paths

# Candidates per chunk: its inked pixels (~30 bytes each) stay near 50 MB; larger chunks measured
# slower (temporaries fall out of cache), much smaller ones pay per-chunk overhead.
_CHUNK_CANDIDATES = 1_500_000
# Candidates per block of coverage arithmetic: a dozen float32 temporaries stay in the CPU cache.
_BATCH_CANDIDATES = 32_768
# Coverage is clipped below 1 so log(1 − c) stays finite; 1e-9 is far below 8-bit resolution.
_MAX_COVERAGE = 1.0 - 1e-9


def darkness(log_paper: np.ndarray) -> np.ndarray:
    return np.abs(np.expm1(log_paper)).astype(np.float32)  # abs: no -0.0 on paper


class Grid:
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


def accumulate(log_paper: np.ndarray, paths: Paths, grid: Grid) -> None:
    """Add ``Σ log(1 − coverage)`` of every path to ``log_paper`` (in place)."""
    if not len(paths):
        return
    a, b, seg_path = segments(paths)
    ink(log_paper, grid.to_px(a), grid.to_px(b), seg_path, grid)


def ink(log_paper: np.ndarray, a: np.ndarray, b: np.ndarray, seg_path: np.ndarray, grid: Grid) -> None:
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


def _chunk_coverage(frames: _Frames, lo: int, hi: int, grid: Grid):
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
        self.f32 = {
            name: arr.astype(np.float32)
            for name, arr in {
                "before": -along,
                "after": along - f.length[seg],
                "across": y * f.cos[seg] - x * f.sin[seg],
                "sin": f.sin[seg],
                "cos": f.cos[seg],
                "outer": (f.cos[seg] + np.abs(f.sin[seg])) / 2,
                "inner": (f.cos[seg] - np.abs(f.sin[seg])) / 2,
                "inv_cos": 1.0 / f.cos[seg],
                "inv_2cs": 0.5 / (f.cos[seg] * np.maximum(np.abs(f.sin[seg]), 1e-12)),
            }.items()
        }

    def block(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Columns ``start:stop`` as row vectors (float32 geometry, int64 positions)."""
        out = {name: arr[None, start:stop] for name, arr in self.f32.items()}
        out.update(
            u=self.u[None, start:stop], v=self.v[None, start:stop], segment=self.segment[None, start:stop]
        )
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


def segments(paths: Paths) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
