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
the texture's strokes span proportionally more pixels (see
:func:`~pencilbot.imaging.scale.reference_scale`); solved per pixel, β would follow them and
flatten the texture (the relative spread of ln T falls from 0.25 at 512² to 0.06 at 12 MP). So
β is solved constant on blocks of ``round(reference_scale)`` pixels
— the exact minimiser of the same energy over such β: block sums of a² and a·b on the diagonal
and right-hand side, λ·block per block edge (that many pixel edges cross it), i.e. the paper's
problem on reference-sized pixels — and interpolated bilinearly. That keeps the look independent
of resolution and makes a 12 MP solve cost what a 0.25 MP one does.

The paper fills with a hand-drawn texture; :func:`user_texture` takes one (a scan or photo of
pencil hatching), made seamless and tiled to the image. By default the texture is synthesised
(:func:`pencil_texture`): graphite marks — thin, tapered, of random pressure, hatched at two
nearby angles as a right hand does — scattered over the sheet, broken up by the paper's grain.
Both are normalised to the same graphite density, so that β, the number of passes, means the
same with either.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import cv2
import numpy as np
import scipy.fft

from pencilbot.errors import ImageLoadError
from pencilbot.imaging.scale import reference_scale
from pencilbot.imaging.texture_solve import block_sum, pcg, relative_residual, upsample

