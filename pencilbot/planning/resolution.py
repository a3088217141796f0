"""The resolution a photo is planned at: a pixel at least a third of the pen wide on the page.

A pen cannot draw detail finer than its width, and the stroke length ℓ is counted in pixels: a
12 MP photo on A4 would give strokes under a millimetre and tens of thousands of them.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from pencilbot.imaging.io import LoadedImage, image_from_array
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.plan import Page
from pencilbot.planning.style import Style


def at_plot_resolution(image: LoadedImage, page: Page, pen_width: float) -> LoadedImage:
    """The image resampled so a pixel is at least a third of the pen wide on the page.

    A pen cannot draw detail finer than its width, and the stroke length ℓ is counted in
    pixels: a 12 MP photo on A4 would give strokes under a millimetre and tens of thousands of
    them. Smaller images, and images already at that size, are returned unchanged. A photo
    file is better loaded at that size directly: see :func:`plot_resolution`.

    Parameters
    ----------
    image : LoadedImage
    page : Page
    pen_width : float
        Pen width, mm.

    Returns
    -------
    LoadedImage
    """
    height, width = plot_shape(image.shape, page, pen_width)
    if (height, width) == image.shape:
        return image
    rgb = np.clip(cv2.resize(image.rgb, (width, height), interpolation=cv2.INTER_AREA), 0.0, 1.0)
    return image_from_array(rgb, source=image.source)


def plot_shape(shape: tuple[int, int], page: Page, pen_width: float) -> tuple[int, int]:
    """``(H, W)`` pixels an image of ``shape`` is planned at on ``page``: a pixel at least a
    third of the pen wide (sizes rounded down, so that it is), never more than ``shape``."""
    scale = Layout.fit(shape, page).mm_per_px / (pen_width / 3)
    if scale >= 1:
        return shape[0], shape[1]
    return max(1, math.floor(shape[0] * scale)), max(1, math.floor(shape[1] * scale))


def plot_resolution(style: Style, page: Page | None = None):
    """For :func:`~pencilbot.imaging.io.load_image`'s ``shrink_to``: the size a photo of a given
    size is planned at with ``style`` (on ``page``, default the style's page for that photo), so
    that a big photo is reduced while it is decoded instead of after.
    """

    def shape_for(shape: tuple[int, int]) -> tuple[int, int]:
        sheet = page if page is not None else page_size(style.page, style.orientation, shape, style.margin)
        return plot_shape(shape, sheet, style.pen_width)

    return shape_for
