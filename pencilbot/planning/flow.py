"""The direction field hatching follows, and the stripe phase whose level lines are hatch lines.

An artist hatches along the form: the strokes of a cheek curve with the cheek, the strokes of a
table run with its grain, and flat backgrounds get one calm direction. The form is read from the
tone itself with a **structure tensor**: the tone's gradient ∇J, its outer product ∇J ∇Jᵀ averaged
over a few millimetres, gives at every point the direction across which tone changes most; hatch
lines run across it, along the isophotes (lines of equal tone). Where the tone is flat the tensor
is weak and a small constant tensor of the default direction wins, so empty areas get straight,
parallel hatching instead of noise.

That field is a *line* field (θ and θ + 180° are the same direction). Hatch lines are the level
lines φ = k·s of a **stripe phase** φ whose gradient is the field's normal: φ solves the Poisson
problem min ‖∇φ − n‖², with n made a vector field by choosing its signs consistently — the
leading eigenvector of the matrix of neighbour agreements n_i · n_j (a relaxation of the sign
choice that flips as few neighbours as possible; a flip remains only where the field truly cannot
be oriented, around a half-turn singularity). Where the field has curl, |∇φ| ≠ 1 and lines crowd
or spread; the hatcher measures |∇φ| and adjusts line density to it.

Everything runs on a coarse grid (cells of a few millimetres: the form varies slowly) and is
upsampled smoothly; the Poisson solve is one DCT, the sign problem a sparse eigenvector.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy import fft, sparse
from scipy import ndimage as ndi
from scipy.sparse import csgraph

from pencilbot.planning.backdrop import own_structure

#: Coherence of the structure tensor below which texture follows the default direction, and
#: above which the form is followed exactly (linear in between).
COHERENCE_RANGE = (0.35, 0.7)
#: Hatch lines run at this angle (degrees from the page's +x) where the tone is flat: the
#: natural stroke of a right hand.
DEFAULT_ANGLE = 45.0


@dataclass(frozen=True)
class Grid:
    """Square cells of ``cell`` mm over a drawing ``box`` (x0, y0, x1, y1) in page mm, Y up.

    Cell (r, c) is centred at (x0 + (c + ½)·cell, y1 − (r + ½)·cell): row 0 is the top of the
    picture, as in images. The cells cover the box (the last row and column may overhang it).
    """

    box: tuple[float, float, float, float]
    cell: float

    @property
    def shape(self) -> tuple[int, int]:
        x0, y0, x1, y1 = self.box
        return (
            max(1, int(np.ceil((y1 - y0) / self.cell - 1e-9))),
            max(1, int(np.ceil((x1 - x0) / self.cell - 1e-9))),
        )

    def centres(self) -> np.ndarray:
        """Page mm (rows, cols, 2) of the cell centres."""
        x0, _, _, y1 = self.box
        rows, cols = self.shape
        x = x0 + (np.arange(cols) + 0.5) * self.cell
        y = y1 - (np.arange(rows) + 0.5) * self.cell
        return np.stack(np.meshgrid(x, y), axis=-1)

    def to_rc(self, points: np.ndarray) -> np.ndarray:
        """Fractional (row, col) of page points (…, 2)."""
        x0, _, _, y1 = self.box
        points = np.asarray(points, np.float64)
        return np.stack(
            [(y1 - points[..., 1]) / self.cell - 0.5, (points[..., 0] - x0) / self.cell - 0.5], axis=-1
        )

    def to_mm(self, rc: np.ndarray) -> np.ndarray:
        """Page mm of fractional (row, col) (…, 2)."""
        x0, _, _, y1 = self.box
        rc = np.asarray(rc, np.float64)
        return np.stack([x0 + (rc[..., 1] + 0.5) * self.cell, y1 - (rc[..., 0] + 0.5) * self.cell], axis=-1)

    def sample(self, values: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Bilinear values of a (rows, cols) array on this grid at page points (N, 2), clamped."""
        return bilinear(values, self.to_rc(points).reshape(-1, 2))

    def resample(self, values: np.ndarray, finer: Grid, *, cubic: bool = False) -> np.ndarray:
        """A (rows, cols) array on this grid, interpolated onto the cells of another grid."""
        # Both grids are axis-aligned: the map is separable, built from one row and one column.
        rows, cols = finer.shape
        x0, _, _, y1 = self.box
        fx0, _, _, fy1 = finer.box
        col = ((fx0 + (np.arange(cols) + 0.5) * finer.cell - x0) / self.cell - 0.5).astype(np.float32)
        row = ((y1 - (fy1 - (np.arange(rows) + 0.5) * finer.cell)) / self.cell - 0.5).astype(np.float32)
        map_x = np.broadcast_to(col, (rows, cols)).copy()
        map_y = np.broadcast_to(row[:, None], (rows, cols)).copy()
        mode = cv2.INTER_CUBIC if cubic else cv2.INTER_LINEAR
        return cv2.remap(np.asarray(values, np.float32), map_x, map_y, mode, borderMode=cv2.BORDER_REPLICATE)


