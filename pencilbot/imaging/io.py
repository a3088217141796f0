"""Load photos into the float arrays the rest of :mod:`pencilbot.imaging` works on.

Everything downstream sees one representation: ``float32`` in ``[0, 1]`` with 1 = white paper,
a grey ``(H, W)`` array and an RGB ``(H, W, 3)`` array. Transparency is composited on white
paper (a transparent pixel is blank paper, not black), palettes are expanded, 16-bit samples keep
their precision, and the EXIF orientation tag is applied so a phone photo is drawn upright.

Grey is Rec. 601 luma (``0.299 R + 0.587 G + 0.114 B``), the Y of JPEG's YCbCr, so a colour
sketch can swap Y and keep Cb/Cr without a second definition of brightness.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass

import cv2
import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError

from pencilbot.errors import ImageLoadError, no_such_file
from pencilbot.fileio import available_memory, refuse_special_input
from pencilbot.imaging.png_strips import STRIP_BYTES, PngLayout, png_layout, reduced_png

DEFAULT_MAX_PIXELS = 40_000_000
#: More pixels than this are never decoded unless ``max_pixels`` allows more: Pillow's own
#: decompression-bomb threshold (twice its ``MAX_IMAGE_PIXELS``), kept when its check is not.
DECODE_LIMIT = 2 * 89_478_485
_EXIF_ORIENTATION = 0x0112
_BYTE_TO_FLOAT = np.arange(256, dtype=np.float32) / 255.0
log = logging.getLogger(__name__)
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
    path: str | os.PathLike,
    *,
    max_pixels: int = DEFAULT_MAX_PIXELS,
    downscale: bool = False,
    shrink_to: Callable[[tuple[int, int]], tuple[int, int]] | None = None,
) -> LoadedImage:
    """Decode an image file.

    Parameters
    ----------
    path : str or path-like
        Any format Pillow reads (PNG, JPEG, TIFF, BMP, WebP, GIF, ...). Of an animation or a
        multi-page file the first frame is used, with a warning saying so.
    max_pixels : int
        Largest accepted width × height, in pixels. Bigger images are refused (or shrunk, see
        ``downscale``) before their pixels are decoded, so a huge file cannot exhaust memory.
    downscale : bool
        Shrink a too-large image (area averaging, aspect kept) to at most ``max_pixels`` instead
        of refusing it.
    shrink_to : callable, optional
        ``shrink_to((H, W)) -> (h, w)``: the size the caller will use an image of upright size
        ``(H, W)`` at (no larger). The image is then decoded at a reduced scale where the format
        can (JPEG: 1/2, 1/4, 1/8), reduced further in its own 8- or 16-bit samples by area
        averaging, and only then converted to float: a 24 MP photo planned on A4 never exists
        as a full-size float array.

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
        raise ImageLoadError(no_such_file(name, "the path of an image file (PNG, JPEG, ...)"))
    refuse_special_input(name, "image", folder_ok=True)  # a FIFO, a device (a folder: below)
    if os.path.isdir(name):
        raise ImageLoadError(f"{name} is a directory, not an image file. Give an image file.")
    if os.path.getsize(name) == 0:
        raise ImageLoadError(f"{name} is empty (0 bytes). Re-export or re-download the image.")
    try:
        with _without_pillow_pixel_limit(), Image.open(name) as img:
            pixels, size = _decode(img, name, max_pixels, downscale, shrink_to)
    except ImageLoadError:
        raise
    except UnidentifiedImageError:
        raise ImageLoadError(
            f"{name} is not an image file Pillow can read. Give a PNG, JPEG, TIFF, BMP or WebP file."
        ) from None
    except (OSError, SyntaxError, ValueError) as err:
        raise ImageLoadError(
            f"{name} could not be decoded ({err}); it is probably truncated or corrupt. "
            "Re-export or re-download the image."
        ) from None
    return _from_samples(_reduce(pixels, size), name)


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


@contextmanager
def _without_pillow_pixel_limit():
    """Pillow's decompression-bomb check (a raw warning above 89.5 MP, an error above 179 MP)
    gives way to pencilbot's own: ``max_pixels`` before decoding, ``DECODE_LIMIT`` after."""
    saved = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None
    try:
        yield
    finally:
        Image.MAX_IMAGE_PIXELS = saved


