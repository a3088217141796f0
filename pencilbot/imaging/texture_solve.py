"""The linear system of the texture map: (D + μL) β = rhs, D diagonal (the texture's energy per
pixel or block), L the Neumann Laplacian, solved by conjugate gradients with a Jacobi
preconditioner (:func:`pcg`), on blocks of pixels summed (:func:`block_sum`) and spread back
(:func:`upsample`). All whole-array numpy / OpenCV."""

from __future__ import annotations

import cv2
import numpy as np

_LAPLACIAN = np.array([[0, -1, 0], [-1, 4, -1], [0, -1, 0]], dtype=np.float32)


def neumann_laplacian(x: np.ndarray, weight: float = 1.0) -> np.ndarray:
    """``weight`` · DᵀD x for forward differences inside the grid.

    Replicating the border makes each missing neighbour equal to the pixel itself, so its
    difference term vanishes: exactly the Neumann graph Laplacian."""
    return cv2.filter2D(x, -1, weight * _LAPLACIAN, borderType=cv2.BORDER_REPLICATE)


def degree(shape: tuple[int, int]) -> np.ndarray:
    """Number of in-grid 4-neighbours of each pixel (the diagonal of DᵀD)."""
    h, w = shape
    rows = np.full(h, 2.0, np.float32)
    cols = np.full(w, 2.0, np.float32)
    rows[[0, -1]] -= 1.0
    cols[[0, -1]] -= 1.0
    return rows[:, None] + cols[None, :]


def apply(d: np.ndarray, mu: float, x: np.ndarray) -> np.ndarray:
    """(diag(d) + μ DᵀD) x."""
    out = neumann_laplacian(x, mu)
    out += d * x
    return out


def pcg(d: np.ndarray, rhs: np.ndarray, mu: float, tol: float, max_iter: int) -> tuple[np.ndarray, int]:
    """Solve (diag(d) + μ DᵀD) x = rhs by Jacobi-preconditioned conjugate gradients from 0.

    Returns x and the number of iterations (stops when ‖r‖ <= tol ‖rhs‖ or at ``max_iter``)."""
    inv_diag = 1.0 / (d + mu * degree(d.shape))
    target = tol * float(np.linalg.norm(rhs))
    x = np.zeros_like(rhs)
    r = rhs.copy()
    z = r * inv_diag
    p = z.copy()
    rz = float(np.vdot(r, z))
    for iteration in range(max_iter):
        if float(np.linalg.norm(r)) <= target:
            return x, iteration
        q = apply(d, mu, p)
        alpha = rz / float(np.vdot(p, q))
        x += alpha * p
        r -= alpha * q
        np.multiply(r, inv_diag, out=z)
        rz_next = float(np.vdot(r, z))
        p *= rz_next / rz
        p += z
        rz = rz_next
    return x, max_iter


def block_sum(x: np.ndarray, block: int) -> np.ndarray:
    """Sums over ``block`` × ``block`` blocks (the last row/column of blocks may be partial)."""
    if block == 1:
        return x
    rows = np.add.reduceat(x, np.arange(0, x.shape[0], block), axis=0)
    return np.add.reduceat(rows, np.arange(0, x.shape[1], block), axis=1)


def upsample(x: np.ndarray, block: int, shape: tuple[int, int]) -> np.ndarray:
    """Bilinear interpolation of block values (one per block centre) to pixels of ``shape``.

    Returns a view into a slightly larger array when ``shape`` is not a multiple of ``block``."""
    if block == 1:
        return x
    h, w = x.shape
    return cv2.resize(x, (w * block, h * block), interpolation=cv2.INTER_LINEAR)[: shape[0], : shape[1]]


def relative_residual(d: np.ndarray, rhs: np.ndarray, mu: float, x: np.ndarray) -> float:
    """‖(diag(d) + μ DᵀD) x − rhs‖ / ‖rhs‖ in float64 (0 when rhs is 0 and so is the answer)."""
    x64 = x.astype(np.float64)
    r = d * x64 + neumann_laplacian(x64, mu) - rhs
    norm = float(np.linalg.norm(rhs.astype(np.float64)))
    return float(np.linalg.norm(r)) / norm if norm > 0 else float(np.linalg.norm(r))
