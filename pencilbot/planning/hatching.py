"""Tone as hatching: layers of parallel pen lines whose density follows the darkness of the image.

Parallel lines of pen width w at spacing s cover w/s of the paper; layers at different angles
combine as 1 − Π(1 − w/sₖ). Each layer has ruled lines at the densest spacing s = w / f (f = the
``coverage`` of one full layer), and every line j of layer k has its own darkness threshold: line
j is drawn where the darkness exceeds it. The thresholds of neighbouring lines follow a 1-D ordered
dither (bit-reversed index), so at any darkness the lines that are drawn are spread evenly and the
layer's local coverage is the fraction of lines switched on. Layer k starts where the k layers
before it are full, so the total coverage 1 − (1 − f)ᵏ (1 − f·φ) tracks darkness continuously
instead of in K steps.

Clipping is raster work, not geometry: every hatch line is sampled at sub-pixel steps, the samples
look up the (slightly blurred) darkness, and the runs of samples above the line's threshold become
pen strokes, found with one ``diff`` over the whole (lines × samples) boolean array. Short gaps
are bridged and short runs dropped, so tone never turns into speckle.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage as ndi

from pencilbot.planning.plan import Layer

# Lines per dither period: a layer's coverage moves in steps of 1/16 of its maximum.
DITHER_PERIOD = 16
# Hatch samples looked up at once: ~2 M keeps the temporary index arrays near 50 MB.
_SAMPLES_PER_BLOCK = 2_000_000


def hatch_layers(
    darkness: np.ndarray,
    layout,
    *,
    pen_width: float = 0.5,
    angles: tuple[float, ...] = (45.0, -45.0, 0.0, 90.0),
    coverage: float = 0.5,
    blur: float = 1.0,
    min_run: float = 2.0,
    blank_below: float = 0.0,
    jitter: float = 0.0,
    seed: int = 0,
) -> list[Layer]:
    """Hatch layers whose pen coverage follows ``darkness``.

    Parameters
    ----------
    darkness : (H, W) float array in [0, 1]
        Fraction of paper to cover with ink, on the image's pixel grid (e.g. 1 − J).
    layout : pencilbot.planning.layout.Layout
        Placement of the image on the page (``drawing_box``, ``mm_per_px``, ``mm_to_px``).
    pen_width : float
        Pen line width w, mm.
    angles : tuple of float
        One hatch layer per angle, degrees counter-clockwise from the page's +x axis, in the
        order the darkness fills them (the first covers the lightest tones).
    coverage : float
        Paper fraction f in (0, 1) one layer covers at its densest; line spacing = w / f.
    blur : float
        Gaussian sigma in mm applied to ``darkness`` first, so runs follow regions, not noise.
    min_run : float
        Shortest kept piece of hatch line, mm; gaps shorter than half of it are bridged.
    blank_below : float
        Darkness (after the blur) below which the paper is left blank.
    jitter : float
        Random offset of each line across its direction, as a fraction of the spacing in [0, 1].
    seed : int
        Seed of the jitter.

    Returns
    -------
    list of Layer
        One layer per angle, named ``hatch<k>-<angle mod 180>``, each a serpentine sequence of
        two-point paths in mm (Y up). A layer the tone never needs has no paths.
    """
    if not 0 < coverage < 1:
        raise ValueError(f"coverage must be in (0, 1), got {coverage}")
    dark = np.clip(np.asarray(darkness, dtype=np.float32), 0.0, 1.0)
    if blur > 0:
        dark = ndi.gaussian_filter(dark, blur / layout.mm_per_px, mode="nearest")
    # The lightest tones would get single ruled lines centimetres apart, which read as
    # scratches, not tone: leave them as paper.
    dark = np.where(dark < blank_below, 0.0, dark)
    spacing = pen_width / coverage
    # Run ends to a quarter pen width; the tone itself varies on the scale of millimetres.
    step = pen_width / 4
    x0, y0, x1, y1 = layout.drawing_box
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
    radius = np.hypot(x1 - x0, y1 - y0) / 2
    along_t = np.arange(-radius, radius + step, step)
    n_lines = int(np.ceil(2 * radius / spacing)) + 1
    rng = np.random.default_rng(seed)

    layers = []
    for k, angle in enumerate(angles):
        offsets = (np.arange(n_lines) - (n_lines - 1) / 2) * spacing
        offsets += rng.uniform(-jitter / 2, jitter / 2, n_lines) * spacing
        # Line j is drawn where darkness > 1 − (1 − f)^k (1 − f τ_j): layers before k are full,
        # and τ_j (the dither rank of j) is the share of layer k that must be on for line j.
        rank = (_bit_reverse(np.arange(n_lines) % DITHER_PERIOD) + 0.5) / DITHER_PERIOD
        threshold = 1 - (1 - coverage) ** k * (1 - coverage * rank)
        paths = _hatch_runs(dark, layout, centre, angle, along_t, offsets, threshold, min_run)
        layers.append(Layer(f"hatch{k + 1}-{angle % 180:g}", paths, pen_width=pen_width, role="hatch"))
    return layers


def hatch_coverage(darkness, *, coverage: float = 0.5, n_layers: int = 4) -> np.ndarray:
    """Paper fraction the hatching puts ink on for a given darkness (the dither's ideal).

    Parameters
    ----------
    darkness : float or array in [0, 1]
    coverage : float
        Coverage f of one full layer.
    n_layers : int
        Number of hatch layers K.

    Returns
    -------
    ndarray
        1 − (1 − f)ᵏ (1 − f·φ) with φ the share of layer k switched on, rounded to the dither's
        1/16 steps; saturates at 1 − (1 − f)ᴷ.
    """
    d = np.clip(np.asarray(darkness, dtype=np.float64), 0, 1)
    remaining = 1 - d
    full = np.floor(np.log(np.maximum(remaining, 1e-12)) / np.log(1 - coverage))
    full = np.minimum(full, n_layers)
    base = (1 - coverage) ** full
    share = np.where(full < n_layers, (1 - remaining / base) / coverage, 0.0)
    share = np.floor(share * DITHER_PERIOD + 0.5) / DITHER_PERIOD
    return 1 - base * (1 - coverage * share)


def _bit_reverse(index: np.ndarray) -> np.ndarray:
    """Ordered-dither rank of each line: the bit-reversed index in 0..DITHER_PERIOD−1."""
    bits = int(np.log2(DITHER_PERIOD))
    out = np.zeros_like(index)
    for b in range(bits):
        out |= ((index >> b) & 1) << (bits - 1 - b)
    return out


def _hatch_runs(dark, layout, centre, angle, along_t, offsets, threshold, min_run):
    """Runs of every hatch line where the darkness exceeds that line's threshold, as paths."""
    a = np.deg2rad(angle)
    direction = np.array([np.cos(a), np.sin(a)])
    normal = np.array([-np.sin(a), np.cos(a)])
    # The page → pixel map is affine: map each line's centre and the unit step once, then
    # every sample is a broadcast multiply-add (float32) instead of millions of mappings.
    base_mm = centre + offsets[:, None] * normal
    base_px = layout.mm_to_px(base_mm).astype(np.float32)
    step_px = (layout.mm_to_px(centre + direction) - layout.mm_to_px(centre))[0].astype(np.float32)
    t = along_t.astype(np.float32)
    # Whole lines at a time, in blocks, keeping only each block's runs: the full (lines ×
    # samples) mask of a fine pen on a big sheet would take gigabytes.
    block = max(1, _SAMPLES_PER_BLOCK // t.size)
    runs = [np.zeros((3, 0), dtype=np.intp)]
    for first in range(0, len(offsets), block):
        lines = slice(first, first + block)
        on = _sample(dark, base_px[lines], step_px, t) > threshold[lines, None]
        padded = np.zeros((on.shape[0], on.shape[1] + 2), dtype=np.int8)
        padded[:, 1:-1] = on
        change = np.diff(padded, axis=1)
        line_s, start = np.nonzero(change == 1)
        _, stop = np.nonzero(change == -1)  # same row order as the starts: runs alternate
        runs.append(np.stack([line_s + first, start, stop - 1]))
    line_s, start, stop = np.concatenate(runs, axis=1)
    if start.size == 0:
        return []
    step = along_t[1] - along_t[0]
    # Bridge gaps shorter than half a minimum run, then drop runs shorter than one.
    bridged = np.zeros(start.size, dtype=bool)
    bridged[1:] = (line_s[1:] == line_s[:-1]) & ((start[1:] - stop[:-1]) * step < min_run / 2)
    first = np.flatnonzero(~bridged)
    last = np.append(first[1:], start.size) - 1
    line_s, start, stop = line_s[first], start[first], stop[last]
    long_enough = (stop - start) * step >= min_run
    line_s, start, stop = line_s[long_enough], start[long_enough], stop[long_enough]

    # Serpentine: every other drawn line runs backwards, its runs in reverse order.
    rank = np.cumsum(np.append(True, line_s[1:] != line_s[:-1])) - 1
    backwards = rank % 2 == 1
    order = np.lexsort((np.where(backwards, -start, start), line_s))
    line_s, start, stop, backwards = line_s[order], start[order], stop[order], backwards[order]
    t0 = np.where(backwards, along_t[stop], along_t[start])
    t1 = np.where(backwards, along_t[start], along_t[stop])
    base = base_mm[line_s]
    # Samples are placed in float32 pixels: a run's end can lie a few µm past the picture's
    # edge, which a bed check or a clip test counts as outside. Pull the ends back onto it.
    box = np.asarray(layout.drawing_box, np.float64)
    p0 = np.clip(base + t0[:, None] * direction, box[:2], box[2:])
    p1 = np.clip(base + t1[:, None] * direction, box[:2], box[2:])
    return list(np.stack([p0, p1], axis=1))


def _sample(dark: np.ndarray, base_px: np.ndarray, step_px: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Darkness at ``base + t·step`` (pixels, nearest) for each line; 0 outside the image."""
    height, width = dark.shape
    col = np.rint(base_px[:, None, 0] + t[None, :] * step_px[0]).astype(np.intp)
    row = np.rint(base_px[:, None, 1] + t[None, :] * step_px[1]).astype(np.intp)
    inside = (col >= 0) & (col < width) & (row >= 0) & (row < height)
    values = np.zeros(col.shape, dtype=np.float32)
    values[inside] = dark[row[inside], col[inside]]
    return values
