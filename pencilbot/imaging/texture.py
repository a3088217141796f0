"""Pencil texture H and the texture map T = H^β (paper formulas 13–14).

A pencil renders a tone by going over the paper again and again: k passes of a stroke texture H
leave H^k. So the tone target J is approximated by T = H^β, with β the smooth "number of
passes" that solves

    β* = argmin ‖β ln H − ln J‖² + λ ‖∇β‖²,     λ = 0.2.

With a = ln H and b = ln J the normal equations are

    (diag(a²) + λ DᵀD) β = a·b,

where D stacks the forward differences along rows and columns *inside* the image, so DᵀD is the
graph Laplacian with Neumann (reflecting) borders. The widespread shortcut that builds the
Laplacian from ``spdiags`` of the full 5-point stencil gives border pixels four neighbours, two
of them fictitious zeros; that pulls β towards 0 along the edges and leaves light bands.

The system is symmetric positive definite and solved by conjugate gradients with a Jacobi
preconditioner, matrix-free (the Laplacian is one OpenCV filter pass), in float32. Measured on
astronaut at 1000² (relative residual 1e-3): plain CG 53 iterations, Jacobi-PCG 29. A
coarse-to-fine start (the same problem on 2×2 blocks, recursively) cut that to 19–21 but cost
as much time as it saved on the grids solved here (≤ 0.6 MP, see below), so it is not used.

λ is per pixel of a reference-sized image (about 500 × 500, coffee's size). On a larger image
the texture's strokes span proportionally more pixels (see :func:`texture_scale`); solved per
pixel, β would follow them and flatten the texture (the relative spread of ln T falls from 0.25
at 512² to 0.06 at 12 MP). So β is solved constant on blocks of ``round(texture_scale)`` pixels
— the exact minimiser of the same energy over such β: block sums of a² and a·b on the diagonal
and right-hand side, λ·block per block edge (that many pixel edges cross it), i.e. the paper's
problem on reference-sized pixels — and interpolated bilinearly. That keeps the look independent
of resolution and makes a 12 MP solve cost what a 0.25 MP one does.

The texture itself is synthesised, not scanned: a periodic Gaussian random field whose spectrum
is concentrated in long thin diagonal streaks (two stroke directions, as a right hand hatches)
plus fine isotropic grain for the paper's tooth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import scipy.fft

#: Pixels across a "reference" image (about coffee's size); bigger images get proportionally
#: wider and longer strokes, and a β solved on proportionally larger blocks, so the drawing
#: looks the same at the same print size.
REFERENCE_SIDE = 500.0
#: Stroke shape at the reference size, in pixels: Gaussian std along and across the stroke.
STROKE_LENGTH, STROKE_WIDTH = 30.0, 0.7
#: Main hatching direction (degrees counter-clockwise from +x, as seen on screen) and a second,
#: weaker direction a little steeper, so the hatching looks hand-made rather than ruled.
STROKE_ANGLES = (40.0, 55.0)
STROKE_WEIGHTS = (1.0, 0.6)
GRAIN_WEIGHT = 0.5
#: Graphite density −ln H = MEAN_DENSITY · exp(CONTRAST · field) / mean: H ≈ e^−0.3 ≈ 0.74 on
#: average, a one-σ stroke 57 % denser than the ground (chosen by eye on coffee and camera:
#: 0.35 looks washed out, 0.6 turns dark areas into white rain).
MEAN_DENSITY, CONTRAST = 0.3, 0.45

#: ln J is floored here: J = 0 would ask for infinitely many passes.
J_FLOOR = 1.0 / 255.0


@dataclass(frozen=True)
class TextureResult:
    """The fitted texture map.

    Attributes
    ----------
    T : ndarray of float32, shape (H, W)
        Texture map min(H^β, 1) in (0, 1].
    beta : ndarray of float32, shape (H, W)
        Number of pencil passes at each pixel (≥ 0 in practice, 0 on paper white).
    iterations : int
        Preconditioned CG iterations.
    residual : float
        Relative residual ‖A β − a·b‖ / ‖a·b‖ of the normal equations on the solved grid
        (block-restricted when ``block > 1``), computed in float64.
    block : int
        Side in pixels of the blocks β was solved on (1 = per pixel, the paper's problem).
    """

    T: np.ndarray
    beta: np.ndarray
    iterations: int
    residual: float
    block: int


def pencil_texture(
    shape: tuple[int, int], *, seed: int = 0, scale: float | None = None, reduction: int | None = None
) -> np.ndarray:
    """Synthesise a graphite hatching texture.

    Parameters
    ----------
    shape : (int, int)
        ``(H, W)`` in pixels.
    seed : int
        Seed of the random field; the same ``(shape, seed, scale)`` gives the same texture.
    scale : float, optional
        Stroke size multiplier. Default :func:`texture_scale`, so strokes are about 0.7 px wide
        and 30 px long on a coffee-sized image and proportionally larger on bigger ones.
    reduction : int, optional
        Synthesise the random field on a grid this many times coarser (at FFT-friendly sizes)
        and bring it to ``shape`` by periodic cubic interpolation. The field has no detail finer
        than its grain (Gaussian σ = ``scale / 2`` px), so this changes nothing visible while
        the grain spans a pixel of the coarse grid; default ``floor(scale / 2)``: 1 (exact
        synthesis at ``shape``) below about 4 MP, 3 at 12 MP, where it makes the texture 2-3x
        faster (and sides with large prime factors, such as 3464 = 8·433, no slower than others).

    Returns
    -------
    ndarray of float32, shape (H, W)
        Texture strictly inside (0, 1), 1 = paper. Periodic with period ``shape``: tiled copies
        join without a seam.
    """
    h, w = int(shape[0]), int(shape[1])
    if h < 1 or w < 1:
        raise ValueError(f"shape must be positive, got {shape!r}")
    if scale is None:
        scale = texture_scale((h, w))
    reduction = max(1, math.floor(scale / 2)) if reduction is None else int(reduction)
    if reduction < 1:
        raise ValueError(f"reduction must be at least 1, got {reduction}")
    if reduction == 1:
        grid = (h, w)
    else:
        grid = (scipy.fft.next_fast_len(-(-h // reduction)), scipy.fft.next_fast_len(-(-w // reduction), real=True))
    # White noise through a filter: a circular convolution, hence periodic. Arithmetic is in
    # place where it can be, since at 12 MP each fresh temporary costs 0.1 s or more.
    noise = np.random.default_rng(seed).standard_normal(grid, dtype=np.float32)
    spectrum = scipy.fft.rfft2(noise, workers=-1)
    del noise
    # Frequencies in cycles per pixel of the image, whatever grid they are sampled on.
    fy = (scipy.fft.fftfreq(grid[0]) * (grid[0] / h)).astype(np.float32)
    fx = (scipy.fft.rfftfreq(grid[1]) * (grid[1] / w)).astype(np.float32)
    gain = GRAIN_WEIGHT * _unit_power(_gaussian_spectrum(fx, fy, 0.0, 0.5 * scale, 0.5 * scale))
    for angle, weight in zip(STROKE_ANGLES, STROKE_WEIGHTS):
        blob = _gaussian_spectrum(fx, fy, angle, STROKE_LENGTH * scale, STROKE_WIDTH * scale)
        blob = _unit_power(blob)
        blob *= weight
        gain += blob
    spectrum *= gain
    del gain
    field = scipy.fft.irfft2(spectrum, s=grid, workers=-1)
    del spectrum
    field -= field.mean()
    field *= CONTRAST / max(float(field.std()), 1e-12)
    if grid != (h, w):
        # Grid sample j lies at j · W / grid_w image pixels: a scaling of the torus, so
        # wrapping at the borders keeps the texture periodic with period (H, W).
        to_grid = np.array([[grid[1] / w, 0.0, 0.0], [0.0, grid[0] / h, 0.0]])
        field = cv2.warpAffine(
            field, to_grid, (w, h), flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_WRAP
        )
    # Log-normal graphite density: sparse thin dark strokes over a lighter ground (a symmetric
    # field would draw white streaks as boldly as dark ones, which reads as rain, not pencil).
    # It is positive, so ln H < 0: H strictly inside (0, 1).
    density = np.exp(field, out=field)
    density *= -MEAN_DENSITY / density.mean()
    return np.exp(density, out=density)


def texture_scale(shape: tuple[int, ...]) -> float:
    """Texture size multiplier for an image of ``shape`` (H, W[, C]): ``max(1, √(H·W) / 500)``."""
    return max(1.0, math.sqrt(shape[0] * shape[1]) / REFERENCE_SIDE)


def texture_map(
    J: np.ndarray,
    H: np.ndarray,
    *,
    lam: float = 0.2,
    block: int | None = None,
    tol: float = 1e-3,
    max_iter: int = 1000,
) -> TextureResult:
    """Fit β so that H^β renders the tone target J (paper formulas 13–14).

    Parameters
    ----------
    J : ndarray, shape (H, W)
        Tone target in [0, 1] (1 = paper white), e.g. from :func:`~pencilbot.imaging.tone.tone_target`.
    H : ndarray, shape (H, W)
        Pencil texture strictly inside (0, 1), e.g. from :func:`pencil_texture`.
    lam : float
        Smoothness weight λ per (block) pixel. The paper's 0.2 is the default.
    block : int, optional
        Solve β constant on ``block`` × ``block`` pixel blocks, then interpolate. Default
        ``round(texture_scale(J.shape))``: 1 (per pixel) up to about 750 × 750.
    tol : float
        Relative residual at which CG stops, on the normal equations of the solved grid. The solver
        works in float32 (half the memory and time at 12 MP); its floor is about 2e-6, so ask
        for no less than 1e-5.
    max_iter : int
        CG iteration limit.

    Returns
    -------
    TextureResult
    """
    J = np.asarray(J, dtype=np.float32)
    H = np.asarray(H, dtype=np.float32)
    if J.ndim != 2 or J.shape != H.shape:
        raise ValueError(f"J and H must be 2-D arrays of the same shape, got {J.shape} and {H.shape}")
    if not (np.all(H > 0) and np.all(H < 1)):
        raise ValueError("H must lie strictly inside (0, 1) so that ln H is finite and negative")
    if lam < 0:
        raise ValueError(f"lam must be >= 0, got {lam}")
    block = round(texture_scale(J.shape)) if block is None else int(block)
    if block < 1:
        raise ValueError(f"block must be at least 1 pixel, got {block}")
    a = np.log(H)
    rhs = np.clip(J, J_FLOOR, 1.0)
    np.log(rhs, out=rhs)
    rhs *= a
    # β constant on blocks: data terms add up, and `block` fine edges cross each coarse edge.
    d, rhs, mu = _block_sum(np.square(a), block), _block_sum(rhs, block), float(lam) * block
    beta, iterations = _pcg(d, rhs, mu, tol, max_iter)
    residual = _relative_residual(d, rhs, mu, beta)
    beta = _upsample(beta, block, J.shape)
    # T = H^β = exp(β ln H), computed in a's buffer. Next to paper white the smoothness term
    # makes β overshoot slightly below 0; a pencil cannot lighten the paper, so T stops at 1.
    T = np.exp(np.multiply(beta, a, out=a), out=a)
    np.minimum(T, 1.0, out=T)
    return TextureResult(T=T, beta=beta, iterations=iterations, residual=residual, block=block)


def _gaussian_spectrum(fx, fy, angle_deg: float, sigma_along: float, sigma_across: float) -> np.ndarray:
    """Fourier transform of an oriented Gaussian blob on the rfft2 grid ``fy`` × ``fx``.

    ``sigma_along`` and ``sigma_across`` are its std in pixels along and across the direction
    ``angle_deg``, which follows the image convention: (cos θ, −sin θ) in (col, row). The
    exponent is the quadratic form A·fx² + B·fx·fy + C·fy², built from the 1-D axes so that only
    two half-image arrays are ever allocated.
    """
    t = math.radians(angle_deg)
    c, s = math.cos(t), math.sin(t)
    # f_along = σu (c fx − s fy), f_across = σv (s fx + c fy); sum of squares expanded.
    u2, v2 = sigma_along**2, sigma_across**2
    A, B, C = c * c * u2 + s * s * v2, 2 * c * s * (v2 - u2), s * s * u2 + c * c * v2
    k = -2.0 * math.pi**2  # Python floats keep the arithmetic in float32
    exponent = np.add.outer((k * C) * fy * fy, (k * A) * fx * fx)
    exponent += np.multiply.outer((k * B) * fy, fx)
    return np.exp(exponent, out=exponent)


def _unit_power(spectrum: np.ndarray) -> np.ndarray:
    """Scale a filter so white noise through it has unit variance (Parseval), so the weights
    above compare components of equal strength whatever their bandwidth."""
    spectrum *= 1.0 / math.sqrt(float(np.vdot(spectrum, spectrum)) / spectrum.size)
    return spectrum


_LAPLACIAN = np.array([[0, -1, 0], [-1, 4, -1], [0, -1, 0]], dtype=np.float32)


def _neumann_laplacian(x: np.ndarray, weight: float = 1.0) -> np.ndarray:
    """``weight`` · DᵀD x for forward differences inside the grid.

    Replicating the border makes each missing neighbour equal to the pixel itself, so its
    difference term vanishes: exactly the Neumann graph Laplacian."""
    return cv2.filter2D(x, -1, weight * _LAPLACIAN, borderType=cv2.BORDER_REPLICATE)


def _degree(shape: tuple[int, int]) -> np.ndarray:
    """Number of in-grid 4-neighbours of each pixel (the diagonal of DᵀD)."""
    h, w = shape
    rows = np.full(h, 2.0, np.float32)
    cols = np.full(w, 2.0, np.float32)
    rows[[0, -1]] -= 1.0
    cols[[0, -1]] -= 1.0
    return rows[:, None] + cols[None, :]


def _apply(d: np.ndarray, mu: float, x: np.ndarray) -> np.ndarray:
    """(diag(d) + μ DᵀD) x."""
    out = _neumann_laplacian(x, mu)
    out += d * x
    return out


def _pcg(d: np.ndarray, rhs: np.ndarray, mu: float, tol: float, max_iter: int) -> tuple[np.ndarray, int]:
    """Solve (diag(d) + μ DᵀD) x = rhs by Jacobi-preconditioned conjugate gradients from 0.

    Returns x and the number of iterations (stops when ‖r‖ <= tol ‖rhs‖ or at ``max_iter``)."""
    inv_diag = 1.0 / (d + mu * _degree(d.shape))
    target = tol * float(np.linalg.norm(rhs))
    x = np.zeros_like(rhs)
    r = rhs.copy()
    z = r * inv_diag
    p = z.copy()
    rz = float(np.vdot(r, z))
    for iteration in range(max_iter):
        if float(np.linalg.norm(r)) <= target:
            return x, iteration
        q = _apply(d, mu, p)
        alpha = rz / float(np.vdot(p, q))
        x += alpha * p
        r -= alpha * q
        np.multiply(r, inv_diag, out=z)
        rz_next = float(np.vdot(r, z))
        p *= rz_next / rz
        p += z
        rz = rz_next
    return x, max_iter


def _block_sum(x: np.ndarray, block: int) -> np.ndarray:
    """Sums over ``block`` × ``block`` blocks (the last row/column of blocks may be partial)."""
    if block == 1:
        return x
    rows = np.add.reduceat(x, np.arange(0, x.shape[0], block), axis=0)
    return np.add.reduceat(rows, np.arange(0, x.shape[1], block), axis=1)


def _upsample(x: np.ndarray, block: int, shape: tuple[int, int]) -> np.ndarray:
    """Bilinear interpolation of block values (one per block centre) to pixels of ``shape``.

    Returns a view into a slightly larger array when ``shape`` is not a multiple of ``block``."""
    if block == 1:
        return x
    h, w = x.shape
    return cv2.resize(x, (w * block, h * block), interpolation=cv2.INTER_LINEAR)[: shape[0], : shape[1]]


def _relative_residual(d: np.ndarray, rhs: np.ndarray, mu: float, x: np.ndarray) -> float:
    """‖(diag(d) + μ DᵀD) x − rhs‖ / ‖rhs‖ in float64 (0 when rhs is 0 and so is the answer)."""
    x64 = x.astype(np.float64)
    r = d * x64 + _neumann_laplacian(x64, mu) - rhs
    norm = float(np.linalg.norm(rhs.astype(np.float64)))
    return float(np.linalg.norm(r)) / norm if norm > 0 else float(np.linalg.norm(r))