#: A graphite mark at the reference size, px: Gaussian std along it (about 4 std visible: a
#: hatching stroke of ~60 px on coffee) and across it (a fine pencil line).
STROKE_LENGTH, STROKE_WIDTH = 16.0, 0.55
#: Hatching directions, degrees counter-clockwise from +x as seen on screen, and each one's share
#: of the marks: a main direction and a weaker, steeper one, as a right hand hatches.
STROKE_ANGLES = (42.0, 58.0)
STROKE_WEIGHTS = (0.75, 0.25)
#: Marks per reference pixel²: they overlap (each covers about 60 px²) but stay countable.
MARKS_PER_PIXEL = 1 / 90
#: Paper grain: std of its bumps at the reference size, px, and how much it modulates the graphite.
GRAIN_SIZE, GRAIN_CONTRAST = 0.5, 0.18
#: Graphite density −ln H: its mean (H ≈ e^−0.3 ≈ 0.74), and its coefficient of variation. A
#: graphite haze between the marks sets the latter: a sparser, more contrasted texture reads as
#: crisper marks but T = H^β then falls short of dark tones (the fit is in ln H: the mean of H^β
#: over a region exceeds e^(β · mean ln H)); at 0.5 dark tones come out 0.06 light on coffee and
#: astronaut (σ = 3 px), at 0.7 0.09, at 1 0.18.
MEAN_DENSITY, DENSITY_CV = 0.3, 0.5

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
    """Synthesise a texture of graphite hatching marks on grained paper.

    Parameters
    ----------
    shape : (int, int)
        ``(H, W)`` in pixels.
    seed : int
        Seed of the marks and the grain; the same ``(shape, seed, scale)`` gives the same texture.
    scale : float, optional
        Mark size multiplier. Default :func:`~pencilbot.imaging.scale.reference_scale`, so marks
        are about 1 px wide and 60 px long on a coffee-sized image and proportionally larger
        on bigger ones.
    reduction : int, optional
        Synthesise on a grid about this many times coarser (sides rounded up to FFT-friendly
        lengths) and bring the graphite density to ``shape`` by periodic cubic interpolation.
        Nothing in the texture is finer than its grain (std ``GRAIN_SIZE · scale`` px) and its
        marks' width (``STROKE_WIDTH · scale``), so this changes nothing visible while those
        span a pixel of the coarse grid. Default ``floor(scale / 2)``: 1 (exact synthesis at
        ``shape``) below about 2000 × 2000, 3 at 12 MP, where the texture is 4x cheaper and a
        side with a large prime factor (3464 = 8 · 433) costs no more than any other.

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
        scale = reference_scale((h, w))
    reduction = max(1, math.floor(scale / 2)) if reduction is None else int(reduction)
    if reduction < 1:
        raise ValueError(f"reduction must be at least 1, got {reduction}")
    if reduction == 1:
        grid = (h, w)
    else:
        grid = (
            scipy.fft.next_fast_len(-(-h // reduction)),
            scipy.fft.next_fast_len(-(-w // reduction), real=True),
        )
    gh, gw = grid
    rng = np.random.default_rng(seed)
    # Marks: impulses of random pressure through an oriented Gaussian, one direction at a
    # time; the convolution is circular (FFT), hence periodic. Frequencies are in cycles per
    # pixel of the image, whatever grid they are sampled on, so sizes stay in image pixels.
    fy = (scipy.fft.fftfreq(gh) * (gh / h)).astype(np.float32)
    fx = (scipy.fft.rfftfreq(gw) * (gw / w)).astype(np.float32)
    spectrum = None
    for angle, share in zip(STROKE_ANGLES, STROKE_WEIGHTS):
        count = rng.poisson(share * h * w * MARKS_PER_PIXEL / scale**2)
        impulses = np.zeros(gh * gw, np.float32)
        np.add.at(impulses, rng.integers(0, gh * gw, count), rng.uniform(0.3, 1.0, count).astype(np.float32))
        part = scipy.fft.rfft2(impulses.reshape(gh, gw), workers=-1)
        part *= _gaussian_spectrum(fx, fy, angle, STROKE_LENGTH * scale, STROKE_WIDTH * scale)
        if spectrum is None:
            spectrum = part
        else:
            spectrum += part
    marks = scipy.fft.irfft2(spectrum, s=grid, workers=-1)
    del spectrum
    grain = _paper_grain(grid, rng, (GRAIN_SIZE * scale * gh / h, GRAIN_SIZE * scale * gw / w))
    # Haze under the marks so that the density (marks + haze) · grain has DENSITY_CV:
    # CV² = CV_marks² (1 + var g) + var g for grain g of mean 1, independent of the marks.
    var_grain = _mean_std(grain)[1] ** 2
    marks_cv = math.sqrt(max(DENSITY_CV**2 - var_grain, 1e-6) / (1.0 + var_grain))
    density = _with_haze(marks, marks_cv)
    density *= grain
    if grid != (h, w):
        # Grid sample j lies at j · W / gw image pixels: a scaling of the torus, so wrapping
        # at the borders keeps the texture periodic with period (H, W).
        to_grid = np.array([[gw / w, 0.0, 0.0], [0.0, gh / h, 0.0]])
        density = cv2.warpAffine(
            density, to_grid, (w, h), flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_WRAP
        )
    return _from_density(density)


def user_texture(
    source: str | os.PathLike | np.ndarray, shape: tuple[int, int], *, scale: float | None = None
) -> np.ndarray:
    """A hand-drawn pencil texture, as the paper uses, prepared for an image of ``shape``.

    Parameters
    ----------
    source : path or ndarray
        An image file (any format :func:`~pencilbot.imaging.io.load_image` reads; colour is
        taken as luma) or a grey array in [0, 1], 1 = paper.
    shape : (int, int)
        ``(H, W)`` of the image to texture, pixels.
    scale : float, optional
        The texture's pixels are taken as drawn for a reference-sized picture and enlarged by
        this factor; default :func:`~pencilbot.imaging.scale.reference_scale` of ``shape``.

    Returns
    -------
    ndarray of float32, shape (H, W)
        Strictly inside (0, 1): the texture enlarged and, if smaller than the image, made
        seamless (:func:`_seamless`) and tiled over it; its graphite density −ln H scaled to
        the synthetic texture's mean and lifted by a faint haze where it is more contrasted
        than ``DENSITY_CV`` (paper-white gaps would otherwise never take tone).

    Raises
    ------
    ImageLoadError
        ``source`` is a file that cannot be read as an image.
    """
    if isinstance(source, np.ndarray):
        gray = np.asarray(source, np.float32)
        if gray.ndim != 2 or gray.size == 0 or not np.all(np.isfinite(gray)):
            raise ValueError(f"a texture array must be a finite grey (H, W) array, got shape {gray.shape}")
    else:
        from pencilbot.imaging.io import load_image  # imported here: io is heavier than this module

        try:
            gray = load_image(source).gray
        except ImageLoadError as err:
            raise ImageLoadError(f"pencil texture: {err}") from None
    h, w = int(shape[0]), int(shape[1])
    scale = reference_scale((h, w)) if scale is None else float(scale)
    if scale > 1:
        size = (max(1, round(gray.shape[1] * scale)), max(1, round(gray.shape[0] * scale)))
        gray = np.asarray(
            cv2.resize(gray, size, interpolation=cv2.INTER_LINEAR), np.float32
        )  # float32 already
    density = -np.log(np.clip(gray, 1.0 / 255.0, 1.0))
    if density.shape[0] < h or density.shape[1] < w:
        density = _seamless(density)
        reps = (-(-h // density.shape[0]), -(-w // density.shape[1]))
        density = np.tile(density, reps)
    density = np.ascontiguousarray(density[:h, :w])
    mean, std = _mean_std(density)
    if mean > 0:
        density = _with_haze(density, min(std / mean, DENSITY_CV))
    else:  # a blank sheet: even graphite, no texture
        density = np.ones_like(density)
    return _from_density(density)


def _seamless(density: np.ndarray) -> np.ndarray:
    """``density`` made periodic, so that tiles of it meet without a seam, strokes unturned.

    Blended with itself shifted by half its size, under a weight w that is 0 on its edges and 1
    in its middle; the blend w·d + (1 − w)·d_shifted is divided by √(w² + (1 − w)²) about the
    mean so that the marks keep their contrast where the two overlap. (Mirrored tiles would be
    seamless too, but they turn diagonal hatching into herringbone.)
    """
    h, w = density.shape
    wy = np.sin(np.pi * (np.arange(h) + 0.5) / h) ** 2
    wx = np.sin(np.pi * (np.arange(w) + 0.5) / w) ** 2
    weight = np.outer(wy, wx)
    mean = float(density.mean())
    shifted = np.roll(density, (h // 2, w // 2), axis=(0, 1))
    blend = (weight * (density - mean) + (1 - weight) * (shifted - mean)) / np.hypot(weight, 1 - weight)
    return np.maximum(blend + mean, 0.0).astype(np.float32)


def _paper_grain(shape: tuple[int, int], rng: np.random.Generator, size: tuple[float, float]) -> np.ndarray:
    """Periodic fine noise of mean 1 and std GRAIN_CONTRAST (bumps of std ``size`` = (rows,
    columns) px), ≥ 0.05."""
    noise = rng.standard_normal(shape, dtype=np.float32)
    pad = int(math.ceil(4 * max(size))) + 1
    wrapped = cv2.copyMakeBorder(noise, pad, pad, pad, pad, cv2.BORDER_WRAP)  # circular blur
    grain: np.ndarray = cv2.GaussianBlur(wrapped, (0, 0), sigmaX=size[1], sigmaY=size[0])[pad:-pad, pad:-pad]
    grain *= GRAIN_CONTRAST / max(_mean_std(grain)[1], 1e-12)
    grain += 1.0
    return np.maximum(grain, 0.05, out=grain)


def _with_haze(density: np.ndarray, cv: float) -> np.ndarray:
    """``density`` plus (in place) the constant that brings its coefficient of variation down to ``cv``."""
    mean, std = _mean_std(density)
    density += max(std / max(cv, 1e-6) - mean, 0.0)
    return density


def _mean_std(x: np.ndarray) -> tuple[float, float]:
    """Mean and standard deviation in one pass (NumPy's var makes 12 MP temporaries)."""
    mean, std = cv2.meanStdDev(np.ascontiguousarray(x, np.float32))
    return float(mean[0, 0]), float(std[0, 0])


def _from_density(density: np.ndarray) -> np.ndarray:
    """H = exp(−density), the density scaled to MEAN_DENSITY; float32 strictly inside (0, 1)."""
    density = np.asarray(density, np.float32)
    density *= np.float32(MEAN_DENSITY / max(_mean_std(density)[0], 1e-12))
    np.maximum(density, np.float32(1e-4), out=density)  # H < 1: every pixel takes some graphite
    return np.exp(-density, out=density)


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
        ``round(reference_scale(J.shape))``: 1 (per pixel) up to about 750 × 750.
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
    block = round(reference_scale(J.shape)) if block is None else int(block)
    if block < 1:
        raise ValueError(f"block must be at least 1 pixel, got {block}")
    a = np.log(H)
    rhs = np.clip(J, J_FLOOR, 1.0)
    np.log(rhs, out=rhs)
    rhs *= a
    # β constant on blocks: data terms add up, and `block` fine edges cross each coarse edge.
    d, rhs, mu = block_sum(np.square(a), block), block_sum(rhs, block), float(lam) * block
    beta, iterations = pcg(d, rhs, mu, tol, max_iter)
    residual = relative_residual(d, rhs, mu, beta)
    beta = upsample(beta, block, J.shape)
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
