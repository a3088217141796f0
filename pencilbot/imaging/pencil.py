"""The finished pencil drawing R = L · T (paper formula 15), in grey or colour.

The line drawing L (GMED edges → directional strokes) carries the contours, the texture map T
(the tone target rendered with pencil texture) carries the shading; multiplying them overlays
graphite on graphite as a second pass of the pencil would.

Colour follows Lu et al.: the drawing replaces the photo's luma and keeps its chroma, in Rec.
601 YUV — the space :mod:`pencilbot.imaging.io` already defines grey in, so the drawing is made
from exactly the luma it replaces. Keeping U ∝ B − Y and V ∝ R − Y while Y becomes the drawing's
value D means ``D + (rgb − Y)`` in every channel. A pencil drawing is far lighter than its
photo, and a saturated colour often does not exist at the new luma; clipping channels would then
shift hue and darken the drawing's tone, so instead the chroma is scaled down just enough to fit
(hue and luma exact, saturation reduced only where it must be).
"""

from __future__ import annotations

import functools
import logging
import math
import os
import time
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.imaging.gmed import edge_map
from pencilbot.imaging.io import LUMA_601, LoadedImage, image_from_array
from pencilbot.imaging.strokes import GAMMA_RANGE, WIDTH_RANGE, LineDrawing, line_drawing
from pencilbot.imaging.texture import TextureResult, pencil_texture, texture_map, user_texture
from pencilbot.imaging.tone import tone_target

log = logging.getLogger(__name__)

#: GMED's 3-pixel dilation and strokes of at least 6 pixels need room: in an image only a few
#: pixels across they reach every pixel, E is 1 everywhere and Lu's normalisation (1 − S / max S)
#: turns the whole picture into its darkest stroke (a 2×2 photo came out solid black). Such an
#: image is drawn enlarged (each pixel a block) to this short side, then brought back.
MIN_SIDE = 32
#: The most pixels such an enlarged copy may have: a sketch holds about 70 bytes a pixel at its
#: peak, so 2 megapixels stay near 150 MB. A strip thinner than that allows (65535 × 1 px would be
#: 2 097 120 × 32, 1.9 GB) is refused, not drawn.
MAX_ENLARGED_PIXELS = 2 << 20


@dataclass(frozen=True)
class Sketch:
    """A pencil drawing and the stages it was made from.

    Attributes
    ----------
    result : ndarray of float32, shape (H, W) or (H, W, 3)
        The drawing in [0, 1], 1 = paper; RGB when made with ``color=True``.
    gray : ndarray of float32, shape (H, W)
        The photo's luma the drawing was made from (1 = white).
    line : LineDrawing
        The line drawing L and its labels and edge map.
    tone : ndarray of float32, shape (H, W), or None
        Tone target J (None for a line-only sketch).
    texture : ndarray of float32, shape (H, W), or None
        Pencil texture H.
    fit : TextureResult or None
        β, T = H^β and the solver's iteration count and residual.
    timings : dict of str to float
        Seconds spent in each stage, in pipeline order: ``edges``, ``lines``, ``tone``,
        ``texture``, ``beta`` (the β solve and T), ``compose``.
    rgb : ndarray of float32, shape (H, W, 3), or None
        The photo in colour, same grid as ``gray`` (the face detector sees colour: on the face
        set it finds 58 of 59 faces in colour, 56 in grey).
    """

    result: np.ndarray
    gray: np.ndarray
    line: LineDrawing
    tone: np.ndarray | None = None
    texture: np.ndarray | None = None
    fit: TextureResult | None = None
    timings: dict[str, float] = field(default_factory=dict)
    rgb: np.ndarray | None = None

    @property
    def beta(self) -> np.ndarray | None:
        """β, the number of pencil passes per pixel (None for a line-only sketch)."""
        return None if self.fit is None else self.fit.beta

    @property
    def T(self) -> np.ndarray | None:  # noqa: N802 - the paper's name
        """The texture map T = H^β (None for a line-only sketch)."""
        return None if self.fit is None else self.fit.T


