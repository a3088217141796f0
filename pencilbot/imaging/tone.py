"""Tone target: map a photo's grey levels onto the histogram of a pencil drawing.

A pencil drawing's histogram is not a photo's: most of the sheet stays paper-white, the mid-tones
are spread flat, and a few dark accents sit well above black. Lu et al. (2012) model it as three
layers (paper formulas 9–12), on the 0..255 tone scale:

* bright layer — a one-sided Laplacian rising to paper white, ``p1(r) ∝ exp(−(255 − r)/σ1)``, σ1 = 9;
* middle layer — uniform on [105, 205];
* dark layer   — a Gaussian around 90 with σ3 = 11.

(The paper's text calls p1 the shadow layer; its formula and numbers make it the bright one.)
Each layer is normalised to unit mass over the 256 levels, so a weight is simply the share of the
drawing's pixels that layer holds. The tone target J is the photo's grey histogram-specified onto
this model by Zhang's group mapping law (GML); the single mapping law (SML) is kept for comparison.
Both produce a monotone 256-entry lookup table applied in one indexing operation.
"""

from __future__ import annotations

import cv2
import numpy as np

LEVELS = 256

#: Share of pixels in the (bright, middle, dark) layers. Lu et al. give 76:22:2 (an airy sketch,
#: mostly paper) and 52:37:11. We take 40:45:15, measured on the plotted drawing: with half the
#: picture in the bright layer, a portrait's skin (photo darkness 0.3-0.45) maps to paper and a
#: face is drawn as dashes for its features; 40:45:15 shades it lightly, keeps the highlights
#: paper-white, and follows the photo better (bench/fidelity.py: the ideal plot of J against
#: the photo, Spearman rho coffee 0.967 -> 0.982, astronaut 0.965 -> 0.982, rocket 0.948 -> 0.973).
DEFAULT_WEIGHTS = (40.0, 45.0, 15.0)

#: Share of the photo's own histogram in the target (the rest is the pencil model). The model
#: alone gives every photo the same key: a night sky whose darkest 40 % maps to paper is drawn
#: as a white dome with a few dashes, and a face falls in the bright layer. A fifth of the
#: photo's own histogram keeps its key while the drawing keeps the model's paper-white
#: highlights and graphite shadows (bench/fidelity.py, plot against photo, Spearman rho:
#: rocket 0.905 -> 0.941, coffee 0.912 -> 0.935, astronaut 0.928 -> 0.938).
PHOTO_SHARE = 0.2

BRIGHT_SIGMA = 9.0
MIDDLE_RANGE = (105, 205)
DARK_MEAN, DARK_SIGMA = 90.0, 11.0

#: Model levels with less probability than this are treated as empty. The Gaussian and Laplacian
#: tails never reach exactly zero; left in, GML would send the photo's darkest level to a tone
#: of ~0 that holds 1e-15 of the model's pixels (less than one pixel in a megapixel).
EMPTY_LEVEL = 1e-6


def pencil_histogram(weights: tuple[float, float, float] | None = None) -> np.ndarray:
    """The 3-layer pencil tone histogram (paper formulas 9–12).

    Parameters
    ----------
    weights : (float, float, float), optional
        Relative share of pixels in the (bright, middle, dark) layers; any positive scale, they
        are normalised. Default :data:`DEFAULT_WEIGHTS` (40:45:15).

    Returns
    -------
    ndarray of float64, shape (256,)
        Probability of each tone level 0..255 (255 = paper white), summing to 1.

    Raises
    ------
    ValueError
        Weights that are not three finite non-negative numbers with a positive sum.
    """
    w = np.asarray(DEFAULT_WEIGHTS if weights is None else weights, dtype=np.float64)
    if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weights must be three non-negative numbers with a positive sum, got {weights!r}")
    r = np.arange(LEVELS, dtype=np.float64)
    bright = np.exp(-(LEVELS - 1 - r) / BRIGHT_SIGMA)
    middle = ((r >= MIDDLE_RANGE[0]) & (r <= MIDDLE_RANGE[1])).astype(np.float64)
    dark = np.exp(-((r - DARK_MEAN) ** 2) / (2 * DARK_SIGMA**2))
    layers = np.stack([bright, middle, dark])
    layers /= layers.sum(axis=1, keepdims=True)
    hist = (w / w.sum()) @ layers
    hist[hist < EMPTY_LEVEL] = 0.0
    return hist / hist.sum()


