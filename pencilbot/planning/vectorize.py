"""The GMED line drawing as pen strokes: short straight lines along the 8 stroke directions.

The raster line drawing paints, for every edge pixel labelled with direction i, a line of length
ℓ along direction i (L = Σ Lᵢ ⊗ Bᵢ). A pen reproduces that by drawing each straight run of such
pixels once: for direction i we rotate pixel coordinates so direction i is the u axis, bin the
across coordinate v into bands one pen width wide (so a thick dilated edge becomes one or a few
touching lines, never five overlapping ones), sort by (band, u) and split where u jumps. A run of
pixels [u0, u1] becomes a stroke from u0 − ℓ/2 to u1 + ℓ/2 — exactly the extent the kernel
paints — cut into pieces of about ``piece_length`` · ℓ that overlap, so consecutive strokes of a
contour cross at their ends as a hand-drawn line does. Everything is whole-array numpy: one
lexsort over the edge pixels, no loop per pixel or per stroke.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from skimage.filters import threshold_otsu

if TYPE_CHECKING:
    from pencilbot.imaging.strokes import LineDrawing

N_DIRECTIONS = 8


def edge_threshold(edges: np.ndarray) -> float:
    """Automatic edge-strength threshold: Otsu's split of the edge map into edge and background.

    Parameters
    ----------
    edges : (H, W) float array in [0, 1]
        The GMED edge map E.

    Returns
    -------
    float
        Edge strength in [0, 1]; pixels above it carry a stroke (1.0 for an empty map).
    """
    if not np.any(edges > edges.min()):
        return 1.0
    return float(threshold_otsu(edges))


def edge_strokes(
    line: LineDrawing,
    layout,
    *,
    pen_width: float = 0.5,
    threshold: float | None = None,
    min_pixels: int = 3,
    piece_length: float = 2.0,
) -> list[np.ndarray]:
    """Straight pen strokes that redraw the GMED line drawing.

    Parameters
    ----------
    line : LineDrawing
        Edge map, direction labels and stroke length ℓ (px) from :mod:`pencilbot.imaging.strokes`.
    layout : pencilbot.planning.layout.Layout
        Maps image pixels to page millimetres (``mm_per_px``, ``px_to_mm``).
    pen_width : float
        Pen line width, mm. Parallel runs closer than this are drawn as one stroke.
    threshold : float or None
        Edge strength in [0, 1] below which pixels draw nothing; None uses :func:`edge_threshold`.
    min_pixels : int
        Runs of fewer edge pixels are dropped (speckle, not contour).
    piece_length : float
        Longest stroke, in units of ℓ; longer runs are cut into overlapping pieces.

    Returns
    -------
    list of (2, 2) float64 arrays
        Each stroke's two end points in mm on the page (Y up), in no particular order.
    """
    edges = np.asarray(line.edges, dtype=np.float32)
    ell = float(line.length)
    thr = edge_threshold(edges) if threshold is None else float(threshold)
    rows, cols = np.nonzero(edges > thr)
    if rows.size == 0:
        return []
    direction = line.labels[rows, cols].astype(np.intp)
    theta = direction * (np.pi / N_DIRECTIONS)
    # Direction k is (cos θ, −sin θ) in (col, row): rows grow downward on screen.
    along = np.stack([np.cos(theta), -np.sin(theta)], axis=1)
    across = np.stack([np.sin(theta), np.cos(theta)], axis=1)
    pts = np.stack([cols, rows], axis=1).astype(np.float64)
    u = np.einsum("ij,ij->i", pts, along)
    v = np.einsum("ij,ij->i", pts, across)

    band_px = max(1.0, pen_width / layout.mm_per_px)
    band = np.floor(v / band_px).astype(np.int64)
    order = np.lexsort((u, band, direction))
    direction, band, u, v = direction[order], band[order], u[order], v[order]

    # A gap longer than ℓ/2 is not bridged by the kernel either: start a new run there.
    new_run = np.ones(u.size, dtype=bool)
    new_run[1:] = (
        (direction[1:] != direction[:-1]) | (band[1:] != band[:-1]) | (np.diff(u) > max(2.0, ell / 2))
    )
    starts = np.flatnonzero(new_run)
    counts = np.diff(np.append(starts, u.size))
    keep = counts >= min_pixels
    starts, counts = starts[keep], counts[keep]
    if starts.size == 0:
        return []
    ends = starts + counts - 1
    run_dir = direction[starts]
    run_v = np.add.reduceat(v, np.flatnonzero(new_run))[keep] / counts
    u0 = u[starts] - ell / 2
    u1 = u[ends] + ell / 2

    u0, u1 = _clip_to_image(u0, u1, run_v, run_dir, line.edges.shape)
    inside = u1 - u0 > 1e-6
    u0, u1, run_v, run_dir = u0[inside], u1[inside], run_v[inside], run_dir[inside]
    p0, p1, piece_dir, piece_v = _cut_into_pieces(u0, u1, run_v, run_dir, piece_length * ell, ell)

    theta = piece_dir * (np.pi / N_DIRECTIONS)
    along = np.stack([np.cos(theta), -np.sin(theta)], axis=1)
    across = np.stack([np.sin(theta), np.cos(theta)], axis=1)
    start_px = p0[:, None] * along + piece_v[:, None] * across
    end_px = p1[:, None] * along + piece_v[:, None] * across
    ends_mm = layout.px_to_mm(np.concatenate([start_px, end_px])).reshape(2, -1, 2)
    return list(np.stack([ends_mm[0], ends_mm[1]], axis=1))


def _clip_to_image(u0, u1, v, direction, shape):
    """Shorten each stroke [u0, u1] on line v of direction k to the image rectangle (slab test)."""
    height, width = shape
    theta = direction * (np.pi / N_DIRECTIONS)
    dc, dr = np.cos(theta), -np.sin(theta)
    base_c, base_r = v * np.sin(theta), v * np.cos(theta)
    lo, hi = u0.copy(), u1.copy()
    for base, step, limit in ((base_c, dc, width - 1), (base_r, dr, height - 1)):
        moving = np.abs(step) > 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            t_a = (0 - base) / step
            t_b = (limit - base) / step
        t_min = np.where(moving, np.minimum(t_a, t_b), -np.inf)
        t_max = np.where(moving, np.maximum(t_a, t_b), np.inf)
        lo, hi = np.maximum(lo, t_min), np.minimum(hi, t_max)
    return lo, np.maximum(hi, lo)


def _cut_into_pieces(u0, u1, v, direction, max_len, ell):
    """Cut [u0, u1] into equal pieces ≤ ``max_len`` that overlap by ℓ/4 so their ends cross."""
    overlap = ell / 4
    length = u1 - u0
    n = np.maximum(1, np.ceil((length - overlap) / max(max_len - overlap, 1e-9))).astype(np.intp)
    piece = (length + (n - 1) * overlap) / n
    run = np.repeat(np.arange(u0.size), n)
    index = np.arange(run.size) - np.repeat(np.cumsum(n) - n, n)
    start = u0[run] + index * (piece[run] - overlap)
    return start, start + piece[run], direction[run], v[run]
