"""Image loading: every pixel format we promise, and every bad input giving ImageLoadError."""

import io

import cv2
import numpy as np
import pytest
import skimage.data
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image

from pencilbot.errors import ImageLoadError
from pencilbot.imaging import io as image_io
from pencilbot.imaging.io import LUMA_601, LoadedImage, image_from_array, load_image


def save(tmp_path, img, name, **kwargs):
    path = tmp_path / name
    img.save(path, **kwargs)
    return path


def test_grey_png_values_exact(tmp_path):
    grey = np.arange(256, dtype=np.uint8).reshape(16, 16)
    loaded = load_image(save(tmp_path, Image.fromarray(grey), "g.png"))
    assert loaded.gray.dtype == np.float32 and loaded.rgb.dtype == np.float32
    np.testing.assert_allclose(loaded.gray, grey / 255.0, atol=1e-6)
    np.testing.assert_allclose(loaded.rgb, np.dstack([grey / 255.0] * 3), atol=1e-6)


def test_rgb_png_grey_is_rec601_luma(tmp_path):
    rgb = np.zeros((2, 3, 3), dtype=np.uint8)
    rgb[0, 0] = (255, 0, 0)
    rgb[0, 1] = (0, 255, 0)
    rgb[0, 2] = (0, 0, 255)
    rgb[1] = (10, 200, 90)
    loaded = load_image(save(tmp_path, Image.fromarray(rgb), "c.png"))
    np.testing.assert_allclose(loaded.rgb, rgb / 255.0, atol=1e-6)
    np.testing.assert_allclose(loaded.gray[0], [0.299, 0.587, 0.114], atol=1e-6)
    np.testing.assert_allclose(loaded.gray[1, 0], (0.299 * 10 + 0.587 * 200 + 0.114 * 90) / 255, atol=1e-6)


def test_rgba_composited_on_white_paper(tmp_path):
    rgba = np.zeros((1, 3, 4), dtype=np.uint8)
    rgba[0, 0] = (0, 0, 0, 0)  # fully transparent black: blank paper
    rgba[0, 1] = (0, 0, 0, 255)  # opaque black
    rgba[0, 2] = (0, 0, 0, 102)  # 40 % black
    loaded = load_image(save(tmp_path, Image.fromarray(rgba, "RGBA"), "a.png"))
    np.testing.assert_allclose(loaded.gray[0], [1.0, 0.0, 0.6], atol=1e-6)


def test_palette_with_transparency(tmp_path):
    img = Image.new("P", (4, 1))
    img.putpalette([0, 0, 0, 255, 0, 0] + [0] * 762)
    img.putdata([0, 1, 1, 0])
    img.info["transparency"] = 0  # palette index 0 (black) is transparent
    loaded = load_image(save(tmp_path, img, "p.png", transparency=0))
    np.testing.assert_allclose(loaded.rgb[0, 0], [1, 1, 1], atol=1e-6)
    np.testing.assert_allclose(loaded.rgb[0, 1], [1, 0, 0], atol=1e-6)


def test_sixteen_bit_grey_keeps_precision(tmp_path):
    values = np.array([[0, 1000, 1001, 65535]], dtype=np.uint16)  # 1000/1001 collapse at 8 bits
    loaded = load_image(save(tmp_path, Image.fromarray(values), "g16.png"))
    np.testing.assert_allclose(loaded.gray[0], values[0] / 65535.0, rtol=1e-6, atol=1e-7)
    assert loaded.gray[0, 1] != loaded.gray[0, 2]