def gml_lut(source_hist: np.ndarray, target_hist: np.ndarray) -> np.ndarray:
    """Histogram specification by the group mapping law (Zhang 1992).

    Taking the non-empty target levels ``j`` in increasing order, ``I(j)`` is the source level
    whose cumulative histogram is closest to the target's cumulative at ``j``; the source levels
    ``I(j_prev)+1 .. I(j)`` map to ``j``. Source levels left after the last group map to the last
    non-empty target level.

    Parameters
    ----------
    source_hist, target_hist : ndarray, shape (M,) and (N,)
        Histograms (counts or probabilities, non-negative, positive sum).

    Returns
    -------
    ndarray of int64, shape (M,)
        Target level for each source level; non-decreasing.
    """
    cs, ct = _cumulative(source_hist), _cumulative(target_hist)
    targets = np.flatnonzero(np.asarray(target_hist) > 0)
    ends = np.maximum.accumulate(_closest(cs, ct[targets]))
    # Source level i belongs to the first group whose end I(j) reaches it.
    group = np.searchsorted(ends, np.arange(cs.size), side="left")
    return targets[np.minimum(group, targets.size - 1)]


def sml_lut(source_hist: np.ndarray, target_hist: np.ndarray) -> np.ndarray:
    """Histogram specification by the single mapping law: each source level goes to the
    non-empty target level whose cumulative histogram is closest to its own (the lower one on a
    tie).

    Parameters and return as :func:`gml_lut`.
    """
    cs, ct = _cumulative(source_hist), _cumulative(target_hist)
    targets = np.flatnonzero(np.asarray(target_hist) > 0)
    return targets[_closest(ct[targets], cs)]


def tone_target(
    gray: np.ndarray,
    *,
    weights: tuple[float, float, float] | None = None,
    method: str = "gml",
    never_darker: bool = True,
    photo_share: float = PHOTO_SHARE,
) -> np.ndarray:
    """The tone target J: ``gray`` histogram-specified onto the pencil tone model.

    Histogram specification spreads *any* histogram over the whole model, so on its own it draws
    a white sheet in the model's median grey and a pale, low-contrast photo (a blank page, a
    vignetted wall) in dark tones. A pencil drawing lightens a photo, it never darkens it: with
    ``never_darker`` each level is mapped to the lighter of its specified tone and itself, which
    leaves every photo with real shadows as GML maps it and keeps paper white as paper.

    Parameters
    ----------
    gray : ndarray, shape (H, W)
        Luma in [0, 1] (1 = white), quantised to 256 levels.
    weights : (float, float, float), optional
        (bright, middle, dark) layer shares, see :func:`pencil_histogram`.
    method : {"gml", "sml"}
        Group mapping law (default) or single mapping law.
    never_darker : bool
        Never map a level darker than it is in ``gray`` (see above); False gives the plain
        histogram specification of the paper.
    photo_share : float
        Share in [0, 1) of the photo's own histogram mixed into the model before the mapping
        (see :data:`PHOTO_SHARE`); 0 is the paper's specification onto the model alone.

    Returns
    -------
    ndarray of float32, shape (H, W)
        Tone in [0, 1] (1 = paper white); a monotone function of ``gray``.
    """
    if method not in ("gml", "sml"):
        raise ValueError(f"method must be 'gml' or 'sml', got {method!r}")
    gray = np.asarray(gray)
    if gray.ndim != 2:
        raise ValueError(f"gray must be a 2-D array, got shape {gray.shape}")
    scaled = np.clip(gray, 0.0, 1.0).astype(np.float32)
    scaled *= LEVELS - 1
    levels = np.rint(scaled, out=scaled).astype(np.uint8)
    # OpenCV's histogram and table lookup read the uint8 image directly; NumPy's bincount and
    # fancy indexing would first widen it to 8-byte indices (100 MB at 12 MP).
    source_hist = cv2.calcHist([levels], [0], None, [LEVELS], [0, LEVELS]).ravel()
    if not 0 <= photo_share < 1:
        raise ValueError(f"photo_share must be in [0, 1), got {photo_share}")
    model = pencil_histogram(weights)
    target = (1 - photo_share) * model + photo_share * source_hist / source_hist.sum()
    mapping = (gml_lut if method == "gml" else sml_lut)(source_hist, target)
    if never_darker:
        mapping = np.maximum(mapping, np.arange(LEVELS))
    lut = (mapping / (LEVELS - 1)).astype(np.float32)
    return cv2.LUT(levels, lut)


def _cumulative(hist: np.ndarray) -> np.ndarray:
    """Normalised cumulative histogram (last entry exactly 1)."""
    c = np.cumsum(np.asarray(hist, dtype=np.float64))
    if c.size == 0 or not c[-1] > 0:
        raise ValueError("a histogram needs a positive total")
    return c / c[-1]


def _closest(cum: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Index into non-decreasing ``cum`` of the entry closest to each of ``values`` (the lower
    index on a tie)."""
    hi = np.clip(np.searchsorted(cum, values, side="left"), 0, cum.size - 1)
    below = np.maximum(hi - 1, 0)
    # hi is already the first of its run of equal entries; move the candidate below to the
    # first of its run too, so the lowest index wins among equals (as argmin would).
    lo = np.searchsorted(cum, cum[below], side="left")
    take_lo = np.abs(values - cum[lo]) <= np.abs(cum[hi] - values)
    return np.where(take_lo, lo, hi)
