"""Load photos into the float arrays the rest of :mod:`pencilbot.imaging` works on.

Everything downstream sees one representation: ``float32`` in ``[0, 1]`` with 1 = white paper,
a grey ``(H, W)`` array and an RGB ``(H, W, 3)`` array. Transparency is composited on white
paper (a transparent pixel is blank paper, not black), palettes are expanded, 16-bit samples keep
their precision, and the EXIF orientation tag is applied so a phone photo is drawn upright.

Grey is Rec. 601 luma (``0.299 R + 0.587 G + 0.114 B``), the Y of JPEG's YCbCr, so a colour
sketch can swap Y and keep Cb/Cr without a second definition of brightness.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import cv2
import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError

from pencilbot.errors import ImageLoadError

DEFAULT_MAX_PIXELS = 40_000_000
LUMA_601 = np.array([0.299, 0.587, 0.114], dtype=np.float32)


@dataclass(frozen=True)
class LoadedImage:
    """A decoded image.

    Attributes
    ----------
    gray : ndarray of float32, shape (H, W)
        Luma in [0, 1], 1 = white.
    rgb : ndarray of float32, shape (H, W, 3)
        sRGB in [0, 1], transparency already composited on white.
    source : str
        Where the pixels came from (a path or a description), for messages and file metadata.
    """

    gray: np.ndarray
    rgb: np.ndarray
    source: str

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)`` in pixels."""
        return self.gray.shape


def load_image(
    path: str | os.PathLike, *, max_pixels: int = DEFAULT_MAX_PIXELS, downscale: bool = False
) -> LoadedImage:
    """Decode an image file.

    Parameters
    ----------
    path : str or path-like
        Any format Pillow reads (PNG, JPEG, TIFF, BMP, WebP, GIF, ...).
    max_pixels : int
        Largest accepted width × height, in pixels. Bigger images are refused (or shrunk, see
        ``downscale``) before their pixels are decoded, so a huge file cannot exhaust memory.
    downscale : bool
        Shrink a too-large image (area averaging, aspect kept) to at most ``max_pixels`` instead
        of refusing it.

    Returns
    -------
    LoadedImage

    Raises
    ------
    ImageLoadError
        The file is missing, unreadable, empty, not an image, truncated, or too large, or
        ``max_pixels`` is below 1.
    """
    name = os.fspath(path)
    if max_pixels < 1:
        # Checked first: with downscale, 0 would shrink every photo to one pixel without a word.
        raise ImageLoadError(f"--max-pixels must be at least 1, got {max_pixels}.")
    if not os.path.exists(name):
        raise ImageLoadError(f"{name}: no such file. Check the path.")
    if os.path.isdir(name):
        raise ImageLoadError(f"{name} is a directory, not an image file. Give an image file.")
    if os.path.getsize(name) == 0:
        raise ImageLoadError(f"{name} is empty (0 bytes). Re-export or re-download the image.")
    try:
        with Image.open(name) as img:
            width, height = img.size
            too_large = width * height > max_pixels
            if too_large and not downscale:
                raise ImageLoadError(
                    f"{name} is {width}×{height} = {width * height:,} pixels, more than the "
                    f"limit of {max_pixels:,}. Use --downscale to shrink it, or raise --max-pixels."
                )
            if too_large:
                # JPEG can decode at 1/2, 1/4, 1/8 scale directly: far less memory for huge photos.
                img.draft(img.mode, _fit_size((width, height), max_pixels))
            img.load()
            img = ImageOps.exif_transpose(img)
            pixels = _to_float_rgba(img)
    except ImageLoadError:
        raise
    except Image.DecompressionBombError as err:
        raise ImageLoadError(
            f"{name} is too large to decode safely ({err}). Shrink it with an image editor first."
        ) from None
    except UnidentifiedImageError:
        raise ImageLoadError(
            f"{name} is not an image file Pillow can read. Give a PNG, JPEG, TIFF, BMP or WebP file."
        ) from None
    except (OSError, SyntaxError, ValueError) as err:
        raise ImageLoadError(
            f"{name} could not be decoded ({err}); it is probably truncated or corrupt. "
            "Re-export or re-download the image."
        ) from None
    if pixels.shape[0] * pixels.shape[1] > max_pixels:
        target = _fit_size((pixels.shape[1], pixels.shape[0]), max_pixels)
        pixels = cv2.resize(pixels, target, interpolation=cv2.INTER_AREA)
    return _from_rgba(pixels, name)