def sketch(
    image: LoadedImage,
    *,
    color: bool = False,
    line_length: int | None = None,
    stroke_gamma: float = 1.0,
    stroke_width: float = 1.0,
    texture: str | os.PathLike | np.ndarray | None = None,
    texture_seed: int = 0,
    lines_only: bool = False,
) -> Sketch:
    """Turn a photo into a pencil drawing.

    Parameters
    ----------
    image : LoadedImage
        The photo (its ``gray`` drives every stage; ``rgb`` gives the chroma for ``color``).
    color : bool
        Keep the photo's chroma (Rec. 601 YUV) instead of returning grey.
    line_length : int, optional
        Stroke length ℓ in pixels; default from the image size (6–13 px).
    stroke_gamma : float
        Tone curve of the line drawing, γ in ``GAMMA_RANGE``: > 1 darkens the strokes (faint
        contours show more), < 1 lightens them.
    stroke_width : float
        Width of the line drawing's strokes in pixels, in ``WIDTH_RANGE``.
    texture : path or ndarray, optional
        A hand-drawn pencil texture (image file or grey array, see
        :func:`~pencilbot.imaging.texture.user_texture`); default: synthesised.
    texture_seed : int
        Seed of the synthesised pencil texture.
    lines_only : bool
        Stop after the line drawing: ``result`` is L (in colour if asked), no tone or texture.

    Returns
    -------
    Sketch

    Raises
    ------
    PencilbotError
        ``stroke_gamma`` or ``stroke_width`` out of range, or an unreadable texture file.
    """
    _check_range("stroke_gamma", stroke_gamma, GAMMA_RANGE)
    _check_range("stroke_width", stroke_width, WIDTH_RANGE)
    factor = _enlargement(image)
    drawn = functools.partial(
        _drawn,
        line_length=line_length,
        stroke_gamma=stroke_gamma,
        stroke_width=stroke_width,
        texture=texture,
        texture_seed=texture_seed,
        lines_only=lines_only,
    )
    if factor > 1:
        enlarged = image_from_array(
            np.repeat(np.repeat(image.rgb, factor, 0), factor, 1), source=image.source
        )
        return _reduced(drawn(enlarged, color=False), image, color)
    return drawn(image, color=color)


def _enlargement(image: LoadedImage) -> int:
    """By how much a thin image is enlarged to be sketched (its short side to ``MIN_SIDE``);
    refused when that would pass ``MAX_ENLARGED_PIXELS``."""
    factor = math.ceil(MIN_SIDE / min(image.shape))
    if factor > 1 and image.shape[0] * image.shape[1] * factor**2 > MAX_ENLARGED_PIXELS:
        h, w = image.shape
        raise PencilbotError(
            f"{image.source or 'the image'} is {w} x {h} px, too thin to sketch: its short side is drawn enlarged to "
            f"{MIN_SIDE} px, which would make it {w * factor} x {h * factor} px (over "
            f"{MAX_ENLARGED_PIXELS / 1e6:.1f} megapixels). Crop it to a wider strip, or scale it to at least "
            f"{MIN_SIDE} px on its short side"
        )
    return factor


