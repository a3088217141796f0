"""Lu's stroke step: kernels, direction labels, stroke extent, and the LineDrawing contract."""

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.errors import PencilbotError
from pencilbot.imaging.gmed import edge_map
from pencilbot.imaging.strokes import (
    LONGEST_LENGTH,
    STROKE_FLOOR,
    LineDrawing,
    default_line_length,
    line_drawing,
    line_kernels,
)


def principal_angle(kernel):
    """Orientation of a kernel's weight distribution, degrees CCW from +x on screen, in [0, 180)."""
    n = kernel.shape[0]
    rows, cols = np.mgrid[0:n, 0:n] - (n - 1) / 2
    x, y = cols, -rows  # y up, as seen on screen
    w = kernel / kernel.sum()
    cxx, cyy, cxy = (w * x * x).sum(), (w * y * y).sum(), (w * x * y).sum()
    return math.degrees(0.5 * math.atan2(2 * cxy, cxx - cyy)) % 180


@pytest.mark.parametrize("length", [6, 9, 13])
@pytest.mark.parametrize("width", [1.0, 2.0])
def test_kernels_equal_sum_symmetric_and_oriented(length, width):
    kernels = line_kernels(length, width)
    assert kernels.shape[0] == 8 and kernels.shape[1] == kernels.shape[2] and kernels.shape[1] % 2 == 1
    np.testing.assert_allclose(kernels.sum(axis=(1, 2)), 1.0, rtol=1e-5)
    np.testing.assert_allclose(kernels, kernels[:, ::-1, ::-1], atol=1e-7)  # point-symmetric
    for k, kernel in enumerate(kernels):
        diff = (principal_angle(kernel) - 22.5 * k + 90) % 180 - 90
        assert abs(diff) < 1.0, (k, principal_angle(kernel))


def test_kernel_length_along_its_direction():
    kernels = line_kernels(9)
    centre = kernels.shape[1] // 2
    horizontal = kernels[0][centre]  # k = 0: the middle row carries the whole line
    assert np.count_nonzero(horizontal > 1e-6) == 9
    vertical = kernels[4][:, centre]
    assert np.count_nonzero(vertical > 1e-6) == 9


def draw_line(shape, angle_deg, centre, half_length, thickness=2):
    img = np.zeros(shape, np.uint8)
    theta = math.radians(angle_deg)
    dx, dy = math.cos(theta) * half_length, -math.sin(theta) * half_length  # row down
    shift = 4  # sub-pixel endpoints
    p0 = (round((centre[0] - dx) * 2**shift), round((centre[1] - dy) * 2**shift))
    p1 = (round((centre[0] + dx) * 2**shift), round((centre[1] + dy) * 2**shift))
    cv2.line(img, p0, p1, 255, thickness, cv2.LINE_AA, shift)
    return img.astype(np.float32) / 255


@settings(max_examples=40, deadline=None)
@given(k=st.integers(0, 7), length=st.integers(6, 13), offset=st.tuples(st.floats(-3, 3), st.floats(-3, 3)))
def test_straight_line_at_k_is_labelled_k(k, length, offset):
    centre = (60 + offset[0], 60 + offset[1])  # (col, row)
    E = draw_line((121, 121), 22.5 * k, centre, half_length=45)
    labels = line_drawing(E, length=length).labels
    # Pixels on the line's core, away from its ends.
    rows, cols = np.nonzero(E > 0.9)
    near_middle = np.hypot(cols - centre[0], rows - centre[1]) < 30
    assert near_middle.sum() > 20
    assert np.all(labels[rows[near_middle], cols[near_middle]] == k)


def test_drawing_darkest_along_edges_of_a_shape():
    yy, xx = np.mgrid[0:120, 0:120]
    disk = np.where((yy - 60) ** 2 + (xx - 60) ** 2 < 35**2, 0.2, 0.9).astype(np.float32)
    line = line_drawing(edge_map(disk), length=9)
    dist = np.abs(np.hypot(yy - 60, xx - 60) - 35)
    assert line.drawing[dist < 1.5].mean() < 0.6
    assert np.all(line.drawing[dist > 12] == 1.0)  # far from the contour: clean paper
    assert line.drawing.min() == 0.0  # a clear-cut contour (E = 1) is black


@pytest.mark.parametrize("length", [6, 10, 13])
def test_stroke_extends_half_length_past_segment_ends(length):
    E = np.zeros((41, 101), np.float32)
    E[20, 30:71] = 1.0  # horizontal segment, columns 30..70
    drawing = line_drawing(E, length=length).drawing
    dark = np.nonzero(drawing[20] < 0.999)[0]
    reach = length / 2
    assert dark.min() >= 30 - math.ceil(reach) and dark.max() <= 70 + math.ceil(reach)
    assert dark.min() <= 30 - math.floor(reach) + 1 and dark.max() >= 70 + math.floor(reach) - 1
    assert np.all(drawing[:17] == 1.0) and np.all(drawing[24:] == 1.0)  # thin: no spread across


