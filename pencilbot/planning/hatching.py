"""Tone as hatching: families of pen lines that follow the form, dense where the picture is dark.

A family is the set of level lines φ = k·s of a stripe phase φ (:mod:`pencilbot.planning.flow`):
smooth, evenly spaced curves that run along the picture's isophotes (the first family) or at a
fixed angle to them (the cross-hatching families). s is the densest spacing, w / f for a pen of
width w and a family coverage of f at most.

Which lines are drawn where is an ordered dither: line k carries a rank τ_k = frac(k/γ) in
(0, 1), γ the golden ratio, and is drawn wherever the share of the family the tone asks for
exceeds τ_k. By the three-gap theorem the lines that are on at *any* share are spread evenly
(at most three gap lengths, within a factor γ of each other). Light tones would switch on lines
centimetres apart, which read as scratches: below a share that keeps lines ``MAX_GAP`` apart,
the lines stay at that spacing and are dashed instead, each dash cell of 2 · ``min_run`` drawn when
its own golden rank along the line is below the duty the tone needs (a cell is two shortest
strokes long, so a lone dash is never dropped as a crumb). The share is the family's coverage request
divided by what all its lines would cover there (w · |∇φ| / s: lines crowd where |∇φ| > 1), so a
family's ink follows its request however the level lines bend.

The families share the darkness with overlapping ramps (:mod:`pencilbot.planning.onset`), so
cross-hatching fades in continuously instead of appearing as a band.

Clipping is sampling, not geometry: every level line is traced once (``cv2.findContours`` on the
stripes, then a Newton step onto the exact level), resampled at a fixed step, and its samples are
switched on or off by the request; runs of "on" samples become pen strokes. Short gaps are
bridged and short runs dropped, so tone never turns into speckle. All of it is whole-array numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage as ndi

from pencilbot.paths import Paths, ramps
from pencilbot.planning.flow import DirectionField, Grid, bilinear, grid_gradient, stripe_phase
from pencilbot.planning.onset import Onset
from pencilbot.planning.plan import Layer
from pencilbot.planning.spread import GOLDEN, line_mean, spread_lines
from pencilbot.units import DEFAULT_PEN_WIDTH

#: Default hatching, the one place these are said (the style's fields and shade() start here):
#: the families' angles (degrees; along the forms, then across and at 45° to them), the most one
#: family covers, the share of a family's ramp the next one overlaps, the shortest stroke (mm).
#: Coverage 0.8 and 1.2 mm strokes (were 0.7 and 2 mm): the first family, the one that follows
#: the forms, carries more of the tone on closer lines, and tone changes over shorter dashes, so
#: the plot follows the photo at a finer scale with about the same ink (bench/fidelity.py, whole
#: box rho: starry_night 0.890 -> 0.913, moon 0.936 -> 0.944, baboon 0.937 -> 0.946, coffee
#: 0.955 -> 0.961; plot time up to a minute or two more). Coverage 0.85 followed the photo a
#: little better still (starry_night 0.915) but planned 1.3-1.4x slower: the tone loop's cells
#: shrink with the spacing.
HATCH_ANGLES = (0.0, 90.0, 45.0, -45.0)
HATCH_COVERAGE = 0.8
HATCH_OVERLAP = 0.25
MIN_HATCH_RUN = 1.2

# Widest gap (mm) between neighbouring drawn lines of a family; lighter tones are dashed.
MAX_GAP = 3.0
# Shortest stroke of a cross-hatching family, in shortest strokes of the first family.
CROSS_RUN = 2.5
# Step (mm) at which hatch lines are sampled for switching on and off.
SAMPLE_STEP = 0.4
# Points of an output stroke are kept about this far apart (mm): the lines are smooth curves.
POINT_SPACING = 1.6
# A stroke whose pen path is this much (mm) shorter than its shortest length folds back on itself.
FOLD_TOLERANCE = 0.5
#: Where the picture matters most (a face), the hatching is finer by this factor: shortest
#: stroke, dash cell and widest gap between lines are this share of elsewhere's (a light face
#: gets dashes of 0.7 mm on lines under 2 mm apart instead of 1.2 mm dashes 3 mm apart; finer
#: still is more pen lifts than a face is worth: grace_hopper's plot went past 30 minutes).
FINE = 0.6


@dataclass(frozen=True)
class HatchLines:
    """All candidate lines of one family, sampled every ``SAMPLE_STEP`` mm.

    Attributes
    ----------
    points : (N, 2) float array
        Samples in page mm; the samples of one line are consecutive.
    line : (N,) int array
        Which traced line each sample lies on (non-decreasing).
    level : (N,) int array
        The level k (φ = k·s) of the sample's line.
    along : (N,) float array
        Arc length (mm) from the start of the sample's traced line.
    full : (N,) float array
        Paper fraction the family covers at that sample with every line on (w · |∇φ| / s, ≤ 1).
    normal : (N, 2) float array
        Unit direction of ∇φ (towards the next level), page mm.
    capacity : (rows, cols) float array
        The same on the field's grid, everywhere (0 where no line of the family passes).
    """

    points: np.ndarray
    line: np.ndarray
    level: np.ndarray
    along: np.ndarray
    full: np.ndarray
    capacity: np.ndarray
    normal: np.ndarray


def family_lines(
    field: DirectionField, *, pen_width: float, coverage: float, wobble: float = 0.0, seed: int = 0
) -> HatchLines:
    """Trace the level lines of the stripe phase of ``field`` at spacing ``pen_width / coverage``.

    Parameters
    ----------
    field : DirectionField
        Directions the lines follow.
    pen_width : float
        Pen width w, mm.
    coverage : float
        Densest family coverage f in (0, 1); spacing s = w / f.
    wobble : float
        Amplitude of a smooth random bend of the lines, as a fraction of the spacing.
    seed : int
        Seed of the wobble.

    Returns
    -------
    HatchLines
    """
    spacing = pen_width / coverage
    coarse = field.grid
    phase = stripe_phase(field)
    if wobble > 0:
        rng = np.random.default_rng(seed)
        noise = ndi.gaussian_filter(rng.standard_normal(phase.shape), 6.0 / coarse.cell, mode="wrap")
        phase = phase + wobble * spacing * noise / max(noise.std(), 1e-12)
    grad_r, grad_c = grid_gradient(phase, coarse.cell)
    slope = np.hypot(grad_r, grad_c)  # |∇φ|: 1 where the field is curl-free
    # A fine grid of three cells per spacing resolves every stripe of width s.
    fine = Grid(coarse.box, spacing / 3.0)
    phi = coarse.resample(phase, fine, cubic=True).astype(np.float64)
    stripes = (np.floor(phi / spacing).astype(np.int64) & 1 == 0).astype(np.uint8)  # sin(πφ/s) > 0
    contours, _ = cv2.findContours(stripes, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return _no_lines(coarse.shape)
    lengths = np.array([len(c) for c in contours])
    rc = np.concatenate(contours).reshape(-1, 2)[:, ::-1].astype(np.float64)  # (row, col)
    chain = np.repeat(np.arange(len(contours)), lengths)
    rows, cols = fine.shape
    # Contour pixels on the grid's border trace the picture's edge, not a level line.
    inner = (rc[:, 0] > 0) & (rc[:, 0] < rows - 1) & (rc[:, 1] > 0) & (rc[:, 1] < cols - 1)
    # Every other contour pixel is plenty for a smooth curve sampled every SAMPLE_STEP.
    inner[1::2] = False
    rc, chain = rc[inner], chain[inner]
    if rc.size == 0:
        return _no_lines(coarse.shape)
    # A Newton step onto the nearest level φ = k·s (φ is nearly linear across a cell); its
    # gradient comes from the smooth coarse phase, in fine cells.
    value = bilinear(phi, rc)
    level = np.rint(value / spacing)
    at = coarse.to_rc(fine.to_mm(rc))
    g = np.stack([bilinear(grad_r, at), bilinear(grad_c, at)], axis=1) * fine.cell
    rc = rc - ((value - level * spacing) / np.maximum((g**2).sum(axis=1), 1e-12))[:, None] * g
    rc = np.clip(rc, 0, [rows - 1, cols - 1])
    level = level.astype(np.int64)
    mm = fine.to_mm(rc)
    # A traced line ends where its contour leaves the picture, changes level or jumps.
    step = np.linalg.norm(np.diff(mm, axis=0), axis=1)
    cut = (chain[1:] != chain[:-1]) | (level[1:] != level[:-1]) | (step > 4.0 * fine.cell)
    piece = np.concatenate([[0], np.cumsum(cut)])
    points, owner, along = _resample(mm, piece, SAMPLE_STEP)
    # The fine grid overhangs the drawing box by part of a cell: samples out there are dropped,
    # and a line that leaves the box and comes back continues as a new line.
    x0, y0, x1, y1 = coarse.box
    inside = (points[:, 0] >= x0) & (points[:, 0] <= x1) & (points[:, 1] >= y0) & (points[:, 1] <= y1)
    restart = np.append(True, (owner[1:] != owner[:-1]) | ~inside[:-1])
    line = np.cumsum(restart)[inside] - 1
    points, owner, along = points[inside], owner[inside], along[inside]
    if points.size == 0:
        return _no_lines(coarse.shape)
    piece_level = level[np.searchsorted(piece, np.arange(piece[-1] + 1))]
    capacity = np.minimum(1.0, pen_width * slope / spacing)
    full = coarse.sample(capacity, points)
    normal = np.stack([coarse.sample(grad_c, points), -coarse.sample(grad_r, points)], axis=1)
    normal /= np.maximum(np.linalg.norm(normal, axis=1), 1e-12)[:, None]
    return HatchLines(points, line, piece_level[owner], along, full, capacity, normal)


def hatch_strokes(
    lines: HatchLines,
    request: np.ndarray,
    *,
    pen_width: float,
    min_run: float = 2.0,
    offset: float = 0.0,
    fine: np.ndarray | None = None,
) -> Paths:
    """The pen strokes of one family for a per-sample coverage request.

    Parameters
    ----------
    lines : HatchLines
    request : (N,) float array
        Paper fraction this family should cover around each sample.
    pen_width : float
        Pen width, mm.
    min_run : float
        Shortest stroke kept, mm; gaps shorter than half of it are bridged.
    offset : float
        Shift of the dither ranks in [0, 1), so families switch on different lines.
    fine : (N,) float array in [0, 1], optional
        How much each sample lies where the picture matters most (a face): there strokes,
        dashes and the widest gap between lines shrink towards ``FINE`` of their size, so
        tone changes over shorter distances and light tones are closer lines.

    Returns
    -------
    Paths
        Polylines in page mm, one per run of switched-on samples.
    """
    if lines.points.size == 0:
        return Paths.empty()
    if fine is not None and not np.any(fine > 0):
        fine = None  # exactly the plain path: no rounding of cell counts differs
    scale = np.ones(len(lines.points)) if fine is None else 1.0 - (1.0 - FINE) * np.clip(fine, 0.0, 1.0)
    on, line_share = _switched_on(
        lines, request, pen_width=pen_width, min_run=min_run, offset=offset, fine=fine, scale=scale
    )
    return _strokes(spread_lines(lines, on, line_share, offset, pen_width, SAMPLE_STEP), on, min_run, scale)


def _switched_on(lines: HatchLines, request, *, pen_width: float, min_run: float, offset: float, fine, scale):
    """(N,) bool: the samples drawn, by the ordered dither of lines and dash cells (see the module)."""
    # The share of lines needed, smoothed along each line over a shortest stroke: a line
    # switches on or off where the tone really changes, not at every ripple of the request.
    raw = np.asarray(request, np.float64) / np.maximum(lines.full, 1e-6)
    share = _along_mean(raw, lines.line, min_run)
    if fine is not None:
        share = np.where(scale < 1.0, _along_mean(raw, lines.line, FINE * min_run), share)
    # Local line spacing w / full; lines may not be switched off below MAX_GAP apart.
    least = np.minimum(1.0, pen_width / (np.maximum(lines.full, 1e-6) * MAX_GAP * scale))
    line_share = np.maximum(share, least)
    level_rank = np.mod(lines.level * GOLDEN + offset, 1.0)
    # Dash cells are all on or all off, by the cell's mean duty. A cell is 2 · min_run long
    # (shorter where ``fine``): cells are counted along the line by the integral of 1 / length.
    if fine is None:
        cell = np.floor(lines.along / (2.0 * min_run)).astype(np.int64)
    else:
        count = np.cumsum(SAMPLE_STEP / (2.0 * min_run * scale))
        first = np.flatnonzero(np.append(True, lines.line[1:] != lines.line[:-1]))
        owner = np.cumsum(np.append(True, lines.line[1:] != lines.line[:-1])) - 1
        cell = np.floor(count - count[first][owner]).astype(np.int64)
    key = np.cumsum(np.append(True, (cell[1:] != cell[:-1]) | (lines.line[1:] != lines.line[:-1]))) - 1
    duty = np.bincount(key, weights=share / line_share) / np.bincount(key)
    dash_rank = np.mod(cell * GOLDEN + lines.level * 0.7548776662 + offset, 1.0)
    on = (level_rank < line_share) & (dash_rank < duty[key]) & (share > 0)
    return on, line_share


def _strokes(lines: HatchLines, on: np.ndarray, min_run: float, scale: np.ndarray) -> Paths:
    """The runs of ``on`` samples as pen strokes: short gaps bridged, crumbs and hooks dropped."""
    # Runs of "on" samples within a line.
    starts, stops = _runs(on, lines.line)
    if starts.size == 0:
        return Paths.empty()
    # Bridge gaps shorter than half a minimum run, then drop runs shorter than one.
    gap = (starts[1:] - stops[:-1] - 1) * SAMPLE_STEP
    same_line = lines.line[starts[1:]] == lines.line[stops[:-1]]
    merged = np.append(False, same_line & (gap < min_run * scale[starts[1:]] / 2))
    keep_start = np.flatnonzero(~merged)
    run_start = starts[keep_start]
    run_stop = stops[np.append(keep_start[1:], starts.size) - 1]
    long_enough = (run_stop - run_start) * SAMPLE_STEP >= min_run * np.minimum(
        scale[run_start], scale[run_stop]
    )
    run_start, run_stop = run_start[long_enough], run_stop[long_enough]
    if run_start.size == 0:
        return Paths.empty()
    # Keep every few samples along a run, and always its last one.
    keep_every = max(1, round(POINT_SPACING / SAMPLE_STEP))
    counts = run_stop - run_start + 1
    kept = (counts - 1) // keep_every + 1 + ((counts - 1) % keep_every > 0)
    index = np.minimum(np.repeat(run_start, kept) + ramps(kept) * keep_every, np.repeat(run_stop, kept))
    strokes = Paths(lines.points[index], np.concatenate([[0], np.cumsum(kept)]))
    # A run long enough along its line can still fold back on itself where the form turns
    # sharply: its pen stroke is then a hook shorter than a shortest stroke. Drop those.
    hooked = (
        strokes.drawn_lengths() < min_run * np.minimum(scale[run_start], scale[run_stop]) - FOLD_TOLERANCE
    )
    return strokes.take(np.flatnonzero(~hooked)) if hooked.any() else strokes


def hatch_layers(
    darkness: np.ndarray,
    grid: Grid,
    field: DirectionField,
    *,
    pen_width: float = DEFAULT_PEN_WIDTH,
    angles: tuple[float, ...] = HATCH_ANGLES,
    coverage: float = HATCH_COVERAGE,
    overlap: float = HATCH_OVERLAP,
    min_run: float = MIN_HATCH_RUN,
    wobble: float = 0.0,
    seed: int = 0,
    lines: list[HatchLines] | None = None,
    capacity: np.ndarray | None = None,
    fine: np.ndarray | None = None,
) -> list[Layer]:
    """Hatch layers whose ink follows ``darkness`` (one layer per family).

    Parameters
    ----------
    darkness : (rows, cols) array
        Darkness to cover in [0, 1] on ``grid``.
    grid : Grid
        The grid of ``darkness``.
    field : DirectionField
        The form the first family follows; family j runs at ``angles[j]`` degrees to it.
    pen_width : float
        Pen width, mm.
    angles : tuple of float
        Each family's angle to the field, degrees; the first covers the lightest tones.
    coverage : float
        Densest coverage of one family, in (0, 1); spacing = pen_width / coverage.
    overlap : float
        How much of a family's ramp the next one overlaps, in [0, 1): 0 starts a family only
        when the one before is full (a visible band), 0.5 halfway.
    min_run : float
        Shortest stroke, mm.
    wobble : float
        Smooth random bend of the lines, fraction of the spacing.
    seed : int
    lines : list of HatchLines, optional
        Lines traced before by :func:`trace_families` for the same field and parameters; it may
        hold only the first families (the tone never needs the others): those are not drawn.
    capacity : (families, rows, cols) array, optional
        :func:`family_capacity` of ``lines`` on ``grid``, when it was computed before.
    fine : (rows, cols) array in [0, 1], optional
        Where on ``grid`` the hatching is finer (faces; see :func:`hatch_strokes`).

    Returns
    -------
    list of Layer
        Named ``hatch<j>-<angle to the form>``, lightest first; a family the tone never needs has no paths.
    """
    if not 0 < coverage < 1:
        raise ValueError(f"coverage must be in (0, 1), got {coverage}")
    if lines is None:
        lines = trace_families(
            field, pen_width=pen_width, angles=angles, coverage=coverage, wobble=wobble, seed=seed
        )
    onset = Onset.spread(len(angles), coverage, overlap)
    if capacity is None:
        capacity = family_capacity(lines, field, grid, families=len(angles))
    shares = onset.allocate(darkness, capacity).reshape(len(angles), *grid.shape)
    layers = []
    for j, (family, angle) in enumerate(zip(lines, angles[: len(lines)], strict=True)):
        request = grid.sample(shares[j], family.points)
        # Cross-hatching in a narrow band would be a comb of short ticks: later families need
        # longer strokes, and the loop hands what they leave to the first.
        shortest = min_run * (1.0 if j == 0 else CROSS_RUN)
        where = None if fine is None else grid.sample(fine, family.points)
        strokes = hatch_strokes(
            family, request, pen_width=pen_width, min_run=shortest, offset=j * GOLDEN / 3, fine=where
        )
        layers.append(Layer(f"hatch{j + 1}-{angle % 180:g}", strokes, pen_width=pen_width, role="hatch"))
    return layers


def family_capacity(
    lines: list[HatchLines], field: DirectionField, grid: Grid, *, families: int | None = None
) -> np.ndarray:
    """(families, rows, cols): what each family covers with every line on, on ``grid``; zero for
    the families past ``len(lines)`` that were not traced."""
    out = np.zeros((families or len(lines), *grid.shape))
    for j, family in enumerate(lines):
        out[j] = field.grid.resample(family.capacity, grid)
    return out


def trace_families(
    field: DirectionField,
    *,
    pen_width: float,
    angles: tuple[float, ...],
    coverage: float,
    wobble: float = 0.0,
    seed: int = 0,
) -> list[HatchLines]:
    """:func:`family_lines` for every family angle (the part of hatching that does not depend on tone)."""
    return [
        family_lines(
            field.rotated(angle), pen_width=pen_width, coverage=coverage, wobble=wobble, seed=seed + j
        )
        for j, angle in enumerate(angles)
    ]


def _resample(
    points: np.ndarray, piece: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points every ``step`` mm along each piece (consecutive points with one ``piece`` id).

    Returns the points, the piece of each and its arc length from the piece's start.
    """
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    seg[piece[1:] != piece[:-1]] = 0.0
    along = np.concatenate([[0.0], np.cumsum(seg)])
    first = np.flatnonzero(np.append(True, piece[1:] != piece[:-1]))
    last = np.append(first[1:], len(points)) - 1
    start, length = along[first], along[last] - along[first]
    count = np.floor(length / step).astype(np.int64) + 1
    count[length < step] = 0  # a piece shorter than one step is a crumb
    owner = np.repeat(np.arange(first.size), count)
    t = start[owner] + ramps(count) * step
    # Pieces are separated in `along` only by zero-length joins: search within the piece.
    seg_index = np.clip(np.searchsorted(along, t, side="right") - 1, 0, len(points) - 2)
    seg_index = np.clip(seg_index, first[owner], np.maximum(last[owner] - 1, first[owner]))
    a, b = points[seg_index], points[np.minimum(seg_index + 1, last[owner])]
    span = np.maximum(along[np.minimum(seg_index + 1, last[owner])] - along[seg_index], 1e-12)
    frac = np.clip((t - along[seg_index]) / span, 0.0, 1.0)
    return a + (b - a) * frac[:, None], owner, t - start[owner]


def _along_mean(values: np.ndarray, line: np.ndarray, length: float) -> np.ndarray:
    """Moving average of per-sample ``values`` over ``length`` mm along each line (not across lines)."""
    return line_mean(values, line, int(round(length / (2 * SAMPLE_STEP))))


def _runs(on: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and last index of every run of True in ``on`` that stays within one ``line``."""
    boundary = np.append(True, line[1:] != line[:-1])
    starts = np.flatnonzero(on & (boundary | ~np.append(False, on[:-1])))
    end = np.append(line[1:] != line[:-1], True)
    stops = np.flatnonzero(on & (end | ~np.append(on[1:], False)))
    return starts, stops


def _no_lines(shape: tuple[int, int]) -> HatchLines:
    empty = np.zeros(0)
    return HatchLines(
        np.zeros((0, 2)),
        empty.astype(np.int64),
        empty.astype(np.int64),
        empty,
        empty,
        np.zeros(shape),
        np.zeros((0, 2)),
    )