def image_from_array(arr: np.ndarray, source: str = "array") -> LoadedImage:
    """Wrap an in-memory image (e.g. from ``skimage.data``) as a :class:`LoadedImage`.

    Parameters
    ----------
    arr : ndarray
        Shape (H, W), (H, W, 1), (H, W, 3) or (H, W, 4). ``uint8`` (0..255), ``uint16``
        (0..65535), ``bool``, or float already in [0, 1]. Alpha is composited on white.
    source : str
        A description kept in :attr:`LoadedImage.source`.

    Raises
    ------
    ImageLoadError
        Wrong shape, empty, non-finite or out-of-range values, or an unsupported dtype.
    """
    arr = np.asarray(arr)
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[2] not in (3, 4)):
        raise ImageLoadError(
            f"{source}: an image array must be (H, W), (H, W, 3) or (H, W, 4), got shape {arr.shape}."
        )
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ImageLoadError(f"{source}: the image has no pixels (shape {arr.shape}).")
    if arr.dtype == np.uint8:
        pixels = arr.astype(np.float32) / 255.0
    elif arr.dtype == np.uint16:
        pixels = arr.astype(np.float32) / 65535.0
    elif arr.dtype == bool:
        pixels = arr.astype(np.float32)
    elif np.issubdtype(arr.dtype, np.floating):
        pixels = arr.astype(np.float32)
        if not np.all(np.isfinite(pixels)) or pixels.min() < 0 or pixels.max() > 1:
            raise ImageLoadError(f"{source}: float image values must be finite and in [0, 1].")
    else:
        raise ImageLoadError(
            f"{source}: unsupported pixel type {arr.dtype}; use uint8, uint16, bool or float in [0, 1]."
        )
    if pixels.ndim == 2:
        pixels = np.dstack([pixels, pixels, pixels])
    if pixels.shape[2] == 3:
        pixels = np.dstack([pixels, np.ones(pixels.shape[:2], np.float32)])
    return _from_rgba(pixels, source)


def _fit_size(size: tuple[int, int], max_pixels: int) -> tuple[int, int]:
    """Largest ``(w, h)`` with the aspect of ``size`` and ``w * h <= max_pixels``."""
    width, height = size
    scale = math.sqrt(max_pixels / (width * height))
    return max(1, math.floor(width * scale)), max(1, math.floor(height * scale))


def _to_float_rgba(img: Image.Image) -> np.ndarray:
    """Any Pillow mode → float32 (H, W, 4) straight (non-premultiplied) RGBA in [0, 1]."""
    if img.mode in ("I;16", "I;16L", "I;16B", "I;16N", "I"):
        # 16-bit grey (Pillow reports PNG/TIFF 16-bit grey as I;16, older versions as I): keep
        # the precision. 16-bit colour PNGs arrive from Pillow already reduced to 8 bits per
        # channel, which is still far finer than any pencil tone.
        grey = np.clip(np.asarray(img).astype(np.float32) / 65535.0, 0.0, 1.0)
        alpha = np.ones_like(grey)
        return np.dstack([grey, grey, grey, alpha])
    if img.mode == "F":
        grey = np.clip(np.nan_to_num(np.asarray(img, dtype=np.float32)), 0.0, 1.0)
        return np.dstack([grey, grey, grey, np.ones_like(grey)])
    # P with a transparency entry, LA, PA, RGBA, CMYK, YCbCr, 1, L, RGB: Pillow converts all.
    rgba = np.asarray(img.convert("RGBA"), dtype=np.float32) / 255.0
    return rgba


def _from_rgba(pixels: np.ndarray, source: str) -> LoadedImage:
    """Composite straight RGBA on white paper and derive grey."""
    alpha = pixels[:, :, 3:4]
    rgb = pixels[:, :, :3] * alpha + (1.0 - alpha)
    rgb = np.ascontiguousarray(np.clip(rgb, 0.0, 1.0), dtype=np.float32)
    gray = np.clip(rgb @ LUMA_601, 0.0, 1.0).astype(np.float32)
    return LoadedImage(gray=gray, rgb=rgb, source=source)