@pytest.mark.parametrize(("orientation", "dark_side"), [(1, "left"), (3, "right"), (6, "top"), (8, "bottom")])
def test_exif_orientation_applied(tmp_path, orientation, dark_side):
    # Stored 64 wide × 32 high, left half black. Orientation 6 = "rotate 90° clockwise to view".
    stored = np.full((32, 64, 3), 255, dtype=np.uint8)
    stored[:, :32] = 0
    exif = Image.Exif()
    exif[0x0112] = orientation
    loaded = load_image(save(tmp_path, Image.fromarray(stored), "o.jpg", exif=exif, quality=95))
    gray = loaded.gray
    assert gray.shape == ((32, 64) if orientation in (1, 3) else (64, 32))
    h, w = gray.shape
    halves = {
        "left": gray[:, : w // 2],
        "right": gray[:, w // 2 :],
        "top": gray[: h // 2],
        "bottom": gray[h // 2 :],
    }
    assert halves[dark_side].mean() < 0.05


def test_too_large_refused_before_decoding(tmp_path):
    path = save(tmp_path, Image.new("L", (100, 60)), "big.png")
    with pytest.raises(ImageLoadError, match=r"100×60.*--downscale"):
        load_image(path, max_pixels=5000)


@pytest.mark.parametrize("limit", [0, -5])
def test_a_pixel_limit_below_one_is_refused_not_a_one_pixel_photo(tmp_path, limit):
    path = save(tmp_path, Image.new("L", (100, 60)), "photo.png")
    with pytest.raises(ImageLoadError, match=f"--max-pixels must be at least 1, got {limit}"):
        load_image(path, max_pixels=limit, downscale=True)


@pytest.mark.parametrize("suffix", ["png", "jpg"])
def test_downscale_fits_limit_and_keeps_aspect(tmp_path, suffix):
    img = np.zeros((600, 900, 3), dtype=np.uint8)
    img[:, 450:] = 255
    loaded = load_image(
        save(tmp_path, Image.fromarray(img), f"big.{suffix}"), max_pixels=20_000, downscale=True
    )
    h, w = loaded.gray.shape
    assert h * w <= 20_000
    assert abs(w / h - 1.5) < 0.05
    assert loaded.gray[:, : w // 2 - 2].mean() < 0.05 and loaded.gray[:, w // 2 + 2 :].mean() > 0.95


def test_missing_file(tmp_path):
    with pytest.raises(ImageLoadError, match="no such file"):
        load_image(tmp_path / "nope.png")


def test_directory(tmp_path):
    with pytest.raises(ImageLoadError, match="directory"):
        load_image(tmp_path)


def test_empty_file(tmp_path):
    (tmp_path / "e.png").write_bytes(b"")
    with pytest.raises(ImageLoadError, match="empty"):
        load_image(tmp_path / "e.png")


def test_not_an_image(tmp_path):
    (tmp_path / "t.png").write_text("this is a shopping list, not a picture\n")
    with pytest.raises(ImageLoadError, match="not an image"):
        load_image(tmp_path / "t.png")


@pytest.mark.parametrize("fmt", ["PNG", "JPEG"])
def test_truncated_file(tmp_path, fmt):
    buffer = io.BytesIO()
    Image.fromarray(skimage.data.astronaut()).save(buffer, format=fmt)
    data = buffer.getvalue()
    (tmp_path / "cut").write_bytes(data[: len(data) // 2])
    with pytest.raises(ImageLoadError, match="truncated"):
        load_image(tmp_path / "cut")


def test_image_from_array_skimage_photo():
    loaded = image_from_array(skimage.data.coffee(), source="coffee")
    assert isinstance(loaded, LoadedImage)
    assert loaded.shape == (400, 600) and loaded.rgb.shape == (400, 600, 3)
    assert loaded.source == "coffee"


@pytest.mark.parametrize(
    "arr",
    [np.zeros((4, 4, 2)), np.zeros((0, 5)), np.zeros(5), np.full((3, 3), 1.5), np.zeros((3, 3), np.int64)],
)
def test_image_from_array_rejects(arr):
    with pytest.raises(ImageLoadError):
        image_from_array(arr)


@settings(max_examples=40, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 9), st.integers(1, 9), st.sampled_from([1, 3, 4]))))
def test_image_from_array_invariants(arr):
    loaded = image_from_array(arr)
    h, w = arr.shape[:2]
    assert loaded.gray.shape == (h, w) and loaded.rgb.shape == (h, w, 3)
    assert loaded.gray.dtype == np.float32
    assert loaded.gray.min() >= 0.0 and loaded.gray.max() <= 1.0
    np.testing.assert_allclose(loaded.gray, loaded.rgb @ LUMA_601, atol=1e-5)
    if arr.shape[2] == 4:  # transparency only ever lightens toward paper
        opaque = arr[:, :, :3].astype(np.float32) / 255 @ LUMA_601
        assert np.all(loaded.gray >= opaque - 1e-5)


def photo(shape=(480, 640)):
    return cv2.resize(skimage.data.astronaut(), shape[::-1], interpolation=cv2.INTER_CUBIC)


@pytest.mark.parametrize(("suffix", "tolerance"), [("png", 1.5 / 255), ("jpg", 0.02)])
def test_shrink_to_decodes_at_the_size_asked_for_and_matches_shrinking_after(tmp_path, suffix, tolerance):
    path = save(
        tmp_path, Image.fromarray(photo()), f"p.{suffix}", **({"quality": 95} if suffix == "jpg" else {})
    )
    asked = []

    def half(shape):
        asked.append(shape)
        return shape[0] // 2 - 1, shape[1] // 2 - 1

    small = load_image(path, shrink_to=half)
    full = load_image(path)
    assert asked == [(480, 640)] and small.shape == (239, 319)
    after = cv2.resize(full.rgb, (319, 239), interpolation=cv2.INTER_AREA)
    assert np.abs(small.rgb - after).mean() < tolerance
    np.testing.assert_allclose(small.gray, small.rgb @ LUMA_601, atol=1e-5)


def test_shrink_to_sees_the_upright_size_of_a_turned_jpeg(tmp_path):
    exif = Image.Exif()
    exif[0x0112] = 6  # stored 640 wide, viewed 480 wide
    path = save(tmp_path, Image.fromarray(photo()), "t.jpg", exif=exif, quality=95)
    asked = []
    small = load_image(path, shrink_to=lambda shape: asked.append(shape) or (160, 120))
    assert asked == [(640, 480)] and small.shape == (160, 120)


def test_shrinking_a_transparent_image_mixes_in_paper_not_hidden_colour(tmp_path):
    rgba = np.zeros((40, 40, 4), np.uint8)
    rgba[..., 3] = 255
    rgba[::2, :, :3] = 0  # opaque black rows ...
    rgba[1::2, :, 3] = 0  # ... between fully transparent (hidden black) rows: blank paper
    small = load_image(save(tmp_path, Image.fromarray(rgba, "RGBA"), "t.png"), shrink_to=lambda s: (20, 20))
    np.testing.assert_allclose(small.gray, 0.5, atol=1 / 255)


def test_sixteen_bit_grey_keeps_its_precision_when_shrunk(tmp_path):
    values = np.full((8, 8), 1000, np.uint16)
    values[:, 4:] = 1001
    small = load_image(save(tmp_path, Image.fromarray(values), "g16.png"), shrink_to=lambda s: (4, 4))
    np.testing.assert_allclose(small.gray[:, :2], 1000 / 65535, rtol=1e-6)
    np.testing.assert_allclose(small.gray[:, 2:], 1001 / 65535, rtol=1e-6)


def test_pillow_decompression_bomb_checks_give_way_to_ours(tmp_path, monkeypatch, recwarn):
    # Pretend the photo is past Pillow's bomb thresholds (a warning at 1 000, an error at 2 000).
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 1000)
    path = save(tmp_path, Image.new("L", (100, 60), 128), "big.png")
    assert load_image(path).shape == (60, 100)  # within our limit: loads, Pillow says nothing
    with pytest.raises(ImageLoadError, match=r"100×60 = 6,000 pixels, more than the limit of 5,000"):
        load_image(path, max_pixels=5000)
    assert not [w for w in recwarn if issubclass(w.category, Image.DecompressionBombWarning)]
    assert Image.MAX_IMAGE_PIXELS == 1000  # Pillow's setting is left as it was


def test_too_many_pixels_to_decode_even_with_downscale_is_one_message(tmp_path, monkeypatch):
    monkeypatch.setattr(image_io, "DECODE_LIMIT", 5000)
    path = save(tmp_path, Image.new("L", (100, 60)), "big.bmp")  # BMP cannot decode at a reduced scale
    with pytest.raises(ImageLoadError, match=r"decoding more than 5,000 is unsafe.*image editor"):
        load_image(path, max_pixels=1000, downscale=True)
    deep = tmp_path / "deep.png"  # nor a 16-bit colour PNG (read whole, as Pillow reads it)
    cv2.imwrite(str(deep), np.zeros((60, 100, 3), np.uint16))
    with pytest.raises(ImageLoadError, match=r"decoding more than 5,000 is unsafe"):
        load_image(deep, max_pixels=1000, downscale=True)
    png = save(tmp_path, Image.new("L", (100, 60)), "big.png")  # an 8-bit PNG can: read in strips
    height, width = load_image(png, max_pixels=1000, downscale=True).shape
    assert height * width <= 1000
    jpeg = save(tmp_path, Image.new("L", (400, 240)), "big.jpg")  # JPEG can: 1/8 scale is 1 500
    height, width = load_image(jpeg, max_pixels=1000, downscale=True).shape
    assert height * width <= 1000


def test_a_multi_frame_file_gives_its_first_frame_and_says_so(tmp_path, caplog):
    frames = [Image.new("L", (8, 8), value) for value in (0, 255, 128)]
    path = tmp_path / "anim.gif"
    frames[0].save(path, save_all=True, append_images=frames[1:])
    with caplog.at_level("WARNING", logger="pencilbot.imaging.io"):
        loaded = load_image(path)
    np.testing.assert_allclose(loaded.gray, 0.0, atol=1e-6)
    assert "holds 3 frames" in caplog.text and "first only" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="pencilbot.imaging.io"):
        load_image(save(tmp_path, frames[0], "still.gif"))
    assert caplog.text == ""