@dataclass(frozen=True)
class DirectionField:
    """Unit hatch directions on a grid over a drawing box.

    Attributes
    ----------
    grid : Grid
    direction : (rows, cols, 2) float array
        Unit vector (dx, dy) in page axes (Y up) of the hatch direction, signs chosen consistently.
    """

    grid: Grid
    direction: np.ndarray

    def rotated(self, degrees: float) -> DirectionField:
        """The same field turned by ``degrees`` counter-clockwise (a cross-hatching family)."""
        a = np.deg2rad(degrees)
        c, s = np.cos(a), np.sin(a)
        dx, dy = self.direction[..., 0], self.direction[..., 1]
        turned = np.stack([c * dx - s * dy, s * dx + c * dy], axis=-1)
        return DirectionField(self.grid, turned)


def bilinear(values: np.ndarray, rc: np.ndarray) -> np.ndarray:
    """Bilinear interpolation of a 2-D array at fractional (row, col) points (N, 2), clamped.

    OpenCV's remap in float32 (its weights are quantised to 1/32 of a cell: a few µm on these
    grids), ten times faster than gathering the four neighbours in NumPy.
    """
    values = np.asarray(values, np.float32)
    rc = np.asarray(rc, np.float32).reshape(-1, 2)
    n = len(rc)
    if n == 0:
        return np.zeros(0)
    if max(values.shape) >= _REMAP_LIMIT:  # pragma: no cover - grids over 32 767 cells a side
        return ndi.map_coordinates(values, [rc[:, 0], rc[:, 1]], order=1, mode="nearest")
    # remap wants a 2-D map under 32 767 a side: fold the points into rows.
    pad = (-n) % _REMAP_ROW
    cols = np.pad(rc[:, 1], (0, pad)).reshape(-1, _REMAP_ROW)
    rows = np.pad(rc[:, 0], (0, pad)).reshape(-1, _REMAP_ROW)
    out = cv2.remap(values, cols, rows, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.ravel()[:n].astype(np.float64)


_REMAP_ROW = 4096
_REMAP_LIMIT = 32767


def direction_field(
    tone: np.ndarray,
    grid: Grid,
    *,
    scale: float = 8.0,
    default_angle: float = DEFAULT_ANGLE,
    calm: float = 0.008,
) -> DirectionField:
    """Hatch directions along the isophotes of ``tone``, calm where the tone is flat.

    Parameters
    ----------
    tone : (rows, cols) float array
        Darkness or tone on ``grid`` (e.g. from :func:`sample_image`).
    grid : Grid
        Cells of a few mm: the form varies slowly.
    scale : float
        Gaussian sigma (mm) over which the structure tensor is averaged: the size of a "form".
    default_angle : float
        Direction (degrees from +x) where the tone has no direction of its own.
    calm : float
        Tone gradient (per mm) below which the default direction wins: a flat area's noise
        and grain do not steer the hatching.

    Returns
    -------
    DirectionField
    """
    tone = np.asarray(tone, np.float64)
    cell = grid.cell
    # Gradients in page axes: +x along columns, +y up (against rows).
    smooth = ndi.gaussian_filter(tone, 0.5, mode="nearest")
    gy_rows, gx = grid_gradient(smooth, cell)
    gy = -gy_rows
    sigma = max(scale / cell, 0.5)
    jxx = ndi.gaussian_filter(gx * gx, sigma, mode="nearest")
    jxy = ndi.gaussian_filter(gx * gy, sigma, mode="nearest")
    jyy = ndi.gaussian_filter(gy * gy, sigma, mode="nearest")
    # In the doubled-angle representation an orientation is a vector: the tensor's is
    # (jxx − jyy, 2 jxy), as long as its anisotropy. Where the tone is flat (below ``calm``) or
    # its texture has no direction of its own (grass, fabric: low coherence), the default
    # direction takes over smoothly, so such areas get calm parallel hatching instead of
    # whorls that trace noise; where the form is clear it is followed exactly.
    form = np.stack([jxx - jyy, 2 * jxy], axis=-1)
    spread = np.linalg.norm(form, axis=-1)
    trace = jxx + jyy
    coherence = spread / np.maximum(trace, 1e-12)
    strength = np.clip(trace / calm**2, 0.0, 1.0) if np.isfinite(calm) and calm > 0 else np.zeros_like(trace)
    strength *= own_structure(gx, gy, cell, calm)  # a flat backdrop is hatched flat
    follow = strength * np.clip(
        (coherence - COHERENCE_RANGE[0]) / (COHERENCE_RANGE[1] - COHERENCE_RANGE[0]), 0, 1
    )
    across = np.deg2rad(2 * (default_angle + 90.0))  # the default's gradient, doubled
    default = np.array([np.cos(across), np.sin(across)])
    blend = (
        follow[..., None] * form / np.maximum(spread, 1e-12)[..., None] + (1 - follow[..., None]) * default
    )
    # The blend's angle halved is the gradient's orientation; isophotes run across it.
    theta = 0.5 * np.arctan2(blend[..., 1], blend[..., 0]) + np.pi / 2
    axial = np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    return DirectionField(grid, orient(axial))


def orient(axial: np.ndarray) -> np.ndarray:
    """Choose the sign of every unit vector of a line field so neighbours agree.

    Parameters
    ----------
    axial : (rows, cols, 2) float array
        Unit vectors, each meaning the line through it (sign arbitrary).

    Returns
    -------
    (rows, cols, 2) float array
        The same lines as a vector field. Signs are propagated from one cell along the maximum
        spanning tree of neighbour alignment |u_i · u_j| (so they are carried across where the
        field is clearest, and a seam, if the field cannot be oriented, falls where it is
        weakest), by pointer jumping: O(log n) whole-array steps.
    """
    rows, cols = axial.shape[:2]
    n = rows * cols
    flat = axial.reshape(n, 2)
    if n == 1:
        return axial.copy()
    index = np.arange(n).reshape(rows, cols)
    i = np.concatenate([index[:, :-1].ravel(), index[:-1, :].ravel()])
    j = np.concatenate([index[:, 1:].ravel(), index[1:, :].ravel()])
    agree = np.einsum("ij,ij->i", flat[i], flat[j])
    # Minimum spanning tree of 1 − |agreement| (+ε: csgraph drops zero weights).
    cost = sparse.coo_matrix((1.0 + 1e-6 - np.abs(agree), (i, j)), shape=(n, n)).tocsr()
    tree = csgraph.minimum_spanning_tree(cost)
    tree = tree + tree.T
    _, parent = csgraph.breadth_first_order(tree, 0, directed=False, return_predecessors=True)
    # The sign of the edge to each cell's parent, then the product of signs up to the root.
    sign = np.ones(n)
    child = np.flatnonzero(parent >= 0)
    sign[child] = np.where(np.einsum("ij,ij->i", flat[child], flat[parent[child]]) < 0, -1.0, 1.0)
    jump = np.where(parent >= 0, parent, np.arange(n))
    while True:
        sign = sign * np.where(jump != np.arange(n), sign[jump], 1.0)
        nxt = jump[jump]
        if np.array_equal(nxt, jump):
            break
        jump = nxt
    return (flat * sign[:, None]).reshape(rows, cols, 2)


def stripe_phase(field: DirectionField) -> np.ndarray:
    """The phase φ (mm) whose level lines run along ``field``: min ‖∇φ − n‖², n the unit normal.

    Where n is curl-free (the isophotes of any tone, which are what the first family follows)
    the level lines follow the field exactly with |∇φ| = 1. Where it is not (lines fanning out
    around a point, as the cross-hatching of a round form would), the fit keeps the curl-free
    part: lines bend away from the field and crowd or spread, which the hatcher measures as
    |∇φ| and compensates with line density. (Fitting a spacing factor m so that m·n is
    curl-free was tried: lines followed fans better, but crowding cost more tone fidelity than
    it gained, and the sparse solve doubled the planning time.)

    Parameters
    ----------
    field : DirectionField

    Returns
    -------
    (rows, cols) float array
        φ on the field's grid, mm, mean zero.
    """
    dx, dy = field.direction[..., 0], field.direction[..., 1]
    # The normal, turned +90° from the direction, in grid axes (columns right, rows down).
    n_col, n_row = -dy, -dx
    rows, cols = field.grid.shape
    h = field.grid.cell
    # Least squares over forward differences on the staggered grid: D^T D φ = D^T n, with D^T D
    # the Neumann Laplacian that the DCT-II diagonalises.
    flux_col = 0.5 * (n_col[:, 1:] + n_col[:, :-1]) * h
    flux_row = 0.5 * (n_row[1:, :] + n_row[:-1, :]) * h
    rhs = np.zeros((rows, cols))
    rhs[:, :-1] -= flux_col
    rhs[:, 1:] += flux_col
    rhs[:-1, :] -= flux_row
    rhs[1:, :] += flux_row
    eig_r = 2.0 - 2.0 * np.cos(np.pi * np.arange(rows) / rows)
    eig_c = 2.0 - 2.0 * np.cos(np.pi * np.arange(cols) / cols)
    denom = eig_r[:, None] + eig_c[None, :]
    denom[0, 0] = 1.0
    spectrum = fft.dctn(rhs, type=2, norm="ortho") / denom
    spectrum[0, 0] = 0.0
    return fft.idctn(spectrum, type=2, norm="ortho")


def sample_image(image: np.ndarray, layout, grid: Grid) -> np.ndarray:
    """Values of an image (on the layout's pixel grid) at the centres of a grid's cells.

    Area-averaged when the cells are larger than the pixels, bilinear otherwise.
    """
    image = np.asarray(image, np.float32)
    ratio = grid.cell / layout.mm_per_px
    factor = np.array([1.0, 1.0])
    if ratio > 1.5:
        shrunk = cv2.resize(
            image,
            (max(1, round(image.shape[1] / ratio)), max(1, round(image.shape[0] / ratio))),
            interpolation=cv2.INTER_AREA,
        )
        factor = np.array([image.shape[1] / shrunk.shape[1], image.shape[0] / shrunk.shape[0]])
        image = shrunk
    px = layout.mm_to_px(grid.centres().reshape(-1, 2))
    # Pixel (c, r) of the shrunk image covers original pixels [c·f − ½, (c + 1)·f − ½).
    maps = ((px + 0.5) / factor - 0.5).reshape(*grid.shape, 2).astype(np.float32)
    return cv2.remap(image, maps[..., 0], maps[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def gaussian(image: np.ndarray, sigma: float) -> np.ndarray:
    """``image`` (float32) blurred by a Gaussian of ``sigma`` cells, its edges replicated; as it is
    for a ``sigma`` of 0 or less."""
    if sigma <= 0:
        return np.asarray(image, np.float32)
    return cv2.GaussianBlur(np.asarray(image, np.float32), (0, 0), sigma, borderType=cv2.BORDER_REPLICATE)


def grid_gradient(values: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """``np.gradient`` of a 2-D grid (per mm; along rows, along columns), zero along an axis the
    grid is one cell across: the grid of a 1 x N picture's sheet has one row, with no slope."""
    along_rows, along_columns = (
        np.gradient(values, spacing, axis=axis) if values.shape[axis] > 1 else np.zeros_like(values)
        for axis in (0, 1)
    )
    return along_rows, along_columns
