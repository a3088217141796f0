"""Drawings to PNG files: a sheet streamed band by band, a colour job's inks stacked on paper."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from pencilbot.colors import inks_on_paper
from pencilbot.paths import Paths
from pencilbot.render.canvas import (
    DEFAULT_DPI,
    TRAVEL_RGB,
    Bands,
    Canvas,
    band_rows,
    picture,
    sheet_pixels,
    travel_width,
)
from pencilbot.render.png import write_png_bands
from pencilbot.units import DEFAULT_PEN_WIDTH


def save_drawing_png(
    path: str | os.PathLike,
    paths: Paths | Sequence[np.ndarray],
    width_mm: float,
    height_mm: float,
    *,
    dpi: float = DEFAULT_DPI,
    pen_width: float = DEFAULT_PEN_WIDTH,
    travel: Paths | Sequence[np.ndarray] | None = None,
    band_pixels: int | None = None,
) -> tuple[int, int]:
    """Render ``paths`` (and a pen-up ``travel`` overlay) band by band straight into a PNG.

    The same picture :meth:`Canvas.save_png` writes for a canvas with these paths drawn (and
    travel overlaid), with memory bounded by one band of ``band_pixels`` pixels
    (:data:`BAND_PIXELS`, about 100 MB) whatever the sheet's size. Written atomically.

    Returns
    -------
    (int, int)
        The PNG's (rows, columns).
    """
    ink = Bands(paths, width_mm, height_mm, dpi=dpi, pen_width=pen_width)
    moves = (
        None
        if travel is None
        else Bands(travel, width_mm, height_mm, dpi=dpi, pen_width=travel_width(pen_width, ink.mm_per_px))
    )
    rows, columns = ink.shape
    step = band_rows(columns, band_pixels)

    def bands():
        for first in range(0, rows, step):
            stop = min(first + step, rows)
            yield picture(
                ink.log_transmittance(first, stop),
                None if moves is None else moves.log_transmittance(first, stop),
            )

    write_png_bands(path, ink.shape if travel is None else (rows, columns, 3), bands())
    return ink.shape


def color_image(canvases: Sequence[Canvas], colors: Sequence[str]) -> np.ndarray:
    """The ink of one canvas per pen, stacked as transparent colour layers on white paper.

    Parameters
    ----------
    canvases : sequence of Canvas
        One per pen, all of one shape; a travel overlay on any of them is shown in
        :data:`TRAVEL_RGB` on top.
    colors : sequence of str
        Each pen's ink, ``#rrggbb``.

    Returns
    -------
    (H, W, 3) uint8
        sRGB (see :func:`pencilbot.colors.inks_on_paper`).
    """
    rgb = 255.0 * inks_on_paper([canvas.darkness for canvas in canvases], colors)
    for canvas in canvases:
        travel = canvas.travel_share()
        if travel is not None:
            rgb = rgb * (1.0 - travel[..., None]) + np.asarray(TRAVEL_RGB, np.float32) * travel[..., None]
    return np.rint(rgb).astype(np.uint8)


def write_png(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write a uint8 grey (H, W) or RGB (H, W, 3) image as a PNG, atomically."""
    write_png_bands(path, image.shape, [image])


def save_color_png(
    path: str | os.PathLike,
    inks: Sequence[tuple[Paths | Sequence[np.ndarray], str, float]],
    width_mm: float,
    height_mm: float,
    *,
    dpi: float = DEFAULT_DPI,
    travel: Paths | Sequence[np.ndarray] | None = None,
    travel_pen: float = DEFAULT_PEN_WIDTH,
    band_pixels: int | None = None,
) -> tuple[int, int]:
    """Render each pen's paths as a transparent layer of its ink, band by band into a PNG.

    The picture :func:`color_image` makes of one :class:`Canvas` per pen, with memory bounded
    by one band of every pen (as :func:`save_drawing_png` for one pen). Written atomically.

    Parameters
    ----------
    inks : sequence of (paths, colour, pen width mm)
        One entry per pen, in the order they were drawn; colour ``#rrggbb``.
    travel : paths, optional
        Pen-up moves, overlaid in :data:`TRAVEL_RGB` (drawn as :class:`Canvas` draws travel
        for a ``travel_pen`` pen).

    Returns
    -------
    (int, int)
        The PNG's (rows, columns).
    """
    layers = [Bands(paths, width_mm, height_mm, dpi=dpi, pen_width=width) for paths, _, width in inks]
    colors = [color for _, color, _ in inks]
    mm_per_px, (rows, columns) = sheet_pixels(width_mm, height_mm, dpi, travel_pen)
    moves = (
        None
        if travel is None
        else Bands(travel, width_mm, height_mm, dpi=dpi, pen_width=travel_width(travel_pen, mm_per_px))
    )
    step = band_rows(columns * max(1, len(layers)), band_pixels)

    def bands():
        for first in range(0, rows, step):
            stop = min(first + step, rows)
            rgb = 255.0 * inks_on_paper([layer.darkness(first, stop) for layer in layers], colors)
            if moves is not None:
                share = -np.expm1(moves.log_transmittance(first, stop)).astype(np.float32)[..., None]
                rgb = rgb * (1.0 - share) + np.asarray(TRAVEL_RGB, np.float32) * share
            yield np.rint(rgb).astype(np.uint8)

    write_png_bands(path, (rows, columns, 3), bands())
    return rows, columns
