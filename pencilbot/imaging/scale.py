"""The reference scale: how many pixels of an image stand for one pixel of a reference-sized picture.

A pencil drawing should look the same printed at the same size whatever the photo's resolution,
so sizes that are really fractions of the picture (edge-gradient step, line width, texture stroke
size) are counted in reference pixels, ``1 / REFERENCE_SIDE`` of the picture's linear size √(H·W).
Pictures up to the reference size (about coffee's 600 × 400) use their own pixels: scale 1.
"""

from __future__ import annotations

import math

#: Pixels across a reference picture (about skimage's coffee).
REFERENCE_SIDE = 500.0


def reference_scale(shape: tuple[int, ...]) -> float:
    """Pixels per reference pixel for an image of ``shape`` (H, W[, C]): ``max(1, √(H·W) / 500)``."""
    return max(1.0, math.sqrt(shape[0] * shape[1]) / REFERENCE_SIDE)
