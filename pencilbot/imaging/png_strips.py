"""A big PNG shrunk while it is read, a strip of rows at a time: the full picture never exists.

JPEG decodes at 1/2, 1/4 or 1/8 scale by itself; PNG has no such thing, and Pillow (like
OpenCV) decodes the whole picture first: a 30000 × 30000 PNG is 3.6 GB before it can be shrunk.
Here the file's compressed rows are inflated with :mod:`zlib` a strip at a time (a few MB), each
strip is unfiltered by Pillow's own PNG decoder (its C code: the Paeth and Average filters run
along a row and cannot be vectorised) and area-averaged by a whole factor ``k`` at once, so only
one strip and the picture at ``1/k`` scale are ever held.

Pillow unfilters a strip as a small PNG of its own: the rows as they are in the file (filter
byte included) after the strip's previous row, already unfiltered (filter "none"), which is what
the rows' Up, Average and Paeth filters refer to. That small PNG's header says 8-bit samples
with as many bytes per pixel as the file's (what the filters step by), so Pillow hands back the
unfiltered bytes untouched; they are read here as the file's own samples (palette, bit depth,
transparency). Interlaced files and 16-bit colour are not read this way (the caller decodes
those whole, within its limits).
"""

from __future__ import annotations

import io
import math
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np
from PIL import Image

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Bytes of unfiltered rows per strip (about): what is held besides the 1/k picture.
STRIP_BYTES = 8 << 20
_MAX_CHUNK = 1 << 31
#: Colour types and bit depths read in strips: (colour type, depth) -> samples per pixel.
_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
#: The small PNG Pillow unfilters a strip as: 8-bit samples, as many bytes per pixel as the file's.
_LIE = {1: 0, 2: 4, 3: 2, 4: 6}  # bytes per pixel -> colour type (grey, grey+alpha, RGB, RGBA)


