"""Pages, fit, alignment, rotation and the one px ↔ mm mapping (with its Y flip)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.errors import PencilbotError
from pencilbot.planning.layout import Layout, page_size


@pytest.mark.parametrize(
    "name, size", [("A5", (148, 210)), ("a4", (210, 297)), ("A3", (297, 420)), ("letter", (215.9, 279.4))]
)
def test_named_pages_in_both_orientations(name, size):
    assert (page_size(name).width, page_size(name).height) == size
    land = page_size(name, "landscape")
    assert (land.width, land.height) == size[::-1]
    assert page_size(name, "portrait").width == size[0]


def test_custom_size_is_taken_as_typed_unless_orientation_is_asked():
    assert (page_size("300x200").width, page_size("300x200").height) == (300, 200)
    assert page_size("300 x 200", "portrait").width == 200
    assert page_size("120.5X80", margin=5).width == 120.5


def test_auto_orientation_follows_the_image():
    assert page_size("A4", "auto", image_shape=(100, 300)).width == 297
    assert page_size("A4", "auto", image_shape=(300, 100)).width == 210
    with pytest.raises(PencilbotError, match="image size"):
        page_size("A4", "auto")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(name="B7"), "unknown page size 'B7'.*A4"),
        (dict(name="A4", orientation="sideways"), "unknown orientation"),
        (dict(name="A4", margin=105), "margin 105"),
        (dict(name="A4", margin=-1), "margin -1"),
        (dict(name="0x100"), "no area"),
    ],
)
def test_bad_pages_are_user_errors(kwargs, message):
    with pytest.raises(PencilbotError, match=message):
        page_size(**kwargs)


def test_fit_fills_the_limiting_side_and_centres():
    page = page_size("A4", margin=15)  # free area 180 x 267 mm
    wide = Layout.fit((100, 200), page)  # 2:1 image: width limits
    assert wide.mm_per_px == pytest.approx(0.9)
    assert wide.drawing_box == pytest.approx((15, 103.5, 195, 193.5))
    tall = Layout.fit((400, 100), page)  # 4:1 tall image: height limits
    x0, y0, x1, y1 = tall.drawing_box
    assert (y0, y1) == pytest.approx((15, 282)) and (x0 + x1) / 2 == pytest.approx(105)


def test_y_flip_image_top_left_lands_top_left_of_the_box():
    layout = Layout.fit((100, 200), page_size("A4"))
    x0, y0, x1, y1 = layout.drawing_box
    s = layout.mm_per_px
    corners = layout.px_to_mm([[-0.5, -0.5], [199.5, 99.5]])  # outer corners of the image
    np.testing.assert_allclose(corners, [[x0, y1], [x1, y0]])
    # pixel (row 0, col 0) centre is half a pixel in from the top-left corner
    np.testing.assert_allclose(layout.px_to_mm([[0, 0]]), [[x0 + s / 2, y1 - s / 2]])
    # going down the image (row +1) goes down the page (y −)
    step = layout.px_to_mm([[10, 11]]) - layout.px_to_mm([[10, 10]])
    np.testing.assert_allclose(step, [[0, -s]])


def test_mm_to_px_flips_back():
    layout = Layout.fit((100, 200), page_size("A4"))
    x0, y0, x1, y1 = layout.drawing_box
    np.testing.assert_allclose(layout.mm_to_px([[x0, y1], [x1, y0]]), [[-0.5, -0.5], [199.5, 99.5]])


@pytest.mark.parametrize(
    "align, expect",
    [
        ("top-left", (15, None, None, 282)),
        ("bottom", (None, 15, None, None)),
        ("right", (None, None, 195, None)),
    ],
)
def test_alignment_moves_the_box_to_the_margin(align, expect):
    box = Layout.fit((300, 300), page_size("A4"), align=align).drawing_box
    for got, want in zip(box, expect):
        if want is not None:
            assert got == pytest.approx(want)


def test_rotate_90_turns_the_picture_counter_clockwise():
    layout = Layout.fit((100, 200), page_size("A4"), rotate=90)
    x0, y0, x1, y1 = layout.drawing_box
    assert (x1 - x0) / (y1 - y0) == pytest.approx(0.5)  # the wide image now stands tall
    # the image's top-left corner goes to the box's bottom-left after a quarter turn CCW
    np.testing.assert_allclose(layout.px_to_mm([[-0.5, -0.5]]), [[x0, y0]])
    # and its top-right corner to the top-left
    np.testing.assert_allclose(layout.px_to_mm([[199.5, -0.5]]), [[x0, y1]])


@settings(max_examples=60, deadline=None)
@given(
    h=st.integers(1, 3000),
    w=st.integers(1, 3000),
    rotate=st.sampled_from([0, 90, 180, 270, -90]),
    align=st.sampled_from(["center", "top-left", "bottom-right", "top", "left"]),
    name=st.sampled_from(["A5", "A4", "A3", "Letter", "500x80"]),
    orientation=st.sampled_from([None, "portrait", "landscape"]),
    margin=st.floats(0, 30),
    pts=st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=1, max_size=20),
)
def test_mapping_round_trips_and_stays_inside_the_margins(
    h, w, rotate, align, name, orientation, margin, pts
):
    page = page_size(name, orientation, margin=margin)
    layout = Layout.fit((h, w), page, align=align, rotate=rotate)
    px = np.array(pts) * [w, h] - 0.5  # anywhere on the image
    mm = layout.px_to_mm(px)
    np.testing.assert_allclose(layout.mm_to_px(mm), px, atol=1e-6 * max(h, w))
    eps = 1e-9 * max(page.width, page.height)
    x0, y0, x1, y1 = layout.drawing_box
    assert np.all((mm[:, 0] >= x0 - eps) & (mm[:, 0] <= x1 + eps))
    assert np.all((mm[:, 1] >= y0 - eps) & (mm[:, 1] <= y1 + eps))
    assert margin - eps <= x0 and x1 <= page.width - margin + eps
    assert margin - eps <= y0 and y1 <= page.height - margin + eps
    # the limiting side touches both margins
    free = (page.width - 2 * margin, page.height - 2 * margin)
    assert max((x1 - x0) / free[0], (y1 - y0) / free[1]) == pytest.approx(1.0)


@pytest.mark.parametrize(
    "kwargs, message", [(dict(rotate=45), "rotation 45"), (dict(align="diagonal"), "alignment")]
)
def test_bad_fit_options_are_user_errors(kwargs, message):
    with pytest.raises(PencilbotError, match=message):
        Layout.fit((10, 10), page_size("A4"), **kwargs)
