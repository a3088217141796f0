"""A PNG shrunk while it is read (pencilbot.imaging.png_strips): the same samples as the whole
decode shrunk afterwards, for every pixel format it takes, a strip at a time; the formats it does
not take are left to the whole decode; a big PNG loads with --downscale under a memory limit."""

from __future__ import annotations

import json
import os
import resource
import struct
import subprocess
import sys
import zlib

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from pencilbot.errors import ImageLoadError
from pencilbot.imaging import io as image_io
from pencilbot.imaging import png_strips
from pencilbot.imaging.io import load_image


def _image(kind: str, pixels: np.ndarray) -> tuple[Image.Image, dict]:
    """A Pillow image of ``kind`` from random bytes (H, W, 4), and its save options."""
    rgb, alpha = pixels[..., :3], pixels[..., 3]
    if kind == "RGB":
        return Image.fromarray(rgb), {}
    if kind == "RGBA":
        return Image.fromarray(pixels, "RGBA"), {}
    if kind == "L":
        return Image.fromarray(rgb[..., 0]), {}
    if kind == "LA":
        return Image.merge("LA", [Image.fromarray(rgb[..., 0]), Image.fromarray(alpha)]), {}
    if kind == "1":
        return Image.fromarray(rgb[..., 0] > 127), {}
    if kind == "I;16":
        return Image.fromarray(rgb[..., 0].astype(np.uint16) * 257 + alpha), {}
    if kind == "L key":
        return Image.fromarray(rgb[..., 0] // 32 * 32), {"transparency": 64}
    if kind == "RGB key":
        return Image.fromarray(rgb // 128 * 128), {"transparency": (128, 0, 128)}
    colours = {"P8": 256, "P4": 16, "P2": 4, "P1": 2}.get(kind.split()[0], 256)
    image = Image.fromarray(rgb).quantize(colours)
    options = {"bits": {"P4": 4, "P2": 2, "P1": 1}[kind.split()[0]]} if kind.split()[0] != "P8" else {}
    if kind.endswith("alpha"):
        options["transparency"] = bytes(range(0, 256, 256 // colours))[:colours]
    return image, options


KINDS = [
    "RGB",
    "RGBA",
    "L",
    "LA",
    "1",
    "I;16",
    "L key",
    "RGB key",
    "P8",
    "P4",
    "P2",
    "P1",
    "P8 alpha",
    "P4 alpha",
]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    kind=st.sampled_from(KINDS),
    factor=st.integers(2, 4),
    blocks=st.tuples(st.integers(1, 12), st.integers(1, 12)),
    seed=st.integers(0, 2**32 - 1),
    strip=st.integers(1, 3000),
    writer=st.sampled_from(["pillow", "opencv"]),
)
def test_strips_give_the_whole_decode_shrunk(tmp_path_factory, kind, factor, blocks, seed, strip, writer):
    height, width = blocks[0] * factor, blocks[1] * factor
    rng = np.random.default_rng(seed)
    smooth = cv2.resize(
        rng.integers(0, 256, (3, 3, 4), dtype=np.uint8), (width, height), interpolation=cv2.INTER_LINEAR
    )
    pixels = np.where(
        rng.random((height, width, 1)) < 0.3, rng.integers(0, 256, (height, width, 4), dtype=np.uint8), smooth
    )
    path = tmp_path_factory.mktemp("png") / "p.png"
    image, options = _image(kind, pixels)
    if writer == "opencv" and kind in ("RGB", "L", "RGBA"):  # libpng's own choice of filters (Paeth, ...)
        array = np.asarray(image)
        cv2.imwrite(
            str(path),
            cv2.cvtColor(array, cv2.COLOR_RGB2BGR)
            if kind == "RGB"
            else cv2.cvtColor(array, cv2.COLOR_RGBA2BGRA)
            if kind == "RGBA"
            else array,
        )
    else:
        image.save(path, **options)
    layout = png_strips.png_layout(path)
    assert layout is not None
    with Image.open(path) as whole:
        whole.load()
        expected = image_io._reduce(image_io._samples(whole), (width // factor, height // factor))
    old = png_strips.STRIP_BYTES
    png_strips.STRIP_BYTES = strip  # many strips, some of one block of rows
    try:
        got = png_strips.reduced_png(path, layout, factor)
    finally:
        png_strips.STRIP_BYTES = old
    assert got.dtype == expected.dtype and got.shape == expected.shape
    assert np.array_equal(got, expected)


def test_a_height_that_is_no_multiple_of_the_factor_keeps_its_last_rows(tmp_path):
    grey = np.zeros((10, 9), np.uint8)
    grey[9] = 255  # the last row alone in its block
    Image.fromarray(grey).save(tmp_path / "g.png")
    got = png_strips.reduced_png(tmp_path / "g.png", png_strips.png_layout(tmp_path / "g.png"), 3)
    assert got.shape == (4, 3, 3) and got[3].min() == 255 and got[:3].max() == 0


def test_formats_it_does_not_read_are_left_to_the_whole_decode(tmp_path):
    cv2.imwrite(str(tmp_path / "deep.png"), np.zeros((8, 8, 3), np.uint16))  # 16-bit colour
    Image.new("L", (8, 8)).save(tmp_path / "g.jpg")
    (tmp_path / "text.png").write_text("not a png")
    for name in ("deep.png", "g.jpg", "text.png"):
        assert png_strips.png_layout(tmp_path / name) is None


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def _write_grey_png(path, width: int, height: int, interlace: int = 0) -> None:
    """A grey PNG of ten horizontal bands (row y is 25 * (10 y // height)), a strip at a time."""
    squeeze = zlib.compressobj(1)
    with open(path, "wb") as out:
        out.write(
            b"\x89PNG\r\n\x1a\n"
            + _chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, interlace))
        )
        for top in range(0, height, 500):
            rows = np.arange(top, min(top + 500, height))
            body = np.empty((len(rows), width + 1), np.uint8)
            body[:, 0] = 0
            body[:, 1:] = (25 * (10 * rows // height))[:, None]
            out.write(_chunk(b"IDAT", squeeze.compress(body.tobytes())))
        out.write(_chunk(b"IDAT", squeeze.flush()) + _chunk(b"IEND", b""))


def test_an_interlaced_png_is_left_to_the_whole_decode(tmp_path):
    _write_grey_png(tmp_path / "i.png", 8, 8, interlace=1)
    assert png_strips.png_layout(tmp_path / "i.png") is None


def test_a_png_whose_pixels_end_early_is_one_message(tmp_path):
    _write_grey_png(tmp_path / "t.png", 400, 300)
    data = (tmp_path / "t.png").read_bytes()
    (tmp_path / "t.png").write_bytes(data[: len(data) // 2])
    with pytest.raises(
        ImageLoadError, match=r"could not be decoded \(its pixel data ends after \d+ of 300 rows\)"
    ):
        load_image(tmp_path / "t.png", max_pixels=1000, downscale=True)


LIMIT = 2 << 30  # bytes of address space the child may have, as tests/cli/test_cli_hostile.py
SIDE = 20_000  # 400 MP: the whole grey picture is 400 MB as bytes, 1.6 GB as Pillow's RGB


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT, LIMIT))


def test_a_400_megapixel_png_loads_downscaled_under_a_memory_limit(tmp_path):
    path = tmp_path / "big.png"
    _write_grey_png(path, SIDE, SIDE)
    # The peak is the child's own VmHWM (its ru_maxrss would start from this process's at the
    # fork), less its peak once the libraries are imported (which varies by 10 MB or so between
    # runs): what the load itself added.
    child = (
        "import json, re, sys\n"
        "from pencilbot.imaging.io import load_image\n"
        "hwm = lambda: int(re.search(r'VmHWM:\\s*(\\d+)', open('/proc/self/status').read())[1])\n"
        "base = hwm()\n"
        "image = load_image(sys.argv[1], max_pixels=250_000, downscale=True)\n"
        "bands = [float(image.gray[round((i + 0.5) * image.shape[0] / 10)].mean()) for i in range(10)]\n"
        "print(json.dumps({'shape': image.shape, 'bands': bands, 'added_mb': (hwm() - base) / 1024}))\n"
    )
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = subprocess.run(
        [sys.executable, "-c", child, str(path)],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=_limit_memory,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    said = json.loads(proc.stdout)
    assert said["shape"] == [500, 500]
    np.testing.assert_allclose(said["bands"], [25 * i / 255 for i in range(10)], atol=1e-6)
    # Loading added about 80 MB (strips of rows); the whole grey picture alone is 381 MB.
    assert said["added_mb"] < SIDE * SIDE / 2**20 / 3, said["added_mb"]
