"""The finished drawing R = L · T: range, composition, colour (chroma kept), determinism."""

import numpy as np
import pytest
import skimage.data
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch, with_luma

LUMA = np.array([0.299, 0.587, 0.114])


def chroma(rgb):
    """(B − Y, R − Y): U and V of Rec. 601 YUV up to constant factors."""
    y = rgb @ LUMA
    return np.stack([rgb[..., 2] - y, rgb[..., 0] - y], axis=-1)


@pytest.fixture(scope="module")
def coffee():
    return image_from_array(skimage.data.coffee(), source="coffee")


@pytest.fixture(scope="module")
def coffee_grey(coffee):
    return sketch(coffee)


def test_grey_sketch_is_line_drawing_times_texture_map(coffee, coffee_grey):
    s = coffee_grey
    assert s.result.dtype == np.float32 and s.result.shape == coffee.shape
    assert s.result.min() >= 0 and s.result.max() <= 1
    np.testing.assert_array_equal(s.result, s.line.drawing * s.T)
    for stage in (s.tone, s.texture, s.beta, s.T):
        assert stage.shape == coffee.shape
    assert list(s.timings) == ["edges", "lines", "tone", "texture", "beta", "compose"]
    assert all(t >= 0 for t in s.timings.values())
    assert s.fit.residual <= 1e-3 and s.fit.iterations > 0


def test_sketch_reads_as_pencil(coffee, coffee_grey):
    gray, R = coffee.gray, coffee_grey.result
    bright = gray >= np.quantile(gray, 0.9)
    dark = gray <= np.quantile(gray, 0.1)
    # Paper-white highlights (the contours that bound them, such as the cup's rim, are drawn
    # as strong as they are), graphite (not black) in the shadows, textured mid-tones.
    assert R[bright & (coffee_grey.line.drawing == 1)].mean() > 0.95
    assert 0.1 < R[dark].mean() < 0.5
    mid = (gray > np.quantile(gray, 0.4)) & (gray < np.quantile(gray, 0.6))
    assert R[mid].std() > 0.05


def assert_luma_replaced_chroma_kept(rgb, luma, out, atol):
    """Luma exact everywhere; chroma equal where the photo's colour exists at the new luma,
    elsewhere the same hue at lower saturation."""
    assert out.dtype == np.float32 and out.min() >= 0 and out.max() <= 1
    np.testing.assert_allclose(out @ LUMA, luma, atol=atol)
    c_in, c_out = chroma(rgb.astype(np.float64)), chroma(out.astype(np.float64))
    shifted = rgb + (luma - rgb @ LUMA)[..., None]
    fits = np.all((shifted >= 0) & (shifted <= 1), axis=-1)
    np.testing.assert_allclose(c_out[fits], c_in[fits], atol=atol)
    cross = c_out[..., 0] * c_in[..., 1] - c_out[..., 1] * c_in[..., 0]
    np.testing.assert_allclose(cross, 0, atol=atol)
    assert np.all((c_out * c_in).sum(-1) >= -atol)
    assert np.all(np.linalg.norm(c_out, axis=-1) <= np.linalg.norm(c_in, axis=-1) + atol)
    return fits


def test_colour_sketch_keeps_the_photos_chroma(coffee, coffee_grey):
    s = sketch(coffee, color=True)
    assert s.result.shape == coffee.rgb.shape
    fits = assert_luma_replaced_chroma_kept(coffee.rgb, coffee_grey.result, s.result, atol=5e-6)
    # Coffee is a saturated orange photo drawn much lighter: many colours do not exist at the
    # drawing's luma, but a good share keeps its chroma exactly.
    assert 0.2 < fits.mean() < 1


@settings(max_examples=60, deadline=None)
@given(
    arrays(np.float32, (5, 7, 3), elements=st.floats(0, 1, width=32)),
    arrays(np.float32, (5, 7), elements=st.floats(0, 1, width=32)),
)
def test_with_luma_replaces_luma_and_keeps_chroma(rgb, luma):
    assert_luma_replaced_chroma_kept(rgb, luma, with_luma(rgb, luma), atol=1e-5)


def test_grey_photo_in_colour_stays_grey():
    img = image_from_array(skimage.data.camera(), source="camera")
    grey, colour = sketch(img), sketch(img, color=True)
    for channel in range(3):
        np.testing.assert_allclose(colour.result[..., channel], grey.result, atol=2e-6)


def test_lines_only_has_no_tone_stage(coffee, coffee_grey):
    s = sketch(coffee, lines_only=True)
    np.testing.assert_array_equal(s.result, coffee_grey.line.drawing)
    assert s.tone is None and s.texture is None and s.beta is None and s.T is None
    assert list(s.timings) == ["edges", "lines", "compose"]


def test_deterministic_and_seeded(coffee, coffee_grey):
    again = sketch(coffee)
    np.testing.assert_array_equal(again.result, coffee_grey.result)
    other = sketch(coffee, texture_seed=1)
    np.testing.assert_array_equal(other.line.drawing, coffee_grey.line.drawing)
    np.testing.assert_array_equal(other.tone, coffee_grey.tone)
    assert np.abs(other.result - coffee_grey.result).mean() > 0.01


def test_line_length_is_passed_through(coffee):
    assert sketch(coffee, line_length=11, lines_only=True).line.length == 11


def test_a_tiny_photo_is_not_drawn_solid_black():
    # This dark 2×2 crop used to come out 0 everywhere: the 3-pixel dilation gave E = 1 at every
    # pixel and the strokes' normalisation made each the darkest one.
    crop = image_from_array(skimage.data.astronaut()[200:202, 200:202], source="crop")
    s = sketch(crop)
    assert s.result.shape == (2, 2) and s.line.labels.shape == (2, 2)
    assert s.line.drawing.min() > 0.5 and s.result.min() > 0.3
    np.testing.assert_array_equal(s.result, s.line.drawing * s.T)
    # ... and the drawing still follows the photo's tone.
    checker = sketch(image_from_array(np.array([[0, 255], [255, 0]], np.uint8)))
    assert checker.result[0, 1] > checker.result[0, 0] + 0.3
    lines = sketch(crop, lines_only=True)
    assert lines.result.min() > 0.5 and lines.T is None


@settings(max_examples=25, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 8), st.integers(1, 8), st.just(3))))
def test_tiny_photos_keep_their_size_and_mostly_paper_lines(arr):
    s = sketch(image_from_array(arr), color=True)
    assert s.result.shape == arr.shape and s.tone.shape == arr.shape[:2]
    assert s.line.drawing.mean() > 0.7  # lines where the photo changes, not everywhere
    np.testing.assert_allclose(s.result @ LUMA, s.line.drawing * s.T, atol=2e-3)
