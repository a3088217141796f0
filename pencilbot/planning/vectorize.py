"""The GMED line drawing as pen paths: chains of short directional strokes along each contour.

The raster line drawing paints, for every edge pixel labelled with direction i, a line of length
ℓ along direction i (L = Σ Lᵢ ⊗ Bᵢ). A pen redraws it contour by contour:

1. **Contour pixels.** Edge pixels at least as strong as the raster shows ``PEN_DARKNESS`` dark
   (:func:`edge_threshold`, on the absolute scale of :mod:`pencilbot.imaging.gmed`), continued by
   hysteresis through stretches half as dark, are thinned to their one-pixel skeleton (pinholes
   filled first, so a textured band does not thin to little loops). A band of edge pixels —
   what dilation makes of one contour, with labels that vary across its width — is drawn once,
   not as parallel strokes of mixed directions.
2. **Strokes.** Lu's labels, averaged as doubled angles over σ = ℓ/5 (the per-pixel argmax
   flickers along a skeleton), group 8-connected skeleton pixels of one direction into a
   stroke. It runs from its first to its last pixel, bending at the centre of each piece of
   about ``piece_length`` · ℓ so that it follows a curving contour instead of cutting a chord,
   and overshoots both ends by ℓ/4 (half its own length at most) as the kernel's paint does.
3. **Texture is not contour.** Where many strokes of different directions crowd (spoon
   reflections, badges, wood grain, hair), a draughtsman draws the few long lines and leaves the
   rest to the shading. Around each skeleton pixel, in a Gaussian window of σ = ``CLUTTER_SIGMA``
   · ℓ: the contours crossing it (the skeleton's density, 1 for a lone contour, 2 between the
   two sides of a rim) times one minus the coherence of their directions (1 when they all run
   alike). This *clutter* is about 0.1 along contours, even parallel ones, and 2–3 in dense
   texture; averaged over a chain of strokes (step 4) it decides: a chain of clutter c above
   ``clutter`` (2) must be at least ℓ · (c / ``clutter``)⁴ long to be drawn. Long coherent
   contours through a textured region stay, its knots of short strokes go, and the hatching
   carries its darkness. A picture that is texture through and through (a painting's brush
   strokes) keeps few chains of low clutter each, but very many: there a *budget* of contour
   length per area holds (the less of it, the further the contours overflow it); past it
   chains go by (1 + clutter) / length, short cluttered ones first and long coherent contours
   last, never those in an ``important`` region (a face).
4. **Chains.** Strokes that continue each other along one contour are chained into one pen-down
   path through their crossing points (:mod:`pencilbot.planning.chaining`).
5. **Bold.** A contour is drawn with as many touching pen lines (up to ``MAX_LINES``) as the
   raster's width across it (its darkness per skeleton pixel over a window of ℓ) is pen widths.

Everything is whole-array numpy, OpenCV and scipy (connected components, one lexsort, bincounts,
a KD-tree, a depth-first order); no loop per pixel or per stroke.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np
from skimage.filters import apply_hysteresis_threshold
from skimage.morphology import skeletonize

from pencilbot.paths import Paths, ramps
from pencilbot.planning.chaining import NO_LINKS, Strokes, chain_ids, chain_polylines, link_strokes, relinked
from pencilbot.planning.contour_budget import OVERFLOW_POWER, budget_length, within_budget
from pencilbot.units import DEFAULT_PEN_WIDTH

if TYPE_CHECKING:
    from pencilbot.imaging.strokes import LineDrawing

N_DIRECTIONS = 8
#: Darkness of the raster line drawing (0..1) from which the pen draws the stroke.
PEN_DARKNESS = 0.45
#: Fewest pixels of a contour that is drawn, and how far (mm) chained strokes may be apart to join.
MIN_EDGE_PIXELS = 3
EDGE_JOIN = 0.5
#: Clutter (crossing contours × incoherence of their directions) above which strokes are texture.
CLUTTER = 2.0
#: Gaussian σ of the clutter window, in stroke lengths ℓ.
CLUTTER_SIGMA = 1.5
#: How fast the length a cluttered chain needs grows with its clutter: ℓ · (c / clutter)^power.
CLUTTER_POWER = 4
#: Most touching pen lines one contour is drawn with, for the widest raster strokes.
MAX_LINES = 3


def edge_threshold(line: LineDrawing, darkness: float = PEN_DARKNESS) -> float:
    """Edge strength from which a contour is drawn with the pen.

    Parameters
    ----------
    line : LineDrawing
        The raster line drawing (its tone curve: γ and floor).
    darkness : float
        Darkness in (0, 1) the raster shows a stroke at before the pen draws it.

    Returns
    -------
    float
        E in [0, 1]; skeleton pixels stronger than this carry a stroke. Absolute: a blank or
        flat picture has no edge this strong and plans no edge strokes.
    """
    return line.edge_strength(darkness)


@dataclass(frozen=True)
class EdgeOptions:
    """How :func:`edge_strokes` draws the contours (a style's edge keys, resolved for one sketch).

    Attributes
    ----------
    pen_width : float
        Pen line width, mm; a contour whose raster stroke is n pen widths wide is drawn with n
        touching lines (at most ``max_lines``).
    threshold : float or None
        Edge strength in [0, 1] below which pixels draw nothing; None uses :func:`edge_threshold`.
    min_pixels : int
        Chains of fewer skeleton pixels are dropped (speckle, not contour).
    piece_length : float
        Longest straight piece, in units of ℓ; a longer component bends between pieces.
    join : float
        Strokes whose core ends lie within this many ℓ (at least 2 px) and continue each other's
        direction are chained into one path through their crossing point; negative: never.
    clutter : float
        Clutter above which short chains of strokes are dropped as texture (see the module
        docstring); ``inf`` keeps every chain.
    max_lines : int
        Most touching pen lines a bold contour is drawn with (1: every contour one line).
    budget : float, optional
        Most contour length, mm per mm² of the image on the page; past it the most cluttered
        chains are dropped first (see the module docstring). None: no budget.
    overflow_power : float
        Past the budget the length kept is the budget / overflow ** this (0: the budget itself).
    fine_threshold : float, optional
        The edge threshold where :func:`edge_strokes`' ``important`` is 1 (default: ``threshold``).
    """

    pen_width: float = DEFAULT_PEN_WIDTH
    threshold: float | None = None
    min_pixels: int = MIN_EDGE_PIXELS
    piece_length: float = 2.0
    join: float = EDGE_JOIN
    clutter: float = CLUTTER
    max_lines: int = MAX_LINES
    budget: float | None = None
    fine_threshold: float | None = None
    overflow_power: float = OVERFLOW_POWER


def edge_strokes(
    line: LineDrawing,
    layout,
    options: EdgeOptions | None = None,
    *,
    important: np.ndarray | None = None,
    **fields: Any,
) -> Paths:
    """Pen paths that redraw the GMED line drawing, one chain of strokes per contour.

    Parameters
    ----------
    line : LineDrawing
        Edge map, direction labels and stroke length ℓ (px) from :mod:`pencilbot.imaging.strokes`.
    layout : pencilbot.planning.layout.Layout
        Maps image pixels to page millimetres (``mm_per_px``, ``px_to_mm``).
    options : EdgeOptions, optional
        How to draw them; ``**fields``: any of its fields, over it (``pen_width=0.5``).
    important : (H, W) float array in [0, 1], optional
        Where the picture matters most (faces: :func:`pencilbot.imaging.faces.face_mask`).
        There the threshold falls towards ``fine_threshold`` (the edge map is raised by their
        ratio, so hysteresis and skeleton stay one pass: an eyelid, a brow, the corner of a
        mouth are faint edges), and no chain there is dropped for the budget.

    Returns
    -------
    Paths
        Pen-down paths in mm on the page (Y up), in no particular order; a lone stroke is a
        path of two points.
    """
    o = replace(options or EdgeOptions(), **fields)
    edges = np.asarray(line.edges, dtype=np.float32)
    ell = float(line.length)
    thr = edge_threshold(line) if o.threshold is None else float(o.threshold)
    if important is not None and o.fine_threshold is not None and 0 < o.fine_threshold < thr:
        edges = edges * (1.0 + (thr / o.fine_threshold - 1.0) * np.asarray(important, np.float32))
    # Hysteresis, as Canny: a contour goes on through stretches down to half the threshold
    # (a rim where the light grazes it), while weak texture on its own draws nothing.
    mask = apply_hysteresis_threshold(edges, _weaker(line, thr), thr)
    skeleton = skeletonize(_without_pinholes(mask, ell * ell / 4))
    # The frame's one-sided differences turn a contour's direction in its last pixel.
    skeleton[[0, -1], :] = skeleton[:, [0, -1]] = False
    found = _components(skeleton, _smoothed_labels(line))
    if found is None:
        return Paths.empty()
    comp, direction, u, v, rows, cols = found
    pen_px = o.pen_width / layout.mm_per_px
    width = _raster_width(line.drawing, skeleton, comp, rows, cols, ell)
    lines = np.clip(np.rint(width / pen_px), 1, max(1, o.max_lines)).astype(np.intp)
    v = v - ((lines - 1) * pen_px / 2)[comp]  # the first of n touching lines; the rest follow
    strokes = _strokes(comp, direction, u, v, ell, o.piece_length)
    links = link_strokes(strokes, max(2.0, o.join * ell)) if o.join >= 0 else NO_LINKS
    pixels = np.bincount(comp)
    texture = np.bincount(comp, weights=_clutter(skeleton, direction, rows, cols, ell)) / pixels
    keep = _contours(strokes, links, pixels, texture, ell, o.min_pixels, o.clutter)
    if o.budget is not None:
        allowed = budget_length(o.budget, edges.shape, layout.mm_per_px) / layout.mm_per_px  # px
        protected = (
            None
            if important is None
            else np.bincount(comp, weights=np.asarray(important, np.float32)[rows, cols]) / pixels > 0.5
        )
        keep &= within_budget(strokes, links, texture, keep, allowed, protected, o.overflow_power)
    paths = _chained(strokes.take(keep), relinked(links, keep), lines[keep], o, pen_px, edges.shape, ell)
    return paths.with_points(layout.px_to_mm(paths.points)) if len(paths) else paths


def _chained(strokes: Strokes, links, lines, o: EdgeOptions, pen_px: float, shape, ell: float) -> Paths:
    """The kept strokes chained along their contours (px), and the further lines of bold
    contours (``lines`` per stroke) beside them, chained alike."""
    reach = max(2.0, o.join * ell)
    paths_px = [chain_polylines(strokes, links, shape)]
    for k in range(1, max(1, o.max_lines)):
        extra = strokes.take(lines > k, shift_px=k * pen_px)
        paths_px.append(
            chain_polylines(extra, link_strokes(extra, reach) if o.join >= 0 else NO_LINKS, shape)
        )
    return Paths.concat(paths_px)


def _without_pinholes(mask: np.ndarray, largest: float) -> np.ndarray:
    """``mask`` with its holes of at most ``largest`` pixels filled.

    A pinhole in a band of edge pixels (texture, a glint) would thin to a little loop of
    strokes, a knot; a hole the size of a pupil is kept.
    """
    _count, hole, stats, _ = cv2.connectedComponentsWithStats((~mask).astype(np.uint8), connectivity=4)
    small = stats[:, cv2.CC_STAT_AREA] <= largest
    small[0] = False  # label 0: the mask itself
    return mask | small[hole]


def _components(skeleton, labels):
    """Skeleton pixels, sorted by (component, u): 8-connected runs of one direction label.

    Returns ``(component index 0..n−1, direction, u, v, row, col)`` per pixel, or None if
    there are none.
    """
    component = _direction_components(skeleton, labels)
    rows, cols = np.nonzero(component)
    if rows.size == 0:
        return None
    ident = component[rows, cols]
    direction = labels[rows, cols].astype(np.intp)
    u, v = _rotate(cols, rows, direction)
    order = np.lexsort((u, ident))
    ident, direction, u, v, rows, cols = (a[order] for a in (ident, direction, u, v, rows, cols))
    comp = np.cumsum(np.append(True, ident[1:] != ident[:-1])) - 1
    return comp, direction, u, v, rows, cols


def _weaker(line: LineDrawing, threshold: float) -> float:
    """The hysteresis low threshold: the strength whose stroke is half as dark as ``threshold``'s."""
    return min(threshold, line.edge_strength(line.stroke_darkness(threshold) / 2))


def _smoothed_labels(line: LineDrawing) -> np.ndarray:
    """Direction labels averaged over a Gaussian of σ = ℓ/5, as doubled angles weighted by E.

    Lu's per-pixel argmax flickers between distant directions along a skeleton where two
    kernels answer alike (on coffee and astronaut a third of the skeleton pixels have a
    neighbour labelled otherwise); the strokes would flicker with it. Averaging the axial
    directions 2θ (so θ and θ + 180° agree) halves that, the rest being the boundaries between
    neighbouring directions along curves. A wider average steadies the labels further but
    follows curves less closely: σ = ℓ/3 drew the plan's edges 0.01–0.03 further from the raster
    (line fidelity, ``bench/plan.py``).
    """
    theta2 = line.labels.astype(np.float32) * np.float32(2 * np.pi / N_DIRECTIONS)
    sigma = line.length / 5
    weight = np.asarray(line.edges, np.float32)
    c = cv2.GaussianBlur(weight * np.cos(theta2), (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    s = cv2.GaussianBlur(weight * np.sin(theta2), (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    step = np.arctan2(s, c) * np.float32(N_DIRECTIONS / (2 * np.pi))
    return (np.rint(step).astype(np.intp) % N_DIRECTIONS).astype(np.uint8)


def _clutter(skeleton, direction, rows, cols, ell) -> np.ndarray:
    """Clutter at each skeleton pixel (see the module docstring).

    The window is a Gaussian of σ = CLUTTER_SIGMA · ℓ. A straight line through its centre adds
    1/(√(2π) σ) to the blurred skeleton, so scaling by √(2π) σ counts crossing contours. Their
    coherence is the length of the mean doubled-angle vector of the skeleton's directions (so
    that θ and θ + 180° agree): 1 when all run alike, about 0 when every direction is there.
    """
    sigma = CLUTTER_SIGMA * ell
    theta2 = direction * (2 * np.pi / N_DIRECTIONS)
    planes = np.zeros((3,) + skeleton.shape, np.float32)
    planes[0, rows, cols] = 1.0
    planes[1, rows, cols] = np.cos(theta2)
    planes[2, rows, cols] = np.sin(theta2)
    count, c, s = (
        cv2.GaussianBlur(plane, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)[rows, cols] for plane in planes
    )
    coherence = np.hypot(c, s) / np.maximum(count, 1e-9)
    return count * (math.sqrt(2 * math.pi) * sigma) * np.clip(1.0 - coherence, 0.0, 1.0)


def _raster_width(drawing, skeleton, comp, rows, cols, ell):
    """Per component: the raster's width across it, in pixels of solid black.

    Darkness summed over an ℓ × ℓ window per skeleton pixel in it, averaged over the
    component's pixels: the graphite the raster lays per pixel of contour.
    """
    size = max(3, int(round(ell)) | 1)
    window: dict[str, Any] = {"ksize": (size, size), "normalize": False, "borderType": cv2.BORDER_CONSTANT}
    ink = cv2.boxFilter(1.0 - drawing, -1, **window)
    count = cv2.boxFilter(skeleton.astype(np.float32), -1, **window)
    width = ink[rows, cols] / np.maximum(count[rows, cols], 1.0)
    return np.bincount(comp, weights=width) / np.bincount(comp)


def _strokes(comp, direction, u, v, ell, piece_length) -> Strokes:
    """Each component's polyline: tip, core end, piece centres (if bent), core end, tip.

    The core ends are where the component's pixels start and stop (at the mean across-position
    of its pixels within a pixel of each end). A component longer than ``piece_length`` · ℓ
    bends at the centre of each piece of about that length. The tips overshoot the core ends
    along the end segments, by ℓ/4 or half the component's length if less, so that consecutive
    strokes cross as the raster's do, and a small feature (an eye's lid, a pupil) is drawn with
    small strokes; a straight (one-piece) stroke is just its two tips.
    """
    first = np.flatnonzero(np.append(True, comp[1:] != comp[:-1]))
    last = np.append(first[1:], u.size) - 1
    n_comp = first.size
    u0, u1 = u[first], u[last]
    n_pieces = np.maximum(1, np.ceil((u1 - u0 + 1) / max(piece_length * ell, 1e-9))).astype(np.intp)
    step = (u1 - u0 + 1) / n_pieces
    index = np.clip(np.floor((u - u0[comp]) / step[comp]), 0, n_pieces[comp] - 1).astype(np.intp)
    base = np.cumsum(n_pieces) - n_pieces
    piece = base[comp] + index
    total = int(n_pieces.sum())
    count = np.bincount(piece, minlength=total)
    piece_u = np.bincount(piece, weights=u, minlength=total) / np.maximum(count, 1)
    piece_v = np.bincount(piece, weights=v, minlength=total) / np.maximum(count, 1)
    # A piece over a gap in its component has no pixels: it sits midway, on the mean v.
    owner = np.repeat(np.arange(n_comp), n_pieces)
    comp_v = np.bincount(comp, weights=v) / np.bincount(comp)
    piece_v = np.where(count == 0, comp_v[owner], piece_v)
    piece_u = np.where(count == 0, u0[owner] + (np.arange(total) - base[owner] + 0.5) * step[owner], piece_u)
    near0 = (u - u0[comp] <= 1.0).astype(np.float64)
    near1 = (u1[comp] - u <= 1.0).astype(np.float64)
    v0 = np.bincount(comp, weights=v * near0) / np.bincount(comp, weights=near0)
    v1 = np.bincount(comp, weights=v * near1) / np.bincount(comp, weights=near1)

    # Vertices in (u, v): core end, piece centres of bent components, core end.
    bent = n_pieces > 1
    n_inner = 2 + np.where(bent, n_pieces, 0)
    starts = np.append(0, np.cumsum(n_inner))[:-1]
    vu, vv = np.empty(int(n_inner.sum())), np.empty(int(n_inner.sum()))
    vu[starts], vv[starts] = u0, v0
    vu[starts + n_inner - 1], vv[starts + n_inner - 1] = u1, v1
    slot = (starts[owner] + 1 + np.arange(total) - base[owner])[bent[owner]]
    vu[slot], vv[slot] = piece_u[bent[owner]], piece_v[bent[owner]]
    inner = np.column_stack(_unrotate(vu, vv, np.repeat(direction[first], n_inner)))
    core = np.stack([inner[starts], inner[starts + n_inner - 1]], axis=1)
    theta = direction[first] * (np.pi / N_DIRECTIONS)
    unit = np.column_stack([np.cos(theta), -np.sin(theta)])
    # Outward at each end: along the end segment, or the label's direction for a dot.
    out0 = core[:, 0] - inner[starts + 1]
    out1 = core[:, 1] - inner[starts + n_inner - 2]
    outward = np.stack([_unit_or(out0, -unit), _unit_or(out1, unit)], axis=1)
    overshoot = np.minimum(ell / 4, (u1 - u0 + 1) / 2)
    tips = core + overshoot[:, None, None] * outward

    # Polylines: tip, [core, centres, core,] tip — a one-piece stroke is its two tips.
    n_vertices = np.where(bent, n_inner + 2, 2)
    offsets = np.append(0, np.cumsum(n_vertices))
    points = np.empty((int(offsets[-1]), 2))
    points[offsets[:-1]] = tips[:, 0]
    points[offsets[1:] - 1] = tips[:, 1]
    keep_inner = np.repeat(bent, n_inner)
    target = (np.repeat(offsets[:-1] + 1, n_inner) + ramps(n_inner))[keep_inner]
    points[target] = inner[keep_inner]
    return Strokes(points, offsets, core, outward, unit, u1 - u0 + 1, overshoot)


def _unit_or(vectors: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """``vectors`` scaled to length 1; ``fallback`` where they are shorter than half a pixel."""
    length = np.hypot(vectors[:, 0], vectors[:, 1])
    return np.where((length >= 0.5)[:, None], vectors / np.maximum(length, 1e-12)[:, None], fallback)


def _contours(strokes, links, pixels, texture, ell, min_pixels, clutter) -> np.ndarray:
    """Which components to draw: those of chains that are contour, not speckle or texture.

    A chain (components linked along one contour) of fewer than ``min_pixels`` skeleton pixels
    is speckle. One whose mean clutter c (``texture`` per component) exceeds ``clutter`` is kept
    only if it is at least ℓ · (c / ``clutter``)^CLUTTER_POWER long. Judging chains, not
    components, keeps the short strokes that turn a corner or close a small circle.
    """
    chain = chain_ids(strokes.n, links)
    length = np.bincount(chain, weights=strokes.extent)
    chain_clutter = np.bincount(chain, weights=texture * strokes.extent) / length
    keep_chain = np.bincount(chain, weights=pixels) >= min_pixels
    keep_chain &= (chain_clutter <= clutter) | (length >= ell * (chain_clutter / clutter) ** CLUTTER_POWER)
    return keep_chain[chain]


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


def _unrotate(u, v, direction):
    """(col, row) of rotated coordinates (the inverse of :func:`_rotate`)."""
    theta = direction * (np.pi / N_DIRECTIONS)
    return u * np.cos(theta) + v * np.sin(theta), -u * np.sin(theta) + v * np.cos(theta)
