"""The GMED line drawing as pen strokes: short straight lines along the 8 stroke directions.

The raster line drawing paints, for every edge pixel labelled with direction i, a line of length
ℓ along direction i (L = Σ Lᵢ ⊗ Bᵢ). A pen reproduces that by drawing each straight stretch of
such pixels once. Edge pixels (E above a threshold) that share a direction label and touch
(8-connected) form a component: one straight piece of contour, however thick the dilated edge
is, so a band of edge pixels is never drawn as several overlapping lines. In coordinates rotated
so direction i is the u axis, a component spanning [u0, u1] becomes a stroke from u0 − ℓ/2 to
u1 + ℓ/2 — the extent the kernel paints — cut into pieces of at most ``piece_length`` · ℓ that
overlap by ℓ/4, so consecutive strokes of a contour cross at their ends as a hand-drawn line
does. Each piece sits at the mean across-position v of its own pixels (following a gently
curving contour), and a piece whose pixels span two pen widths across — a strong, wide edge,
darker in the raster — becomes a bold stroke of two touching lines. Everything is whole-array
numpy (connected components, one lexsort, bincounts); no loop per pixel or per stroke.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
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
        Pen line width, mm; a component two pen widths thick is drawn bold (two lines).
    threshold : float or None
        Edge strength in [0, 1] below which pixels draw nothing; None uses :func:`edge_threshold`.
    min_pixels : int
        Components of fewer edge pixels are dropped (speckle, not contour).
    piece_length : float
        Longest stroke, in units of ℓ; longer components are cut into overlapping pieces.

    Returns
    -------
    list of (2, 2) float64 arrays
        Each stroke's two end points in mm on the page (Y up), in no particular order.
    """
    edges = np.asarray(line.edges, dtype=np.float32)
    ell = float(line.length)
    thr = edge_threshold(edges) if threshold is None else float(threshold)
    found = _component_pixels(edges > thr, line.labels, min_pixels)
    if found is None:
        return []
    comp, direction, u, v = found
    p0, p1, piece_v, piece_dir, piece_of_pixel = _pieces(comp, direction, u, v, ell, piece_length)

    # A piece whose pixels span two pen widths across is a strong, wide edge (the raster
    # draws it darker): draw it as two touching lines, a bold stroke, not one thin one.
    v_min = np.full(p0.size, np.inf)
    v_max = np.full(p0.size, -np.inf)
    np.minimum.at(v_min, piece_of_pixel, v)
    np.maximum.at(v_max, piece_of_pixel, v)
    pen_px = pen_width / layout.mm_per_px
    bold = v_max - v_min + 1 >= 2 * pen_px
    shift = np.where(bold, pen_px / 2, 0.0)
    p0, p1, piece_dir = (np.concatenate([a, a[bold]]) for a in (p0, p1, piece_dir))
    piece_v = np.concatenate([piece_v - shift, piece_v[bold] + pen_px / 2])

    p0, p1 = _clip_to_image(p0, p1, piece_v, piece_dir, edges.shape)
    inside = p1 - p0 > 1e-6
    p0, p1, piece_v, piece_dir = p0[inside], p1[inside], piece_v[inside], piece_dir[inside]
    theta = piece_dir * (np.pi / N_DIRECTIONS)
    along = np.stack([np.cos(theta), -np.sin(theta)], axis=1)
    across = np.stack([np.sin(theta), np.cos(theta)], axis=1)
    start_px = p0[:, None] * along + piece_v[:, None] * across
    end_px = p1[:, None] * along + piece_v[:, None] * across
    ends_mm = layout.px_to_mm(np.concatenate([start_px, end_px])).reshape(2, -1, 2)
    return list(np.stack([ends_mm[0], ends_mm[1]], axis=1))


def _component_pixels(mask, labels, min_pixels):
    """Pixels of components with at least ``min_pixels``, sorted by (component, u).

    Returns ``(component index 0..n−1, direction, u, v)`` per pixel, or None if nothing is left.
    """
    component = _direction_components(mask, labels)
    rows, cols = np.nonzero(component)
    if rows.size == 0:
        return None
    ident = component[rows, cols]
    direction = labels[rows, cols].astype(np.intp)
    u, v = _rotate(cols, rows, direction)
    order = np.lexsort((u, ident))
    ident, direction, u, v = ident[order], direction[order], u[order], v[order]
    counts = np.diff(np.append(np.flatnonzero(np.append(True, ident[1:] != ident[:-1])), ident.size))
    keep = np.repeat(counts >= min_pixels, counts)
    if not keep.any():
        return None
    kept = ident[keep]
    comp = np.cumsum(np.append(True, kept[1:] != kept[:-1])) - 1
    return comp, direction[keep], u[keep], v[keep]


def _pieces(comp, direction, u, v, ell, piece_length):
    """Cut every component's stroke into overlapping pieces, each at its own pixels' mean v.

    A component spanning [u0, u1] paints from u0 − ℓ/2 to u1 + ℓ/2, like the kernel; the
    extent is split into equal pieces of at most ``piece_length`` · ℓ that overlap by ℓ/4.
    Following the mean v piece by piece tracks a gently curving contour instead of one chord.

    Returns
    -------
    p0, p1, v, direction : arrays, one entry per piece (u extent, across position, label)
    piece_of_pixel : array mapping every pixel to its piece
    """
    first = np.flatnonzero(np.append(True, comp[1:] != comp[:-1]))
    last = np.append(first[1:], u.size) - 1
    start, stop = u[first] - ell / 2, u[last] + ell / 2
    overlap = ell / 4
    n_pieces = np.maximum(
        1, np.ceil((stop - start - overlap) / max(piece_length * ell - overlap, 1e-9))
    ).astype(np.intp)
    piece = (stop - start + (n_pieces - 1) * overlap) / n_pieces
    step = piece - overlap

    index_in_comp = np.clip(np.floor((u - start[comp]) / step[comp]), 0, n_pieces[comp] - 1)
    piece_base = np.cumsum(n_pieces) - n_pieces
    piece_of_pixel = piece_base[comp] + index_in_comp.astype(np.intp)
    total = int(n_pieces.sum())
    pixels = np.bincount(piece_of_pixel, minlength=total)
    v_sum = np.bincount(piece_of_pixel, weights=v, minlength=total)
    comp_v = np.bincount(comp, weights=v) / np.bincount(comp)
    owner = np.repeat(np.arange(first.size), n_pieces)
    # A piece over a gap in its component has no pixels: it keeps the component's mean v.
    piece_v = np.where(pixels > 0, v_sum / np.maximum(pixels, 1), comp_v[owner])
    p0 = start[owner] + (np.arange(total) - piece_base[owner]) * step[owner]
    return p0, p0 + piece[owner], piece_v, direction[first][owner], piece_of_pixel


def _direction_components(mask: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Label 8-connected groups of masked pixels that share a direction; 0 = not an edge."""
    out = np.zeros(mask.shape, dtype=np.int32)
    offset = 0
    for k in range(N_DIRECTIONS):
        count, comp = cv2.connectedComponents((mask & (labels == k)).astype(np.uint8), connectivity=8)
        hit = comp > 0
        out[hit] = comp[hit] + offset
        offset += count
    return out


def _rotate(cols, rows, direction):
    """(u, v): pixel coordinates along and across direction k."""
    theta = direction * (np.pi / N_DIRECTIONS)
    # Direction k is (cos θ, −sin θ) in (col, row): rows grow downward on screen.
    u = cols * np.cos(theta) - rows * np.sin(theta)
    v = cols * np.sin(theta) + rows * np.cos(theta)
    return u, v


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