def _drawn(
    image: LoadedImage,
    *,
    color: bool,
    line_length: int | None,
    stroke_gamma: float,
    stroke_width: float,
    texture,
    texture_seed: int,
    lines_only: bool,
) -> Sketch:
    """:func:`sketch` of an image large enough to sketch as it is: the stages, each timed."""
    timings: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(stage: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[stage] = now - clock
        clock = now

    edges = edge_map(image.gray)
    lap("edges")
    line = line_drawing(edges, length=line_length, width=stroke_width, gamma=stroke_gamma)
    lap("lines")
    if lines_only:
        luma, tone, texture, fit = line.drawing.copy(), None, None, None
    else:
        tone = tone_target(image.gray)
        lap("tone")
        if texture is None:
            texture = pencil_texture(image.shape, seed=texture_seed)
        else:
            texture = user_texture(texture, image.shape)
        lap("texture")
        fit = texture_map(tone, texture)
        lap("beta")
        luma = line.drawing * fit.T
    result = with_luma(image.rgb, luma) if color else luma
    lap("compose")
    log.debug(
        "sketch of %s (%d×%d px, ℓ = %d px): %s",
        image.source,
        image.shape[1],
        image.shape[0],
        line.length,
        ", ".join(f"{stage} {seconds:.2f} s" for stage, seconds in timings.items()),
    )
    return Sketch(
        result=result,
        gray=image.gray,
        line=line,
        tone=tone,
        texture=texture,
        fit=fit,
        timings=timings,
        rgb=image.rgb,
    )


def _check_range(name: str, value: float, bounds: tuple[float, float]) -> None:
    low, high = bounds
    if not (isinstance(value, int | float) and not isinstance(value, bool) and low <= value <= high):
        raise PencilbotError(f"{name} must be a number from {low:g} to {high:g}, got {value!r}")


def _reduced(drawn: Sketch, image: LoadedImage, color: bool) -> Sketch:
    """The sketch of an enlarged copy of ``image`` brought back to its size (block means;
    direction labels from each block's centre), R = L·T recomposed at that size."""
    height, width = image.shape
    step = drawn.line.labels.shape[0] // height

    def area(a):
        return None if a is None else cv2.resize(a, (width, height), interpolation=cv2.INTER_AREA)

    labels = drawn.line.labels[step // 2 :: step, step // 2 :: step]
    line = LineDrawing(area(drawn.line.drawing), labels, area(drawn.line.edges), drawn.line.length)
    fit = drawn.fit and replace(drawn.fit, T=area(drawn.fit.T), beta=area(drawn.fit.beta))
    luma = line.drawing * fit.T if fit else line.drawing.copy()
    result = with_luma(image.rgb, luma) if color else luma
    return Sketch(
        result, image.gray, line, area(drawn.tone), area(drawn.texture), fit, drawn.timings, image.rgb
    )


def with_luma(rgb: np.ndarray, luma: np.ndarray) -> np.ndarray:
    """Replace the Rec. 601 luma of ``rgb`` by ``luma``, keeping its chroma (U, V).

    Parameters
    ----------
    rgb : ndarray, shape (H, W, 3)
        Colour image in [0, 1].
    luma : ndarray, shape (H, W)
        New luma in [0, 1].

    Returns
    -------
    ndarray of float32, shape (H, W, 3)
        In [0, 1], with luma exactly ``luma``. The chroma equals ``rgb``'s wherever that colour
        exists at the new luma; where it does not (a saturated orange lifted to near paper
        white), the chroma is scaled down just enough to fit, keeping its hue.
    """
    # In-place arithmetic on few buffers: at 12 MP every fresh temporary costs 0.1–0.2 s of
    # page faults, and NumPy reductions over a length-3 last axis are slow, so the per-pixel
    # extremes are taken plane by plane.
    rgb = np.asarray(rgb, dtype=np.float32)
    luma = np.asarray(luma, dtype=np.float32)
    y_in = cv2.transform(rgb, LUMA_601.reshape(1, 3))
    out = np.subtract(rgb, y_in[..., None])  # chroma: offset from grey, luma 0
    planes = [out[..., c] for c in range(3)]
    # Largest k <= 1 with luma + k·chroma inside [0, 1] in every channel: the channel furthest
    # above grey limits it against 1, the one furthest below against 0 (x/0 gives inf or nan,
    # which fmin skips).
    above = np.maximum(planes[0], planes[1])
    np.maximum(above, planes[2], out=above)
    below = np.minimum(planes[0], planes[1])
    np.minimum(below, planes[2], out=below)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        k = np.divide(np.subtract(1.0, luma, out=y_in), above, out=above)
        np.fmin(k, np.divide(luma, np.abs(below, out=below), out=below), out=k)
    np.clip(np.fmin(k, 1.0, out=k), 0.0, 1.0, out=k)
    out *= k[..., None]
    out += luma[..., None]
    return np.clip(out, 0.0, 1.0, out=out)