@dataclass(frozen=True)
class PngLayout:
    """What a PNG's chunks before its pixels say (sizes in pixels, depth in bits per sample)."""

    width: int
    height: int
    depth: int
    color_type: int
    palette: bytes
    transparency: bytes | None
    first_data: int  # file offset of the first IDAT chunk

    @property
    def bytes_per_pixel(self) -> int:
        """What PNG's filters step by: whole bytes per pixel, at least 1."""
        return max(1, self.depth * _CHANNELS[self.color_type] // 8)

    @property
    def stride(self) -> int:
        """Bytes of one unfiltered row (without its filter byte)."""
        return (self.width * self.depth * _CHANNELS[self.color_type] + 7) // 8


def png_layout(path) -> PngLayout | None:
    """The layout of the PNG at ``path`` if it can be read in strips, else None (not a PNG,
    interlaced, 16-bit colour, or chunks that do not add up: the whole decode says what is wrong)."""
    with open(path, "rb") as handle:
        if handle.read(8) != _SIGNATURE:
            return None
        header, palette, transparency = None, b"", None
        for kind, offset, data in _chunks(handle, stop_at=b"IDAT"):
            if kind == b"IHDR" and len(data) == 13:
                header = struct.unpack(">IIBBBBB", data)
            elif kind == b"PLTE":
                palette = data
            elif kind == b"tRNS":
                transparency = data
            elif kind == b"IDAT":
                if header is None:
                    return None
                width, height, depth, color_type, _, _, interlace = header
                sixteen_bit_color = depth == 16 and color_type in (2, 4, 6)
                if interlace or color_type not in _CHANNELS or sixteen_bit_color or not width or not height:
                    return None
                if (
                    depth not in (1, 2, 4, 8, 16)
                    or (color_type in (2, 4, 6) and depth != 8)
                    or (color_type == 3 and (depth == 16 or not palette))
                ):
                    return None
                return PngLayout(width, height, depth, color_type, palette, transparency, offset)
    return None


def _chunks(handle, stop_at: bytes | None = None) -> Iterator[tuple[bytes, int, bytes]]:
    """``(type, file offset, data)`` of each chunk; the data of ``stop_at`` chunks is not read."""
    while True:
        offset = handle.tell()
        head = handle.read(8)
        if len(head) < 8:
            return
        length, kind = struct.unpack(">I4s", head)
        if length >= _MAX_CHUNK:
            return
        if kind == stop_at:
            yield kind, offset, b""
            return
        data = handle.read(length)
        handle.seek(4, io.SEEK_CUR)  # the CRC: a damaged chunk shows when its data is used
        yield kind, offset, data


def _pixel_data(path, layout: PngLayout) -> Iterator[bytes]:
    """The compressed pixel data of every IDAT chunk, in pieces of at most a megabyte."""
    with open(path, "rb") as handle:
        handle.seek(layout.first_data)
        while True:
            head = handle.read(8)
            if len(head) < 8:
                return
            length, kind = struct.unpack(">I4s", head)
            if kind != b"IDAT":
                return
            while length:
                piece = handle.read(min(length, 1 << 20))
                if not piece:
                    return
                length -= len(piece)
                yield piece
            handle.seek(4, io.SEEK_CUR)


def reduced_png(path, layout: PngLayout, factor: int) -> np.ndarray:
    """The PNG at ``path`` area-averaged ``factor`` × ``factor`` as it is read.

    Returns
    -------
    ndarray
        ``(ceil(H / factor), ceil(W / factor))`` samples: uint8 RGB ``(h, w, 3)``, premultiplied
        uint16 ``(h, w, 4)`` (colour × alpha, alpha × 255, as :func:`pencilbot.imaging.io`'s
        reduction gives it) when the picture has transparency, or uint16 grey ``(h, w)`` for a
        16-bit grey file.

    Raises
    ------
    ValueError
        The pixel data ends early or does not inflate (a truncated or damaged file).
    """
    width = layout.width
    out_w = math.ceil(width / factor)
    rows_per_strip = factor * max(1, STRIP_BYTES // ((layout.stride + 1) * factor))
    previous = b"\0" * (layout.stride + 1)  # the row before the first: all zero, as PNG says
    parts = []
    for raw in _filtered_strips(path, layout, rows_per_strip):
        rows = len(raw) // (layout.stride + 1)
        unfiltered = _unfilter(previous + raw, layout, rows + 1)
        previous = b"\0" + unfiltered[-1].tobytes()
        samples = _samples(unfiltered[1:], layout)
        whole = rows // factor * factor  # rows in whole blocks; the last strip may end with fewer
        for block in (samples[:whole], samples[whole:]):
            if len(block):
                size = (out_w, math.ceil(len(block) / factor))
                parts.append(cv2.resize(block, size, interpolation=cv2.INTER_AREA))
    reduced = np.concatenate(parts) if len(parts) > 1 else parts[0]
    if reduced.ndim == 2 and reduced.dtype == np.uint8:  # 8-bit grey (or fewer bits): as RGB
        reduced = np.repeat(reduced[..., None], 3, axis=2)
    return reduced


def _filtered_strips(path, layout: PngLayout, rows: int) -> Iterator[bytes]:
    """The inflated rows (filter byte and row bytes), ``rows`` at a time (fewer at the end).
    Nothing is inflated more than a strip ahead: a bomb's data costs a strip, not its claim."""
    row_bytes = layout.stride + 1
    left = layout.height * row_bytes
    inflater = zlib.decompressobj()
    pieces = _pixel_data(path, layout)
    buffered, pending = bytearray(), b""
    try:
        while left:
            size = min(rows * row_bytes, left)
            while len(buffered) < size:
                if not pending:
                    pending = next(pieces, b"")
                    if not pending or inflater.eof:
                        raise ValueError(
                            f"its pixel data ends after {layout.height - left // row_bytes} of "
                            f"{layout.height} rows"
                        )
                buffered += inflater.decompress(pending, size - len(buffered))
                pending = inflater.unconsumed_tail
            yield bytes(buffered[:size])
            del buffered[:size]
            left -= size
    except zlib.error as exc:
        raise ValueError(f"its pixel data does not inflate: {exc}") from None


def _unfilter(raw: bytes, layout: PngLayout, rows: int) -> np.ndarray:
    """Rows as in the file (each with its filter byte) → unfiltered bytes ``(rows, stride)``,
    by Pillow's PNG decoder (see the module docstring)."""
    bpp = layout.bytes_per_pixel
    width = layout.stride // bpp if layout.depth >= 8 else layout.stride  # sub-byte: 1 byte a "pixel"

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    small = (
        _SIGNATURE
        + chunk(b"IHDR", struct.pack(">IIBBBBB", width, rows, 8, _LIE[bpp], 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(raw, 0))
        + chunk(b"IEND", b"")
    )
    with Image.open(io.BytesIO(small)) as img:
        img.load()
        return np.frombuffer(img.tobytes(), np.uint8).reshape(rows, layout.stride)


def _samples(rows: np.ndarray, layout: PngLayout) -> np.ndarray:
    """Unfiltered rows → uint8 RGB, premultiplied uint16 RGBA or uint16 grey (see :func:`reduced_png`)."""
    width, depth, color_type, key = layout.width, layout.depth, layout.color_type, layout.transparency
    if depth == 16:  # grey: its own precision, transparency ignored (as the whole decode does)
        return rows.view(">u2").astype(np.uint16)[:, :width]
    if depth < 8:
        bits = np.unpackbits(rows, axis=1).reshape(len(rows), -1, depth)
        values = (bits * (1 << np.arange(depth - 1, -1, -1, dtype=np.uint8))).sum(axis=2, dtype=np.uint8)[
            :, :width
        ]
    else:
        values = rows.reshape(len(rows), width, _CHANNELS[color_type])
        if _CHANNELS[color_type] == 1:
            values = values[..., 0]
    if color_type == 3:
        palette = np.frombuffer(layout.palette, np.uint8).reshape(-1, 3)
        palette = np.vstack([palette, np.zeros((256 - len(palette), 3), np.uint8)])
        alpha = None
        if key:
            alpha = np.full(256, 255, np.uint8)
            alpha[: len(key)] = np.frombuffer(key[:256], np.uint8)
            alpha = alpha[values]
        rgb = palette[values]
    elif color_type in (0, 4):
        grey = values if color_type == 0 else values[..., 0]
        if depth < 8:
            grey = grey * np.uint8(255 // ((1 << depth) - 1))
        alpha = values[..., 1] if color_type == 4 else None
        if color_type == 0 and key is not None and len(key) >= 2:
            alpha = np.where(values == struct.unpack(">H", key[:2])[0], 0, 255).astype(np.uint8)
        if alpha is None:
            return np.ascontiguousarray(grey)  # one channel while shrinking; RGB at the end
        rgb = np.repeat(grey[..., None], 3, axis=2)
    else:
        rgb = values[..., :3]
        alpha = values[..., 3] if color_type == 6 else None
        if color_type == 2 and key is not None and len(key) >= 6:
            alpha = np.where((rgb == np.array(struct.unpack(">HHH", key[:6]))).all(axis=2), 0, 255).astype(
                np.uint8
            )
    if alpha is None:
        return np.ascontiguousarray(rgb)
    alpha16 = alpha.astype(np.uint16)[..., None]
    return np.concatenate([rgb * alpha16, alpha16 * 255], axis=2)
