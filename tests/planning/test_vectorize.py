"""Edge strokes: the GMED line drawing as straight pen strokes along the 8 directions."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage.draw import disk, polygon

from pencilbot.imaging.gmed import edge_map
from pencilbot.imaging.strokes import LineDrawing, line_drawing
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.plan import Page
from pencilbot.planning.vectorize import edge_strokes, edge_threshold


def _layout(shape, mm_per_px=0.5):
    """A page on which an image of ``shape`` lands at exactly ``mm_per_px``."""
    h, w = shape
    return Layout.fit(shape, Page(width=w * mm_per_px + 20, height=h * mm_per_px + 20, margin=10))


def _hand_made(edges, labels, length=7):
    return LineDrawing(drawing=1 - edges, labels=labels, edges=edges, length=length)


def _angles_deg(strokes):
    d = np.array([s[1] - s[0] for s in strokes])
    return np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 180


def _lengths(strokes):
    return np.array([np.linalg.norm(s[1] - s[0]) for s in strokes])


@settings(max_examples=16, deadline=None)
@given(k=st.integers(0, 7), shift=st.floats(-8, 8))
def test_a_straight_edge_yields_strokes_along_its_direction(k, shift):
    # A dark half-plane whose boundary runs at k·22.5° (counter-clockwise on screen) through
    # the centre, drawn by the real GMED edge map and line drawing.
    size = 120
    theta = np.radians(22.5 * k)
    rows, cols = np.mgrid[0:size, 0:size].astype(float)
    c = size / 2 + shift
    # Signed distance to the boundary; the on-screen direction is (cos θ, −sin θ) in (col, row).
    side = (cols - c) * np.sin(theta) + (rows - c) * np.cos(theta)
    gray = np.where(side > 0, 0.15, 0.9).astype(np.float32)
    line = line_drawing(edge_map(gray))
    layout = _layout(gray.shape)
    strokes = edge_strokes(line, layout, pen_width=0.5)
    assert strokes
    # Y up on the page, so the on-screen angle is the page angle.
    off = np.abs((_angles_deg(strokes) - 22.5 * k + 90) % 180 - 90)
    lengths = _lengths(strokes)
    assert lengths[off < 1e-6].sum() >= 0.9 * lengths.sum()
    # The boundary is drawn along most of its length inside the image, not in crumbs.
    assert lengths.sum() >= 0.8 * size * layout.mm_per_px


def test_a_long_run_becomes_overlapping_pieces_covering_the_kernel_extent():
    h, w, ell = 60, 100, 7
    edges = np.zeros((h, w), np.float32)
    edges[30, 20:81] = 1.0
    labels = np.zeros((h, w), np.uint8)  # direction 0: horizontal
    layout = _layout((h, w), mm_per_px=0.5)
    strokes = edge_strokes(_hand_made(edges, labels, ell), layout, pen_width=0.5, piece_length=2.0)
    px = np.array([layout.mm_to_px(s) for s in strokes])  # (n, 2, 2) in (col, row)
    assert np.allclose(px[:, :, 1], 30)
    spans = np.sort(np.sort(px[:, :, 0], axis=1), axis=0)
    # The strokes together span the run extended by ℓ/2 at each end, as the kernel paints it ...
    assert spans[:, 0].min() == pytest.approx(20 - ell / 2)
    assert spans[:, 1].max() == pytest.approx(80 + ell / 2)
    # ... in pieces no longer than 2ℓ, each overlapping the next so the ends cross.
    assert len(strokes) >= (60 + ell) / (2 * ell)
    assert np.all(spans[:, 1] - spans[:, 0] <= 2 * ell + 1e-9)
    assert np.all(spans[1:, 0] < spans[:-1, 1])


@pytest.mark.parametrize(("band", "lines"), [(1, 1), (3, 1), (4, 2), (8, 2)])
def test_a_thick_edge_is_drawn_once_and_bold_when_wide(band, lines):
    # A band of edge pixels (what dilation makes of one contour), pen 2 px wide at plot scale:
    # one line, or for a band two pen widths thick one bold stroke of two touching lines —
    # never one line per pixel row.
    h, w = 60, 100
    edges = np.zeros((h, w), np.float32)
    edges[28 : 28 + band, 10:90] = 0.8
    labels = np.zeros((h, w), np.uint8)
    layout = _layout((h, w), mm_per_px=0.25)
    strokes = edge_strokes(_hand_made(edges, labels), layout, pen_width=0.5)
    rows = np.unique(np.round([layout.mm_to_px(s)[:, 1].mean() for s in strokes], 6))
    assert len(rows) == lines
    assert rows.mean() == pytest.approx(28 + (band - 1) / 2)
    if lines == 2:
        assert rows[1] - rows[0] == pytest.approx(0.5 / 0.25)  # touching, not doubled


def test_two_separate_parallel_contours_stay_two():
    h, w = 60, 100
    edges = np.zeros((h, w), np.float32)
    edges[20, 10:90] = edges[26, 10:90] = 0.8
    layout = _layout((h, w), mm_per_px=0.25)
    strokes = edge_strokes(_hand_made(edges, np.zeros((h, w), np.uint8)), layout, pen_width=0.5)
    rows = np.unique(np.round([layout.mm_to_px(s)[:, 1].mean() for s in strokes], 6))
    assert rows.tolist() == [20, 26]


def test_strokes_follow_a_curved_contour():
    gray = np.full((140, 140), 0.9, np.float32)
    gray[disk((70, 70), 45)] = 0.2
    line = line_drawing(edge_map(gray))
    layout = _layout(gray.shape)
    strokes = edge_strokes(line, layout)
    mid = np.array([layout.mm_to_px(s).mean(axis=0) for s in strokes])
    radius = np.hypot(mid[:, 0] - 70, mid[:, 1] - 70)
    # The mid-points of the chords hug the circle; the band of E is ~3 px wide around r = 45.
    assert np.all(np.abs(radius - 45) < 3.5)
    # And the strokes go round: every 30° sector of the circle has some.
    sectors = np.floor(np.degrees(np.arctan2(mid[:, 1] - 70, mid[:, 0] - 70)) % 360 / 30)
    assert set(sectors.astype(int)) == set(range(12))


def test_speckle_and_weak_edges_draw_nothing():
    rng = np.random.default_rng(1)
    h, w = 80, 80
    edges = np.zeros((h, w), np.float32)
    # Isolated single pixels: no run reaches min_pixels.
    edges[rng.integers(0, h, 40) // 4 * 4, rng.integers(0, w, 40) // 4 * 4] = 1.0
    labels = rng.integers(0, 8, (h, w)).astype(np.uint8)
    layout = _layout((h, w))
    assert edge_strokes(_hand_made(edges, labels), layout, min_pixels=3) == []
    weak = np.zeros((h, w), np.float32)
    weak[40, 10:70] = 0.2
    assert edge_strokes(_hand_made(weak, np.zeros((h, w), np.uint8)), layout, threshold=0.3) == []
    assert edge_strokes(_hand_made(weak, np.zeros((h, w), np.uint8)), layout, threshold=0.1)


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    shape=st.tuples(st.integers(8, 70), st.integers(8, 70)),
    rotate=st.sampled_from([0, 90, 180, 270]),
    pen=st.floats(0.1, 2.0),
)
def test_strokes_stay_inside_the_drawing_box(seed, shape, rotate, pen):
    rng = np.random.default_rng(seed)
    edges = (rng.random(shape) ** 3).astype(np.float32)
    labels = rng.integers(0, 8, shape).astype(np.uint8)
    layout = Layout.fit(shape, page_size("A5", "portrait"), rotate=rotate)
    strokes = edge_strokes(_hand_made(edges, labels, 9), layout, pen_width=pen, min_pixels=1)
    x0, y0, x1, y1 = layout.drawing_box
    for s in strokes:
        assert s.shape == (2, 2)
        assert np.all((s[:, 0] >= x0 - 1e-9) & (s[:, 0] <= x1 + 1e-9))
        assert np.all((s[:, 1] >= y0 - 1e-9) & (s[:, 1] <= y1 + 1e-9))


def test_a_drawn_shape_gives_its_outline_and_nothing_else():
    gray = np.full((100, 140), 0.95, np.float32)
    rr, cc = polygon([20, 20, 80, 80], [30, 110, 110, 30])
    gray[rr, cc] = 0.2
    line = line_drawing(edge_map(gray))
    layout = _layout(gray.shape)
    strokes = edge_strokes(line, layout)
    px = np.concatenate([layout.mm_to_px(s) for s in strokes])
    # Every stroke hugs the rectangle's border (within ℓ/2 + dilation), none floats inside.
    col, row = px[:, 0], px[:, 1]
    to_border = np.minimum.reduce([np.abs(col - 30), np.abs(col - 110), np.abs(row - 20), np.abs(row - 80)])
    assert np.all(to_border <= line.length / 2 + 3)
    # Sides are drawn along the sides; only the corners may take a diagonal stroke.
    axis_aligned = np.isin(np.round(_angles_deg(strokes) / 22.5).astype(int) % 8, [0, 4])
    lengths = _lengths(strokes)
    assert lengths[axis_aligned].sum() >= 0.85 * lengths.sum()


def test_otsu_threshold_separates_two_populations():
    rng = np.random.default_rng(0)
    low, high = rng.uniform(0.0, 0.2, 5000), rng.uniform(0.6, 0.8, 500)
    thr = edge_threshold(np.concatenate([low, high]).astype(np.float32).reshape(50, 110))
    assert low.max() - 0.01 <= thr < high.min()  # 256 histogram bins: 0.004 resolution
    assert edge_threshold(np.zeros((5, 5), np.float32)) == 1.0
