"""Colour of ink on paper: sRGB ↔ linear light, and the subtractive model of stacked inks.

A pen's ink is a filter over the paper: where pen k covers a share a of the paper with ink of
reflectance c (linear light, per channel), the paper reflects ``1 − a (1 − c)`` of what it did.
Inks of separate pens (hatched at different angles, so their lines cross rather than coincide)
stack as independent filters::

    reflectance = paper × Π_k (1 − a_k (1 − c_k))

The colour separation (:mod:`pencilbot.planning.separation`), the colour previews and the simulated
colour plot use this one function, :func:`inks_on_paper`, so what is planned is what is judged.
It is a function of per-pen coverage arrays only, so it works on a whole sheet or on one band of
it at a time.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Rec. 709 / sRGB luminance weights of linear light.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
WHITE = (1.0, 1.0, 1.0)


def srgb_to_linear(rgb) -> np.ndarray:
    """sRGB values in [0, 1] → linear light (IEC 61966-2-1), any shape, float64."""
    rgb = np.clip(np.asarray(rgb, np.float64), 0.0, 1.0)
    return np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(linear) -> np.ndarray:
    """Linear light in [0, 1] → sRGB values, any shape, float64."""
    linear = np.clip(np.asarray(linear, np.float64), 0.0, 1.0)
    return np.where(linear <= 0.0031308, linear * 12.92, 1.055 * linear ** (1 / 2.4) - 0.055)


def hex_to_rgb(color: str) -> np.ndarray:
    """``"#rrggbb"`` → sRGB floats in [0, 1], shape (3,)."""
    return np.array([int(color[i : i + 2], 16) for i in (1, 3, 5)], np.float64) / 255.0


def inks_on_paper(coverages: Sequence[np.ndarray], colors: Sequence, *, paper=WHITE) -> np.ndarray:
    """The colour of paper under stacked inks, as sRGB.

    Parameters
    ----------
    coverages : sequence of (H, W) arrays in [0, 1]
        Share of the paper each pen's ink covers (a pen's own darkness as the exact-area
        renderer gives it: lines of one pen already stack among themselves).
    colors : sequence of sRGB triples in [0, 1] or ``"#rrggbb"`` strings
        Each pen's ink colour, in the order of ``coverages``.
    paper : sRGB triple
        The paper's colour.

    Returns
    -------
    (H, W, 3) float32 array in [0, 1]
        sRGB.
    """
    inks = [hex_to_rgb(c) if isinstance(c, str) else np.asarray(c, np.float64) for c in colors]
    if len(inks) != len(coverages):
        raise ValueError(f"{len(coverages)} coverage arrays for {len(inks)} colours")
    reflect = (
        np.empty((*np.shape(coverages[0]), 3), np.float32) if coverages else np.ones((1, 1, 3), np.float32)
    )
    reflect[...] = srgb_to_linear(paper).astype(np.float32)
    for cover, ink in zip(coverages, inks):
        absorbed = (1.0 - srgb_to_linear(ink)).astype(np.float32)
        reflect *= 1.0 - np.asarray(cover, np.float32)[..., None] * absorbed
    return linear_to_srgb(reflect).astype(np.float32)
