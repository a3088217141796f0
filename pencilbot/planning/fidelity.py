"""How faithfully a plan draws its pencil sketch: the figures ``bench/plan.py`` and ``demo`` report.

* **Line fidelity**: Pearson r between the edge layer rendered on the image's pixel grid and the
  raster line drawing 1 − L, both Gaussian-blurred with σ = 2 px (strokes may sit a pixel off
  the raster line and still draw the same contour).
* **Tone fidelity**: Pearson r and mean absolute difference between the darkness of the whole
  plan and of the raster pencil drawing 1 − R, both blurred with σ = 3 mm at plot scale (the
  distance at which a viewer judges shading rather than single lines).

* **Colour difference** (a colour plan, or a black one judged against colour):
  mean CIEDE2000 ΔE00 between the colour sketch and the plan's inks stacked on paper
  (:func:`pencilbot.colors.inks_on_paper`), both Gaussian-blurred by σ = 3 mm in linear light
  (how the eye averages lines and paper at arm's length). Below 2 is hard to see side by side,
  around 5 reads as the same colour a little off, past 10 as another colour.

A correlation is NaN where it is undefined: one of the two pictures is flat (a blank photo has
no edges to draw, an outline plan of it draws nothing).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import ndimage as ndi
from scipy.stats import spearmanr
from skimage.color import deltaE_ciede2000, rgb2lab
from skimage.metrics import structural_similarity

from pencilbot.colors import inks_on_paper, linear_to_srgb, srgb_to_linear
from pencilbot.imaging.pencil import Sketch
from pencilbot.paths import Paths
from pencilbot.planning.layout import Layout, ink_on_image_grid
from pencilbot.planning.plan import Plan
from pencilbot.render import render_paths
from pencilbot.units import MM_PER_INCH

LINE_SIGMA_PX = 2.0
TONE_SIGMA_MM = 3.0
#: Cell (mm) the colour difference is measured on: far below its 3 mm blur, above the pixel.
COLOR_CELL = 0.25


@dataclass(frozen=True)
class Fidelity:
    """Line r, tone r and tone mean absolute difference (darkness in [0, 1])."""

    line_r: float
    tone_r: float
    tone_mae: float


def fidelity(plan: Plan, drawing: Sketch) -> Fidelity:
    """Compare a plan with the sketch it was planned from.

    Parameters
    ----------
    plan : Plan
        With a layer of role ``"edges"``, planned from ``drawing`` on ``plan.page``.
    drawing : Sketch
        A full (not lines-only) sketch; its image grid is the one the plan was laid out on.

    Returns
    -------
    Fidelity
    """
    layout = Layout.fit(drawing.line.edges.shape, plan.page)
    pen_width = plan.pen_width
    edges = ink_on_image_grid(plan.paths("edges"), layout, pen_width=pen_width)
    line_r = pearson(
        ndi.gaussian_filter(edges, LINE_SIGMA_PX),
        ndi.gaussian_filter(1.0 - drawing.line.drawing, LINE_SIGMA_PX),
    )
    ink = ink_on_image_grid(plan.paths(), layout, pen_width=pen_width)
    sigma = TONE_SIGMA_MM / layout.mm_per_px
    plotted = ndi.gaussian_filter(ink, sigma)
    raster = ndi.gaussian_filter(1.0 - drawing.result, sigma)
    return Fidelity(line_r, pearson(plotted, raster), float(np.abs(plotted - raster).mean()))


def pearson(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two same-sized pictures; NaN (without a warning) if either is flat."""
    a, b = np.ravel(a), np.ravel(b)
    if np.ptp(a) == 0 or np.ptp(b) == 0:
        return float("nan")
    return float(np.corrcoef(a, b)[0, 1])


# The yardstick of issue 11: the plot against the photo itself, as a viewer at arm's length sees it.
YARDSTICK_PX_PER_MM = 10.0
YARDSTICK_SIGMA_MM = 1.0
SSIM_SIGMA_MM = 3.0


@dataclass(frozen=True)
class Likeness:
    """How well a plotted picture follows a reference picture over the drawing box.

    ``rho`` is Spearman's rank correlation (blind to any monotone tone curve, such as the pencil
    tone model), ``r`` Pearson's, both after a Gaussian blur of ``YARDSTICK_SIGMA_MM``; ``ssim``
    is the structural similarity at the ``SSIM_SIGMA_MM`` scale.
    """

    rho: float
    r: float
    ssim: float


def plotted_darkness(paths, box, *, pen_width: float, px_per_mm: float = YARDSTICK_PX_PER_MM) -> np.ndarray:
    """Ink of pen ``paths`` (page mm, Y up) over the drawing ``box`` ``(x0, y0, x1, y1)``, row 0 at the top."""
    x0, y0, x1, y1 = box
    return render_paths(
        paths, x1 - x0, y1 - y0, dpi=px_per_mm * MM_PER_INCH, pen_width=pen_width, origin=(x0, y0)
    )