def test_contract_fields_and_B_partition():
    rng = np.random.default_rng(5)
    E = edge_map(rng.random((50, 60), dtype=np.float32))
    line = line_drawing(E, length=7, width=1.5, gamma=1.0)
    assert isinstance(line, LineDrawing) and line.length == 7
    assert line.drawing.dtype == np.float32 and line.drawing.shape == E.shape
    assert line.drawing.min() >= 0.0 and line.drawing.max() <= 1.0
    assert line.labels.dtype == np.uint8 and line.labels.max() <= 7
    np.testing.assert_array_equal(line.edges, E)
    parts = [line.B(i) for i in range(8)]
    np.testing.assert_allclose(sum(parts), E, atol=1e-7)
    for i, part in enumerate(parts):
        assert part.dtype == np.float32
        assert not np.any(part[line.labels != i])
    with pytest.raises(ValueError):
        line.B(8)


def test_deterministic_and_gamma():
    rng = np.random.default_rng(9)
    E = edge_map(rng.random((40, 40), dtype=np.float32))
    a, b = line_drawing(E), line_drawing(E)
    np.testing.assert_array_equal(a.drawing, b.drawing)
    np.testing.assert_array_equal(a.labels, b.labels)
    np.testing.assert_allclose(line_drawing(E, gamma=2.0).drawing, a.drawing**2, atol=1e-6)


def _segment(strength, row=20, shape=(41, 101)):
    E = np.zeros(shape, np.float32)
    E[row, 30:71] = strength
    return E


def test_stroke_darkness_is_absolute_not_divided_by_the_strongest():
    # Along a straight run S = E: a stroke is 1 − (E − floor) / (1 − floor) light, whether or not
    # a stronger one is in the picture (Lu's S / max S made the weak one black when alone).
    weak = line_drawing(_segment(0.55), length=9).drawing
    expected = 1 - (0.55 - STROKE_FLOOR) / (1 - STROKE_FLOOR)
    assert weak[20, 50] == pytest.approx(expected, abs=1e-4)
    both = _segment(0.55)
    both[10, 30:71] = 1.0
    drawing = line_drawing(both, length=9).drawing
    assert drawing[20, 50] == pytest.approx(expected, abs=1e-4) and drawing[10, 50] == 0.0
    # Below the stroke floor: paper.
    assert np.all(line_drawing(_segment(0.9 * STROKE_FLOOR), length=9).drawing == 1.0)


def test_a_wider_stroke_is_wider_and_as_dark():
    thin = line_drawing(_segment(1.0), length=9, width=1.0).drawing
    wide = line_drawing(_segment(1.0), length=9, width=3.0).drawing
    assert thin[:, 50].min() == 0.0 and wide[:, 50].min() == 0.0
    assert np.count_nonzero(wide[:, 50] < 0.5) >= np.count_nonzero(thin[:, 50] < 0.5) + 2


@pytest.mark.parametrize("gamma", [0.5, 1.0, 2.5])
def test_edge_strength_inverts_the_tone_curve(gamma):
    probe = line_drawing(np.zeros((5, 5), np.float32), gamma=gamma)
    for darkness in (0.2, 0.5, 0.8):
        strength = probe.edge_strength(darkness)
        drawing = line_drawing(_segment(strength), length=9, gamma=gamma).drawing
        assert 1 - drawing[20, 50] == pytest.approx(darkness, abs=1e-3)
    # γ > 1 darkens: a fainter edge reaches the same darkness.
    if gamma > 1:
        assert probe.edge_strength(0.5) < line_drawing(np.zeros((5, 5), np.float32)).edge_strength(0.5)


def test_contours_do_not_fade_with_resolution():
    # The same photo at 0.26 MP and (upsampled) 2.4 MP: the line drawing is about as dark.
    # Per-pixel differences divided by their maximum made it 34 % lighter at 2.4 MP.
    import skimage.data

    photo = skimage.data.astronaut().mean(axis=2).astype(np.float32) / 255
    big = cv2.resize(photo, (1536, 1536), interpolation=cv2.INTER_CUBIC).clip(0, 1)
    small_dark = 1 - line_drawing(edge_map(photo)).drawing.mean()
    big_dark = 1 - line_drawing(edge_map(big)).drawing.mean()
    assert small_dark > 0.03
    assert big_dark == pytest.approx(small_dark, rel=0.15)


def test_flat_edge_map_is_blank_paper():
    line = line_drawing(np.zeros((20, 30), np.float32))
    assert np.all(line.drawing == 1.0)


@pytest.mark.parametrize(
    ("shape", "expected"),
    [
        ((10, 10), 6),
        ((400, 600), 7),
        ((512, 512), 7),
        ((1000, 1000), 9),
        ((3000, 4000), 13),
        ((9000, 9000), 13),
    ],
)
def test_default_line_length_examples(shape, expected):
    assert default_line_length(shape) == expected


@given(st.integers(1, 20000), st.integers(1, 20000), st.integers(1, 20000), st.integers(1, 20000))
def test_default_line_length_in_range_and_monotonic(h1, w1, h2, w2):
    l1, l2 = default_line_length((h1, w1)), default_line_length((h2, w2))
    assert 6 <= l1 <= 13
    if h1 * w1 <= h2 * w2:
        assert l1 <= l2


@pytest.mark.parametrize("length", [0, LONGEST_LENGTH + 1, 100_000])
def test_a_stroke_length_out_of_range_is_a_user_error(length):
    # 100 000 px used to try allocating terabytes for the kernels.
    with pytest.raises(PencilbotError, match=f"stroke length {length} px"):
        line_drawing(np.zeros((20, 20), np.float32), length=length)
