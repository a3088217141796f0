"""Flat backdrops drawn flat: hatching follows a form only where the tone has one of its own.

The direction field (:mod:`pencilbot.planning.flow`) reads the form from the structure tensor
averaged over the style's form scale (8 mm): a studio backdrop beside a head sees the head's
outline in that average and its hatching curves round the head in rings, strokes that pull the
eye off the face and draw a structure the photo does not have. An artist lays an even, quiet tone
there. Here each cell's *own* structure is measured as well: the tone's gradient energy averaged
over only ``OWN_SCALE`` mm. Where it is under the field's calm threshold (a backdrop, a wall, a
clear sky: no edge, no texture, no shading within a few millimetres) the form is not followed and
the hatching runs straight at the default angle; where the tone has structure (a cheek's shading,
hair, a fold) nothing changes.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage as ndi

#: Gaussian sigma (mm) over which a cell's own structure is measured: a few millimetres, well
#: under the form scale, so the rings an outline would cast round itself are left out.
OWN_SCALE = 3.0


def own_structure(gx: np.ndarray, gy: np.ndarray, cell: float, calm: float) -> np.ndarray:
    """How much each cell of a grid has a form of its own, 0 (flat) to 1.

    Parameters
    ----------
    gx, gy : (rows, cols) float arrays
        The tone's gradient per mm on the grid.
    cell : float
        The grid's cell, mm.
    calm : float
        Gradient (per mm) under which the tone counts as flat (the direction field's ``calm``).

    Returns
    -------
    (rows, cols) float array in [0, 1]
        ``1`` where the gradient energy over ``OWN_SCALE`` mm reaches ``calm²``, less below.
    """
    if not (np.isfinite(calm) and calm > 0):
        return np.zeros_like(gx)
    energy = ndi.gaussian_filter(gx * gx + gy * gy, max(OWN_SCALE / cell, 0.5), mode="nearest")
    return np.clip(energy / calm**2, 0.0, 1.0)