#: Resolution (px per mm) at which a plan is judged while it is planned (:func:`sheet_likeness`):
#: four pixels to the yardstick's 1 mm blur are ample to choose between two plans, at a sixth of
#: the yardstick's pixels.
JUDGE_PX_PER_MM = 4.0


def sheet_likeness(layers, layout: Layout, drawing: Sketch) -> float:
    """How like its photo and its own sketch a plan's ``layers`` are, to choose between two plans
    of one picture: Spearman's rho against the photo's darkness plus Pearson's r against the
    sketch's, both over the drawing box at the yardstick's blur (:func:`likeness`)."""
    paths = Paths.concat(layer.paths for layer in layers)
    pen_width = max((layer.pen_width for layer in layers), default=0.5)
    plotted = plotted_darkness(paths, layout.drawing_box, pen_width=pen_width, px_per_mm=JUDGE_PX_PER_MM)
    drawn = _blurred_samples(plotted, plotted.shape, JUDGE_PX_PER_MM)
    photo = _blurred_samples(1.0 - drawing.gray, plotted.shape, JUDGE_PX_PER_MM)
    return _spearman(drawn, photo) + pearson(
        drawn, _blurred_samples(1.0 - sketch_grey(drawing), plotted.shape, JUDGE_PX_PER_MM)
    )


def sketch_grey(drawing: Sketch) -> np.ndarray:
    """The pencil drawing R in grey, what a one-pen plot is compared with: R itself, or the mean
    of a colour sketch's channels."""
    return drawing.result if drawing.result.ndim == 2 else drawing.result.mean(axis=2)


def photo_likeness(plan: Plan, drawing: Sketch) -> Likeness:
    """How well ``plan`` follows the photo its sketch was made from (issue 11's yardstick).

    The plan rendered at ``YARDSTICK_PX_PER_MM`` over its drawing box against the photo's
    darkness 1 − luma (at the resolution it was planned from).
    """
    layout = Layout.fit(drawing.line.edges.shape, plan.page)
    plotted = plotted_darkness(plan.paths(), layout.drawing_box, pen_width=plan.pen_width)
    return likeness(plotted, 1.0 - drawing.gray)


