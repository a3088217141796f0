"""Lu et al.'s directional stroke convolution on an edge map (paper section IV-B).

An edge map E becomes a pencil line drawing in two convolution passes:

1. Classify. Eight line kernels Lᵢ of length ℓ, 22.5° apart, give responses Eᵢ = Lᵢ * E; each
   pixel takes the direction of the largest response, ``labels = argmaxᵢ Eᵢ`` (paper formula 7,
   whose printed "argmin … = 1 / otherwise 1" is a typesetting slip for Lu's argmax / 0).
2. Draw. Bᵢ = E where ``labels == i`` else 0, and S = Σᵢ Lᵢ ⊗ Bᵢ (formula 8): every edge pixel
   paints a short straight stroke of length ℓ in its own direction, so a curved contour turns
   into short straight strokes whose ends overshoot and cross, as a hand draws.

The drawing is ``(1 − clip((w · S − floor) / (1 − floor), 0, 1)) ** gamma``, 1 = paper, for the
stroke width w in pixels. Each kernel sums to 1, so along a contour S ≈ E: a stroke is as dark as
its edge is strong on E's absolute scale (:mod:`pencilbot.imaging.gmed`); a w-pixel stroke lays w
times the graphite, so it is wider but not paler; and ``floor`` (``STROKE_FLOOR``) drops the faint
flanks and tails where a stroke's paint thins out. Lu divides S by its maximum instead, which makes the strongest
stroke of any picture black: on a flat one, noise. γ is the tone curve of the strokes.

Direction k ∈ 0..7 is the angle θ = k·22.5° counter-clockwise from the image +x axis as seen on
screen: unit vector (cos θ, −sin θ) in (col, row). k = 0 is horizontal, k = 4 vertical.

Kernels are anti-aliased (exact-ish area coverage of a ℓ × width rectangle, 8×8 supersampling)
and each is divided by its sum, so all eight answer a uniform image identically; plain rotated
pixel lines would favour diagonals by about 12 %. Both passes use ``cv2.filter2D`` on float32
(the kernels are point-symmetric, so its correlation equals convolution), and the argmax is kept
as a running maximum so memory stays a few image-sized buffers even at 12 MP.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pencilbot.errors import PencilbotError

N_DIRECTIONS = 8
MIN_LENGTH, MAX_LENGTH = 6, 13  # range of the default ℓ
# Longest ℓ accepted, px. Far beyond any useful stroke, and the supersampled kernel grids grow
# as ℓ²: ℓ = 1000 would need gigabytes before drawing anything.
LONGEST_LENGTH = 100
_SUPERSAMPLE = 8
#: Stroke strength (S, in E's units) below which the line drawing stays paper.
STROKE_FLOOR = 0.1
#: Accepted stroke γ and width (px): beyond them a drawing is blank, black or all kernel.
GAMMA_RANGE = (0.1, 10.0)
WIDTH_RANGE = (0.5, 20.0)


@dataclass(frozen=True)
class LineDrawing:
    """Result of :func:`line_drawing`.

    Attributes
    ----------
    drawing : ndarray of float32, shape (H, W)
        The line drawing in [0, 1], 1 = paper.
    labels : ndarray of uint8, shape (H, W)
        Stroke direction index 0..7 of every pixel (angle k·22.5°, see module doc).
    edges : ndarray of float32, shape (H, W)
        The edge map E the drawing was made from.
    length : int
        Stroke length ℓ in pixels.
    gamma, floor : float
        The tone curve the drawing was made with (see :func:`line_drawing`).
    """

    drawing: np.ndarray
    labels: np.ndarray
    edges: np.ndarray
    length: int
    gamma: float = 1.0
    floor: float = STROKE_FLOOR

    def stroke_darkness(self, strength: float) -> float:
        """How dark (0..1) the drawing shows the stroke of an edge of ``strength`` E in [0, 1].

        The tone curve along a contour, where S ≈ E: ``1 − (1 − clip((E − floor) / (1 − floor)))^γ``.
        """
        ink = min(max((float(strength) - self.floor) / (1.0 - self.floor), 0.0), 1.0)
        return 1.0 - (1.0 - ink) ** self.gamma

    def edge_strength(self, darkness: float) -> float:
        """The edge strength E whose stroke is ``darkness`` dark: the inverse of :meth:`stroke_darkness`.

        Strokes at least this strong are at least this dark, whatever γ and floor the drawing
        was made with.
        """
        ink = 1.0 - (1.0 - min(max(float(darkness), 0.0), 1.0)) ** (1.0 / self.gamma)
        return self.floor + (1.0 - self.floor) * ink

    def B(self, i: int) -> np.ndarray:  # noqa: N802 - the paper's name
        """Bᵢ: the edge map where the label is ``i``, 0 elsewhere; (H, W) float32."""
        if not 0 <= i < N_DIRECTIONS:
            raise ValueError(f"direction index must be in 0..{N_DIRECTIONS - 1}, got {i}")
        return np.where(self.labels == i, self.edges, np.float32(0)).astype(np.float32)


def default_line_length(shape: tuple[int, ...]) -> int:
    """Stroke length ℓ for an image of ``shape`` (H, W[, C]), in pixels, in [6, 13].

    ℓ grows with the image's linear size s = √(H·W), log-linearly from 6 px at s ≤ 400 px to
    13 px at s ≥ 4000 px: ``ℓ = round(6 + 7 · log10(s / 400))``. A plotted picture has a fixed
    size on paper, so a larger image has smaller pixels and needs more of them per stroke;
    the logarithm keeps small images (coffee, 600×400 → 7) from getting long, coarse strokes.
    Examples: 512×512 → 7, 1 MP → 9, 12 MP (4000×3000) → 13.
    """
    side = math.sqrt(shape[0] * shape[1])
    length = round(MIN_LENGTH + (MAX_LENGTH - MIN_LENGTH) * math.log10(max(side, 1.0) / 400.0))
    return int(min(MAX_LENGTH, max(MIN_LENGTH, length)))


def line_kernels(length: int, width: float = 1.0) -> np.ndarray:
    """The eight anti-aliased line kernels, shape (8, n, n) float32, each summing to 1.

    Parameters
    ----------
    length : int
        Line length ℓ in pixels (≥ 1).
    width : float
        Line thickness in pixels (≥ 0.5).
    """
    if length < 1:
        raise ValueError(f"line length must be at least 1 pixel, got {length}")
    if width < 0.5:
        raise ValueError(f"line width must be at least 0.5 pixel, got {width}")
    radius = math.ceil((length + width) / 2)
    # Sample points of every pixel of an n×n grid centred on the origin (x = col, y = row).
    sub = (np.arange(_SUPERSAMPLE) + 0.5) / _SUPERSAMPLE - 0.5
    grid = np.arange(-radius, radius + 1)
    x = (grid[None, :, None, None] + sub[None, None, None, :]).astype(np.float64)
    y = (grid[:, None, None, None] + sub[None, None, :, None]).astype(np.float64)
    kernels = []
    for k in range(N_DIRECTIONS):
        theta = k * math.pi / N_DIRECTIONS
        ux, uy = math.cos(theta), -math.sin(theta)  # direction in (col, row), row down
        along = x * ux + y * uy
        across = -x * uy + y * ux
        inside = (np.abs(along) <= length / 2) & (np.abs(across) <= width / 2)
        kernels.append(inside.mean(axis=(2, 3)))
    stack = np.array(kernels)
    # Crop the common all-zero frame, keeping the kernels centred (odd size).
    used = np.logical_or.reduce(stack, axis=0)  # (as stack.any(axis=0), typed as an array)
    margin = min(np.argmax(used.any(axis=1)), np.argmax(used.any(axis=0)))
    stack = stack[:, margin : stack.shape[1] - margin, margin : stack.shape[2] - margin]
    return (stack / stack.sum(axis=(1, 2), keepdims=True)).astype(np.float32)


def line_drawing(
    E: np.ndarray,  # noqa: N803 - the paper's name
    *,
    length: int | None = None,
    width: float = 1.0,
    gamma: float = 1.0,
    floor: float = STROKE_FLOOR,
) -> LineDrawing:
    """Pencil line drawing from an edge map.

    Parameters
    ----------
    E : ndarray of float32, shape (H, W)
        Edge map in [0, 1] (e.g. :func:`pencilbot.imaging.gmed.edge_map`).
    length : int, optional
        Stroke length ℓ in pixels, 1 to ``LONGEST_LENGTH``; default :func:`default_line_length`.
    width : float
        Stroke thickness in pixels (≥ 0.5); a wider stroke paints more graphite, so it is as
        dark as a 1-pixel one, not the same ink spread thinner.
    gamma : float
        Exponent on the drawing, Lu's γ: > 1 darkens every stroke (faint ones show more),
        < 1 lightens them.
    floor : float
        Stroke strength in [0, 1) below which the drawing stays paper.

    Returns
    -------
    LineDrawing

    Raises
    ------
    PencilbotError
        ``length`` outside 1..``LONGEST_LENGTH``.
    """
    E = np.ascontiguousarray(E, dtype=np.float32)  # noqa: N806
    if E.ndim != 2:
        raise ValueError(f"E must be a 2-D array, got shape {E.shape}")
    if gamma <= 0:
        raise ValueError(f"gamma must be positive, got {gamma}")
    if not 0 <= floor < 1:
        raise ValueError(f"floor must be in [0, 1), got {floor}")
    length = default_line_length(E.shape) if length is None else int(length)
    if not 1 <= length <= LONGEST_LENGTH:
        raise PencilbotError(
            f"stroke length {length} px is not in 1..{LONGEST_LENGTH} px; choose a length in that range"
        )
    kernels = [_trim(kernel) for kernel in line_kernels(length, width)]

    best = cv2.filter2D(E, -1, kernels[0], borderType=cv2.BORDER_REFLECT)
    labels = np.zeros(E.shape, dtype=np.uint8)
    better = np.empty(E.shape, dtype=bool)
    for k in range(1, N_DIRECTIONS):
        response = cv2.filter2D(E, -1, kernels[k], borderType=cv2.BORDER_REFLECT)
        np.greater(response, best, out=better)  # ties keep the lower index: deterministic
        np.copyto(best, response, where=better)
        np.copyto(labels, np.uint8(k), where=better)
    del best, response

    strokes = np.zeros_like(E)
    B_k = np.empty_like(E)  # noqa: N806
    for k in range(N_DIRECTIONS):
        np.equal(labels, k, out=better)
        np.multiply(E, better, out=B_k)
        strokes += cv2.filter2D(B_k, -1, kernels[k], borderType=cv2.BORDER_CONSTANT)
    strokes *= np.float32(width)  # the kernels sum to 1: a w-pixel line carries w times the ink
    strokes -= np.float32(floor)
    strokes *= np.float32(1.0 / (1.0 - floor))
    np.clip(strokes, 0.0, 1.0, out=strokes)
    drawing = np.subtract(np.float32(1.0), strokes, out=strokes)
    if gamma != 1.0:
        drawing **= np.float32(gamma)
    return LineDrawing(drawing=drawing, labels=labels, edges=E, length=length, gamma=gamma, floor=floor)


def _trim(kernel: np.ndarray) -> np.ndarray:
    """Crop a centred kernel to its own non-zero box, still centred.

    A 1×13 horizontal kernel costs a thirteenth of a 13×13 one, and OpenCV switches to a much
    slower DFT path for kernels of 13×13 and up: trimming makes the stroke step about 5× faster.
    """
    centre = kernel.shape[0] // 2
    half_rows, half_cols = np.abs(np.argwhere(kernel > 0) - centre).max(axis=0)
    return kernel[centre - half_rows : centre + half_rows + 1, centre - half_cols : centre + half_cols + 1]