def _decode(
    img: Image.Image, name: str, max_pixels: int, downscale: bool, shrink_to
) -> tuple[np.ndarray, tuple[int, int]]:
    """Decode ``img`` upright, at reduced scale where that is free: (samples, wanted (w, h))."""
    width, height = img.size
    frames = getattr(img, "n_frames", 1)
    if frames > 1:
        log.warning(
            "%s holds %d frames (an animation or a multi-page file): using the first only.", name, frames
        )
    too_large = width * height > max_pixels
    if too_large and not downscale:
        raise ImageLoadError(
            f"{name} is {width}×{height} = {width * height:,} pixels, more than the "
            f"limit of {max_pixels:,}. Use --downscale to shrink it, or raise --max-pixels."
        )
    orientation = _orientation(img)
    turned = orientation in (5, 6, 7, 8)  # a quarter turn upright
    upright = (height, width) if turned else (width, height)
    wanted = _fit_size(upright, max_pixels) if too_large else upright
    if shrink_to is not None:
        h, w = shrink_to((wanted[1], wanted[0]))
        wanted = (min(wanted[0], w), min(wanted[1], h))
    if (
        wanted != upright
        and img.format == "PNG"
        and orientation == 1
        and (too_large or width * height > DECODE_LIMIT)
    ):
        # PNG has no reduced decode: a picture too large to hold is read a strip of rows at a
        # time, shrunk as it goes (a whole factor, then the rest as any picture).
        factor = min(width // wanted[0], height // wanted[1])
        layout = png_layout(name) if factor >= 2 else None
        if layout is not None:
            reduced = (math.ceil(width / factor), math.ceil(height / factor))
            _check_memory(name, img, wanted, need=_strip_bytes(layout, factor, reduced, wanted))
            return reduced_png(name, layout, factor), wanted
    if wanted != upright:
        # JPEG can decode at 1/2, 1/4, 1/8 scale directly, keeping at least the size asked for.
        img.draft(img.mode, wanted[::-1] if turned else wanted)
    decoded = img.size[0] * img.size[1]
    if decoded > max(max_pixels, DECODE_LIMIT):
        raise ImageLoadError(
            f"{name} is {width}×{height} = {width * height:,} pixels; decoding more than "
            f"{DECODE_LIMIT:,} is unsafe and only JPEG and PNG (not interlaced, not 16-bit colour) decode at a reduced scale. Shrink it with an "
            "image editor first, or raise --max-pixels if this machine has the memory."
        )
    _check_memory(name, img, wanted)
    img.load()
    return _samples(ImageOps.exif_transpose(img) if orientation != 1 else img), wanted


def _orientation(img: Image.Image) -> int:
    """The EXIF orientation (1-8) known without decoding pixels.

    Pillow's ``getexif`` of a PNG decodes the whole picture to look for an ``eXIf`` chunk after
    the pixels (a 2147483647 x 1 header asked for 8 GB before any size check); the orientation
    of a PNG is read only from a chunk before them, as browsers do. Other formats keep EXIF in
    their header.
    """
    if img.format == "PNG" and "exif" not in img.info:
        return 1
    try:
        return int(img.getexif().get(_EXIF_ORIENTATION, 1))
    except (TypeError, ValueError):
        return 1


# Peak bytes per decoded pixel while loading: Pillow's RGBA-sized buffer, its copy as an array,
# a transposed or converted copy, and the area-averaging's input.
_DECODE_BYTES_PER_PIXEL = 16
# Bytes per pixel of the result: float32 RGB, float32 grey and the conversion's temporaries.
_RESULT_BYTES_PER_PIXEL = 32


def _strip_bytes(layout: PngLayout, factor: int, reduced: tuple[int, int], wanted: tuple[int, int]) -> int:
    """Peak bytes of a PNG read in strips: a strip's copies, the picture at 1/factor (premultiplied
    uint16 RGBA, and its copy as the strips join), the result."""
    strip = (
        factor
        * max(1, STRIP_BYTES // ((layout.stride + 1) * factor))
        * layout.width
        * _DECODE_BYTES_PER_PIXEL
    )
    return strip + reduced[0] * reduced[1] * 16 + wanted[0] * wanted[1] * _RESULT_BYTES_PER_PIXEL


def _check_memory(name: str, img: Image.Image, wanted: tuple[int, int], need: int | None = None) -> None:
    """Refuse a decode that needs more memory than this process can get, before it starts
    (``need``: bytes, when not the whole picture's decode)."""
    if need is None:
        need = (
            img.size[0] * img.size[1] * _DECODE_BYTES_PER_PIXEL
            + wanted[0] * wanted[1] * _RESULT_BYTES_PER_PIXEL
        )
    have, words = available_memory()
    if need > have:
        raise ImageLoadError(
            f"{name} is {img.size[0]}×{img.size[1]} pixels as decoded: loading it needs about "
            f"{need / 1e9:.2g} GB, more than the {have / 1e9:.2g} GB {words}. Shrink it with an image "
            "editor first, or lower --max-pixels with --downscale."
        )


def _samples(img: Image.Image) -> np.ndarray:
    """Pixels in their own depth: uint8 RGB or RGBA (straight alpha), uint16 or float32 grey."""
    if img.mode in ("I;16", "I;16L", "I;16B", "I;16N", "I"):
        # 16-bit grey (Pillow reports PNG/TIFF 16-bit grey as I;16, older versions as I): keep
        # the precision. 16-bit colour PNGs arrive from Pillow already reduced to 8 bits per
        # channel, which is still far finer than any pencil tone.
        return np.clip(np.asarray(img), 0, 65535).astype(np.uint16)
    if img.mode == "F":
        return np.clip(np.nan_to_num(np.asarray(img, dtype=np.float32)), 0.0, 1.0)
    # P with a transparency entry, LA, PA, RGBA, CMYK, YCbCr, 1, L, RGB: Pillow converts all.
    transparent = img.mode in ("RGBA", "LA", "PA", "RGBa", "La") or "transparency" in img.info
    mode = "RGBA" if transparent else "RGB"
    return np.asarray(img if img.mode == mode else img.convert(mode))


def _reduce(pixels: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Area-average samples to ``size`` (w, h) in their own depth; alpha is premultiplied first,
    so a transparent pixel adds paper, not its hidden colour (returned as uint16 (H, W, 4)
    holding colour × alpha and alpha × 255, for :func:`_from_samples`)."""
    if (pixels.shape[1], pixels.shape[0]) == size:
        return pixels
    if pixels.ndim == 3 and pixels.shape[2] == 4 and pixels.dtype == np.uint8:  # (uint16: premultiplied)
        alpha = pixels[:, :, 3:].astype(np.uint16)
        pixels = np.concatenate([pixels[:, :, :3] * alpha, alpha * 255], axis=2)
    return cv2.resize(pixels, size, interpolation=cv2.INTER_AREA)


def _from_samples(pixels: np.ndarray, source: str) -> LoadedImage:
    """One float conversion, at the final size: composite on white paper and derive grey."""
    if pixels.dtype == np.uint16 and pixels.ndim == 3:  # premultiplied, from _reduce
        rgb = (pixels[:, :, :3] + (65025 - pixels[:, :, 3:])).astype(np.float32)
        rgb *= np.float32(1 / 65025)
        return _from_rgb(rgb, source)
    if pixels.dtype == np.uint16:
        grey = pixels.astype(np.float32) / 65535.0
    elif pixels.dtype == np.float32:
        grey = pixels
    else:
        scaled = cv2.LUT(pixels, _BYTE_TO_FLOAT)  # exactly pixels / 255, 8x faster than numpy's cast
        return _from_rgba(scaled, source) if pixels.shape[2] == 4 else _from_rgb(scaled, source)
    return _from_rgb(np.dstack([grey, grey, grey]), source)


def _from_rgba(pixels: np.ndarray, source: str) -> LoadedImage:
    """Composite straight float RGBA on white paper and derive grey."""
    alpha = pixels[:, :, 3:4]
    return _from_rgb(pixels[:, :, :3] * alpha + (1.0 - alpha), source)


def _from_rgb(rgb: np.ndarray, source: str) -> LoadedImage:
    """Float RGB (paper already composited; a fresh array, clipped in place) and its Rec. 601 grey."""
    rgb = np.ascontiguousarray(rgb, dtype=np.float32)
    np.clip(rgb, 0.0, 1.0, out=rgb)
    gray = rgb @ LUMA_601
    np.clip(gray, 0.0, 1.0, out=gray)
    return LoadedImage(gray=gray, rgb=rgb, source=source)
