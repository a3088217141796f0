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
preconditioner, matrix-free (the Laplacian is one OpenCV filter pass), started from the solution
of the same problem on a grid of half the size, recursively (cascadic multigrid). The coarse
problem is the exact restriction of the energy to β constant on 2×2 blocks, so its solution is
the best such β; CG then only has to remove the high-frequency error that Jacobi handles well.

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
#: wider and longer strokes so the drawing looks the same at the same print size.
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

#: Coarsest grid side (pixels) of the multigrid start.
COARSEST_SIDE = 16
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
        CG iterations on the full-resolution grid (the coarse grids cost about a third more).
    residual : float
        Relative residual ‖A β − a·b‖ / ‖a·b‖ of the normal equations, computed in float64.
    """

    T: np.ndarray
    beta: np.ndarray
    iterations: int
    residual: float


def pencil_texture(shape: tuple[int, int], *, seed: int = 0, scale: float | None = None) -> np.ndarray:
    """Synthesise a graphite hatching texture.

    Parameters
    ----------
    shape : (int, int)
        ``(H, W)`` in pixels.
    seed : int
        Seed of the random field; the same ``(shape, seed, scale)`` gives the same texture.
    scale : float, optional
        Stroke size multiplier. Default: ``max(1, sqrt(H·W) / 500)``, so strokes are about 0.7 px
        wide and 30 px long on a coffee-sized image and proportionally larger on bigger ones.

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
        scale = max(1.0, math.sqrt(h * w) / REFERENCE_SIDE)
    noise = np.random.default_rng(seed).standard_normal((h, w), dtype=np.float32)
    # Frequencies in cycles per pixel; the field is a circular convolution, hence periodic.
    fy = scipy.fft.fftfreq(h).astype(np.float32)[:, None]
    fx = scipy.fft.rfftfreq(w).astype(np.float32)[None, :]
    spectrum = GRAIN_WEIGHT * _unit_power(_gaussian_spectrum(fx, fy, 0.0, 0.5 * scale, 0.5 * scale))
    for angle, weight in zip(STROKE_ANGLES, STROKE_WEIGHTS):
        blob = _gaussian_spectrum(fx, fy, angle, STROKE_LENGTH * scale, STROKE_WIDTH * scale)
        spectrum += weight * _unit_power(blob)
    field = scipy.fft.irfft2(scipy.fft.rfft2(noise, workers=-1) * spectrum, s=(h, w), workers=-1)
    field -= field.mean()
    field /= max(float(field.std()), 1e-12)
    # Log-normal graphite density: sparse thin dark strokes over a lighter ground (a symmetric
    # field would draw white streaks as boldly as dark ones, which reads as rain, not pencil).
    # It is positive, so ln H < 0: H strictly inside (0, 1).
    density = np.exp(CONTRAST * field)
    density *= MEAN_DENSITY / density.mean()
    return np.exp(-density).astype(np.float32)


def texture_map(
    J: np.ndarray,
    H: np.ndarray,
    *,
    lam: float = 0.2,
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
        Smoothness weight λ (per unit ln-tone² per pixel²). The paper's 0.2 is the default.
    tol : float
        Relative residual at which CG stops, on the full-resolution normal equations. The solver
        works in float32 (half the memory and time at 12 MP); its floor is about 2e-6, so ask
        for no less than 1e-5.
    max_iter : int
        CG iteration limit per grid level.

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
    a = np.log(H)
    rhs = a * np.log(np.clip(J, J_FLOOR, 1.0))
    beta, iterations = _solve(a * a, rhs, float(lam), tol, max_iter)
    residual = _relative_residual(a * a, rhs, float(lam), beta)
    # Next to paper white the smoothness term makes β overshoot slightly below 0; a pencil
    # cannot lighten the paper, so T stops at 1.
    T = np.minimum(np.exp(beta * a), 1.0)
    return TextureResult(T=T, beta=beta, iterations=iterations, residual=residual)


def _gaussian_spectrum(fx, fy, angle_deg: float, sigma_along: float, sigma_across: float) -> np.ndarray:
    """Fourier transform of an oriented Gaussian blob (std in pixels along/across ``angle``).

    The direction follows the image convention: (cos θ, −sin θ) in (col, row)."""
    # Python-float coefficients keep the arithmetic in float32 (NumPy scalars would promote it).
    t = math.radians(angle_deg)
    cos_t, sin_t = math.cos(t), math.sin(t)
    f_along = fx * (cos_t * sigma_along) - fy * (sin_t * sigma_along)
    f_across = fx * (sin_t * sigma_across) + fy * (cos_t * sigma_across)
    return np.exp(-2.0 * math.pi**2 * (f_along**2 + f_across**2))


def _unit_power(spectrum: np.ndarray) -> np.ndarray:
    """Scale a filter so white noise through it has unit variance (Parseval), so the weights
    above compare components of equal strength whatever their bandwidth."""
    return spectrum / np.sqrt(np.mean(spectrum**2))


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


def _solve(d: np.ndarray, rhs: np.ndarray, mu: float, tol: float, max_iter: int) -> tuple[np.ndarray, int]:
    """Solve (diag(d) + μ DᵀD) x = rhs: coarse-grid start, then Jacobi-preconditioned CG."""
    h, w = d.shape
    if min(h, w) >= 2 * COARSEST_SIDE:
        # β constant on 2×2 blocks: data terms add up, and two fine edges cross each coarse edge.
        coarse, _ = _solve(_block_sum(d), _block_sum(rhs), 2.0 * mu, tol, max_iter)
        x = cv2.resize(coarse, (2 * coarse.shape[1], 2 * coarse.shape[0]), interpolation=cv2.INTER_LINEAR)
        x = np.ascontiguousarray(x[:h, :w])
    else:
        x = np.zeros_like(rhs)
    return _pcg(d, rhs, mu, x, tol, max_iter)


def _pcg(d, rhs, mu, x, tol, max_iter) -> tuple[np.ndarray, int]:
    """Jacobi-preconditioned conjugate gradients from ``x`` (updated in place)."""
    inv_diag = 1.0 / (d + mu * _degree(d.shape))
    target = tol * float(np.linalg.norm(rhs))
    r = rhs - _apply(d, mu, x)
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


def _block_sum(x: np.ndarray) -> np.ndarray:
    """Sums over 2×2 blocks (an odd last row/column forms half blocks)."""
    h, w = x.shape
    padded = np.zeros((h + h % 2, w + w % 2), dtype=x.dtype)
    padded[:h, :w] = x
    return padded[0::2, 0::2] + padded[1::2, 0::2] + padded[0::2, 1::2] + padded[1::2, 1::2]


def _relative_residual(d: np.ndarray, rhs: np.ndarray, mu: float, x: np.ndarray) -> float:
    """‖(diag(d) + μ DᵀD) x − rhs‖ / ‖rhs‖ in float64 (0 when rhs is 0 and so is the answer)."""
    x64 = x.astype(np.float64)
    r = d * x64 + _neumann_laplacian(x64, mu) - rhs
    norm = float(np.linalg.norm(rhs.astype(np.float64)))
    return float(np.linalg.norm(r)) / norm if norm > 0 else float(np.linalg.norm(r))