def likeness(
    plotted: np.ndarray, reference: np.ndarray, *, px_per_mm: float = YARDSTICK_PX_PER_MM
) -> Likeness:
    """Compare a plotted darkness with a reference darkness (any size; resampled onto the plot's grid).

    Parameters
    ----------
    plotted : (H, W) float array in [0, 1]
        Ink over the drawing box at ``px_per_mm``, e.g. from :func:`plotted_darkness`.
    reference : (h, w) float array in [0, 1]
        The picture it should look like, covering the same box (e.g. 1 − luma of the photo).
    px_per_mm : float
        Resolution of ``plotted``.

    Returns
    -------
    Likeness
    """
    height, width = plotted.shape
    ref = _resampled(reference, plotted.shape)
    sa, sb = (
        _blurred_samples(plotted, plotted.shape, px_per_mm),
        _blurred_samples(ref, plotted.shape, px_per_mm),
    )
    rho = _spearman(sa, sb)
    # SSIM on a 1 px/mm grid with a Gaussian window of SSIM_SIGMA_MM.
    step = max(1, round(px_per_mm))
    # At least SSIM's Gaussian window across (skimage: 2·⌊3.5σ + 0.5⌋ + 1 px): a drawing a few mm
    # wide (a 60 x 40 mm page with 2.5 mm of pen) is compared on that many pixels, not refused.
    window = 2 * int(3.5 * SSIM_SIGMA_MM + 0.5) + 1
    small = (max(window, width // step), max(window, height // step))
    ca = cv2.resize(np.asarray(plotted, np.float32), small, interpolation=cv2.INTER_AREA)
    cb = cv2.resize(ref, small, interpolation=cv2.INTER_AREA)
    ssim = float(structural_similarity(ca, cb, data_range=1.0, gaussian_weights=True, sigma=SSIM_SIGMA_MM))
    return Likeness(rho=rho, r=pearson(sa, sb), ssim=ssim)


def _resampled(picture: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``picture`` as float32 on an (H, W) ``shape`` grid (area-averaged; as it is at that size)."""
    picture = np.asarray(picture, np.float32)
    if picture.shape[:2] == tuple(shape[:2]):
        return picture
    return cv2.resize(picture, (shape[1], shape[0]), interpolation=cv2.INTER_AREA)


def _blurred_samples(picture: np.ndarray, shape: tuple[int, ...], px_per_mm: float) -> np.ndarray:
    """``picture`` on the ``shape`` grid at ``px_per_mm``, blurred by the yardstick's sigma, its
    pixels every third of a sigma (the blurred picture varies on the scale of sigma: every third
    pixel loses nothing), flattened."""
    sigma = YARDSTICK_SIGMA_MM * px_per_mm
    stride = max(1, int(sigma // 3))
    return ndi.gaussian_filter(_resampled(picture, shape), sigma)[::stride, ::stride].ravel()


def _spearman(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman's rho of two samples; NaN when one of them is flat."""
    return float("nan") if np.ptp(a) == 0 or np.ptp(b) == 0 else float(spearmanr(a, b).statistic)


def region_rho(
    plotted: np.ndarray,
    reference: np.ndarray,
    region: tuple[float, float, float, float],
    *,
    sigma_mm: float = YARDSTICK_SIGMA_MM,
    px_per_mm: float = YARDSTICK_PX_PER_MM,
) -> float:
    """Spearman's ρ of plotted and reference darkness inside one region (a face), at one blur.

    Both pictures are blurred whole (so the region's border sees its surroundings, as an eye
    does), then compared inside the region only.

    Parameters
    ----------
    plotted : (H, W) float array in [0, 1]
        Ink over the drawing box at ``px_per_mm`` (:func:`plotted_darkness`).
    reference : (h, w) float array in [0, 1]
        The picture it should look like over the same box (e.g. 1 − luma of the photo).
    region : (x, y, width, height)
        The region as fractions of the box (0 to 1; x from the left, y from the top).
    sigma_mm : float
        Gaussian blur, mm (1 mm: the tone at arm's length; 0.5 mm: features, lines).
    px_per_mm : float
        Resolution of ``plotted``.

    Returns
    -------
    float
        ρ, or NaN when either picture is flat in the region.
    """
    height, width = plotted.shape
    ref = cv2.resize(np.asarray(reference, np.float32), (width, height), interpolation=cv2.INTER_AREA)
    sigma = sigma_mm * px_per_mm
    x, y, w, h = region
    c0, c1 = int(round(x * width)), int(round((x + w) * width))
    r0, r1 = int(round(y * height)), int(round((y + h) * height))
    pad = int(4 * sigma) + 1  # blur a window around the region only: a whole A4 box is slow
    window = (slice(max(0, r0 - pad), min(height, r1 + pad)), slice(max(0, c0 - pad), min(width, c1 + pad)))
    a = ndi.gaussian_filter(np.asarray(plotted, np.float32)[window], sigma)
    b = ndi.gaussian_filter(ref[window], sigma)
    inner = (
        slice(r0 - window[0].start, r1 - window[0].start),
        slice(c0 - window[1].start, c1 - window[1].start),
    )
    stride = max(1, int(sigma // 3))
    sa, sb = a[inner][::stride, ::stride].ravel(), b[inner][::stride, ::stride].ravel()
    if sa.size < 3 or np.ptp(sa) == 0 or np.ptp(sb) == 0:
        return float("nan")
    return float(spearmanr(sa, sb).statistic)


def plan_color(plan: Plan, shape: tuple[int, int], *, cell: float = COLOR_CELL) -> tuple[np.ndarray, int]:
    """The plan's inks stacked on paper over the drawing box of an image of ``shape``.

    Returns the sRGB picture (h, w, 3) on blocks of ``coarsen`` image pixels (about ``cell`` mm)
    and ``coarsen``; each pen's layers are rendered together with its width, and stacked
    with its ink colour (a layer naming no pen is black).
    """
    layout = Layout.fit(shape, plan.page)
    coarsen = max(1, round(cell / layout.mm_per_px))
    covers, colors = [], []
    for _, layers in plan.pen_runs():
        covers.append(
            ink_on_image_grid(
                Paths.concat(layer.paths for layer in layers),
                layout,
                pen_width=layers[0].pen_width,
                coarsen=coarsen,
            )
        )
        colors.append(layers[0].color)
    if not covers:
        rows, cols = -(-shape[0] // coarsen), -(-shape[1] // coarsen)
        return np.ones((rows, cols, 3), np.float32), coarsen
    return inks_on_paper(covers, colors), coarsen


def color_difference(plan: Plan, reference: np.ndarray, *, blur: float = TONE_SIGMA_MM) -> float:
    """Mean CIEDE2000 between a plan's colour on paper and ``reference`` after a ``blur`` mm blur.

    Parameters
    ----------
    plan : Plan
        Laid out on the grid of ``reference`` (its image as planned).
    reference : (H, W, 3) float array
        The colour it should look like, sRGB in [0, 1] (the colour sketch).
    blur : float
        Gaussian sigma, mm, applied to both in linear light.

    Returns
    -------
    float
        Mean ΔE00 over the drawing box.
    """
    shape = reference.shape[:2]
    plotted, coarsen = plan_color(plan, shape)
    height, width = plotted.shape[:2]
    ref = cv2.resize(
        srgb_to_linear(reference).astype(np.float32), (width, height), interpolation=cv2.INTER_AREA
    )
    sigma = blur / (Layout.fit(shape, plan.page).mm_per_px * coarsen)

    def seen(linear):
        blurred = cv2.GaussianBlur(
            np.asarray(linear, np.float32), (0, 0), sigma, borderType=cv2.BORDER_REFLECT
        )
        return rgb2lab(linear_to_srgb(blurred))

    return float(deltaE_ciede2000(seen(ref), seen(srgb_to_linear(plotted))).mean())
