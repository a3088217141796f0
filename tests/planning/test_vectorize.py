"""Edge paths: the GMED line drawing as chains of short directional strokes along each contour."""

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage.draw import disk, polygon

from pencilbot.imaging.gmed import edge_map
from pencilbot.imaging.strokes import LineDrawing, line_drawing
from pencilbot.paths import Paths
from pencilbot.planning.layout import Layout, ink_on_image_grid, page_size
from pencilbot.planning.plan import Page
from pencilbot.planning.vectorize import PEN_DARKNESS, edge_strokes, edge_threshold


def _layout(shape, mm_per_px=0.5):
    """A page on which an image of ``shape`` lands at exactly ``mm_per_px``."""
    h, w = shape
    return Layout.fit(shape, Page(width=w * mm_per_px + 20, height=h * mm_per_px + 20, margin=10))


def _hand_made(edges, labels, length=7):
    return LineDrawing(drawing=1 - edges, labels=labels, edges=edges, length=length)


def _segments(paths):
    """(n, 2, 2) every straight segment of every path."""
    return np.concatenate([np.stack([p[:-1], p[1:]], axis=1) for p in paths])


def _angles_deg(segments):
    d = segments[:, 1] - segments[:, 0]
    return np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 180


def _lengths(segments):
    return np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1)


def _samples_px(paths, layout, step=0.25):
    """Points every ``step`` px along every path, in image (col, row)."""
    out = []
    for p in paths:
        px = layout.mm_to_px(p)
        for a, b in zip(px[:-1], px[1:], strict=True):
            n = max(2, int(np.ceil(np.linalg.norm(b - a) / step)) + 1)
            out.append(a + np.linspace(0, 1, n)[:, None] * (b - a))
    return np.concatenate(out)


def _longest_run(mask):
    """Longest run of True in a circular boolean sequence."""
    if mask.all():
        return len(mask)
    doubled = np.concatenate([mask, mask]).astype(np.int8)
    edges = np.diff(np.concatenate([[0], doubled, [0]]))
    return int((np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)).max(initial=0))


def _scribble(gray, rng, low, high, count, *, width):
    """Draw ``count`` random straight marks into ``gray``: centre x, y, half length (px) and grey
    uniform between ``low`` and ``high``, at a uniform angle."""
    (x0, y0, h0, g0), (x1, y1, h1, g1) = low, high
    marks = rng.uniform((x0, y0, 0, h0, g0), (x1, y1, np.pi, h1, g1), (count, 5))
    for x, y, angle, half, grey in marks:
        dx, dy = half * np.cos(angle), half * np.sin(angle)
        cv2.line(gray, (round(x - dx), round(y - dy)), (round(x + dx), round(y + dy)), float(grey), width)


def _disk_picture(size=140, radius=45, ground=0.6, ink=0.2):
    gray = np.full((size, size), ground, np.float32)
    gray[disk((size / 2, size / 2), radius)] = ink
    return gray


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
    paths = edge_strokes(line, layout, pen_width=1.5)  # a pen as wide as the raster line
    assert paths
    segments = _segments(paths)
    # Y up on the page, so the on-screen angle is the page angle. The path bends a little
    # between pieces, following the skeleton's mean across-position.
    off = np.abs((_angles_deg(segments) - 22.5 * k + 90) % 180 - 90)
    lengths = _lengths(segments)
    assert lengths[off < 5].sum() >= 0.9 * lengths.sum()
    # The boundary is drawn along most of its length inside the image, in one pen-down path.
    assert lengths.sum() >= 0.8 * size * layout.mm_per_px
    assert len(paths) == 1


def test_a_straight_run_is_one_path_over_the_run_and_its_overshoot():
    h, w, ell = 60, 100, 7
    edges = np.zeros((h, w), np.float32)
    edges[30, 20:81] = 1.0
    labels = np.zeros((h, w), np.uint8)  # direction 0: horizontal
    layout = _layout((h, w), mm_per_px=0.5)
    paths = edge_strokes(_hand_made(edges, labels, ell), layout, pen_width=0.5, piece_length=2.0)
    assert len(paths) == 1
    px = layout.mm_to_px(paths[0])
    assert np.allclose(px[:, 1], 30)
    # The run, overshot by ℓ/4 at each end so that neighbouring strokes cross ...
    assert px[:, 0].min() == pytest.approx(20 - ell / 4)
    assert px[:, 0].max() == pytest.approx(80 + ell / 4)
    # ... drawn in one direction, bending (here: not) only at pieces at most 2ℓ apart.
    assert np.all(np.diff(px[:, 0]) > 0)
    assert np.all(np.diff(px[:, 0]) <= 2 * ell + 1e-9)


@pytest.mark.parametrize(("band", "lines"), [(1, 1), (3, 1), (4, 2), (8, 3)])
def test_a_thick_edge_is_drawn_once_and_bold_when_wide(band, lines):
    # A band of edge pixels (what dilation makes of one contour), pen 2 px wide at plot scale:
    # one line, or as many touching lines as the raster is pen widths wide — never one line
    # per pixel row.
    h, w = 60, 100
    edges = np.zeros((h, w), np.float32)
    edges[28 : 28 + band, 10:90] = 0.8
    labels = np.zeros((h, w), np.uint8)
    layout = _layout((h, w), mm_per_px=0.25)
    paths = edge_strokes(_hand_made(edges, labels), layout, pen_width=0.5)
    rows = np.unique(np.round([layout.mm_to_px(p)[:, 1].mean() for p in paths], 6))
    assert len(rows) == lines
    assert rows.mean() == pytest.approx(28 + (band - 1) / 2, abs=0.5)
    assert np.allclose(np.diff(rows), 0.5 / 0.25)  # touching, not doubled


def test_two_separate_parallel_contours_stay_two():
    h, w = 60, 100
    edges = np.zeros((h, w), np.float32)
    edges[20, 10:90] = edges[26, 10:90] = 0.8
    layout = _layout((h, w), mm_per_px=0.25)
    paths = edge_strokes(_hand_made(edges, np.zeros((h, w), np.uint8)), layout, pen_width=0.5)
    rows = np.unique(np.round([layout.mm_to_px(p)[:, 1].mean() for p in paths], 6))
    assert rows.tolist() == [20, 26]


def test_a_circle_on_grey_is_a_chain_of_crossing_strokes_on_its_contour():
    # The rim of a cup: strokes on the contour, covering it, chained into few pen-down paths
    # whose ends cross (the pen goes out to a stroke's tip and back), never a chord across.
    gray = _disk_picture()
    line = line_drawing(edge_map(gray))
    layout = _layout(gray.shape)
    paths = edge_strokes(line, layout, pen_width=1.5)  # one line: the raster's is 2–3 px wide
    points = _samples_px(paths, layout)
    # (Forward differences put the jump on the outer pixel left and above, on the inner one
    # right and below; dilating down-right centres GMED's band on the boundary itself.)
    radius = np.hypot(points[:, 0] - 70, points[:, 1] - 70)
    assert np.percentile(np.abs(radius - 45), 95) <= 1.0
    assert np.abs(radius - 45).max() <= 1.5
    # Covered all round: no stretch of the circle farther than 1.5 px from the pen longer than ℓ.
    angle = np.radians(np.arange(0, 360, 0.5))
    on_circle = np.column_stack([70 + 45 * np.cos(angle), 70 + 45 * np.sin(angle)])
    nearest = np.min(np.hypot(*(on_circle[:, None, :] - points[None, ::4, :]).transpose(2, 0, 1)), axis=1)
    assert _longest_run(nearest > 1.5) * np.radians(0.5) * 45 <= line.length
    # Chains: the ~16 directional strokes of the circle join into a few paths ...
    unjoined = edge_strokes(line, layout, pen_width=1.5, join=-1)
    assert len(paths) * 4 <= len(unjoined)
    # ... through their crossings: the pen reverses (retraces its overshoot) at the joints.
    turns = 0
    for p in paths:
        d = np.diff(p, axis=0)
        cos = np.einsum("ij,ij->i", d[:-1], d[1:]) / (
            np.linalg.norm(d[:-1], axis=1) * np.linalg.norm(d[1:], axis=1)
        )
        turns += int(np.count_nonzero(cos < -0.9))
    assert turns >= len(unjoined) - len(paths)


def test_a_rounded_rectangle_gives_its_outline_and_nothing_else():
    gray = np.full((100, 140), 0.7, np.float32)
    rr, cc = polygon([20, 20, 80, 80], [30, 110, 110, 30])
    gray[rr, cc] = 0.25
    rounded = cv2.GaussianBlur(gray, (0, 0), 1.0)
    line = line_drawing(edge_map(rounded))
    layout = _layout(gray.shape)
    paths = edge_strokes(line, layout, pen_width=1.5)
    px = _samples_px(paths, layout)
    # Every stroke hugs the rectangle's border (within its overshoot past a corner), none floats inside.
    col, row = px[:, 0], px[:, 1]
    to_border = np.minimum.reduce([np.abs(col - 30), np.abs(col - 110), np.abs(row - 20), np.abs(row - 80)])
    assert np.all(to_border <= line.length / 4 + 2)
    # Sides are drawn along the sides; only the corners may take a diagonal stroke.
    segments = _segments(paths)
    axis_aligned = np.isin(np.round(_angles_deg(segments) / 22.5).astype(int) % 8, [0, 4])
    lengths = _lengths(segments)
    assert lengths[axis_aligned].sum() >= 0.85 * lengths.sum()
    # One closed outline: one or two pen-down paths.
    assert len(paths) <= 2


def test_texture_is_thinned_while_the_contour_beside_it_keeps_its_strokes():
    # Left: a dense patch of short random marks (a spoon's reflections, a badge's lettering,
    # hair). Right: a clean disk. A draughtsman keeps the contour and leaves the texture to
    # the shading, where the strokes of every band of the texture made knots.
    gray = np.full((160, 320), 0.8, np.float32)
    _scribble(gray, np.random.default_rng(4), (10, 10, 2, 0.3), (150, 150, 6, 0.6), 1500, width=1)
    gray[disk((80, 240), 50)] = 0.3
    line = line_drawing(edge_map(gray))
    layout = _layout(gray.shape)
    raster = 1 - line.drawing

    def ink(paths):
        drawn = ink_on_image_grid(paths, layout, pen_width=0.5)
        return drawn[:, :160].sum() / raster[:, :160].sum(), drawn[:, 175:].sum() / raster[:, 175:].sum()

    texture, contour = ink(edge_strokes(line, layout))
    texture_all, contour_all = ink(edge_strokes(line, layout, clutter=np.inf))
    # The pen lays at least the raster's ink along the contour, all of it kept ...
    assert contour >= 0.9 and contour == pytest.approx(contour_all, rel=1e-6)
    # ... and under half of it in the texture (one stroke per edge-pixel run laid 1.6 times it).
    assert texture <= 0.5 and texture <= texture_all / 2


def test_speckle_and_weak_edges_draw_nothing():
    rng = np.random.default_rng(1)
    h, w = 80, 80
    edges = np.zeros((h, w), np.float32)
    # Isolated single pixels: no run reaches min_pixels.
    edges[rng.integers(0, h, 40) // 4 * 4, rng.integers(0, w, 40) // 4 * 4] = 1.0
    labels = rng.integers(0, 8, (h, w)).astype(np.uint8)
    layout = _layout((h, w))
    assert edge_strokes(_hand_made(edges, labels), layout, min_pixels=3) == Paths.empty()
    weak = np.zeros((h, w), np.float32)
    weak[40, 10:70] = 0.2
    assert edge_strokes(_hand_made(weak, np.zeros((h, w), np.uint8)), layout, threshold=0.3) == Paths.empty()
    assert edge_strokes(_hand_made(weak, np.zeros((h, w), np.uint8)), layout, threshold=0.1)


@pytest.mark.parametrize(
    "gray",
    [
        np.round(np.tile(np.linspace(0.3, 0.8, 400), (300, 1)) * 255) / 255,
        np.clip(0.97 + np.random.default_rng(2).integers(-2, 3, (300, 400)) / 255, 0, 1),
        np.ones((300, 400)),
    ],
    ids=["8-bit-ramp", "noisy-blank-page", "white"],
)
def test_paper_that_should_stay_paper_gets_no_edge_strokes(gray):
    line = line_drawing(edge_map(gray.astype(np.float32)))
    assert edge_strokes(line, _layout(gray.shape)) == Paths.empty()


def test_edge_threshold_is_where_the_raster_stroke_is_dark_enough():
    gray = _disk_picture()
    plain = line_drawing(edge_map(gray))
    darker = line_drawing(edge_map(gray), gamma=3.0)
    assert edge_threshold(plain) == pytest.approx(plain.edge_strength(PEN_DARKNESS))
    assert plain.stroke_darkness(edge_threshold(plain)) == pytest.approx(PEN_DARKNESS)
    # A stroke γ that darkens the raster lines lets the pen draw fainter contours too.
    assert edge_threshold(darker) < edge_threshold(plain)


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
    paths = edge_strokes(_hand_made(edges, labels, 9), layout, pen_width=pen, min_pixels=1)
    x0, y0, x1, y1 = layout.drawing_box
    for p in paths:
        assert p.ndim == 2 and p.shape[1] == 2 and len(p) >= 2
        assert np.all((p[:, 0] >= x0 - 1e-9) & (p[:, 0] <= x1 + 1e-9))
        assert np.all((p[:, 1] >= y0 - 1e-9) & (p[:, 1] <= y1 + 1e-9))


def test_a_picture_of_texture_keeps_its_clean_contour_within_the_budget():
    # Texture all over (brush strokes of a painting: each coherent enough to pass the clutter
    # rule at the old 2.0), and one clean dark disk on it. The budget caps the contour length;
    # short texture chains go first, the disk's long outline stays.
    rng = np.random.default_rng(7)
    clean = np.full((240, 320), 0.75, np.float32)
    clean[disk((120, 160), 45)] = 0.1
    gray = clean.copy()
    _scribble(gray, rng, (0, 0, 4, 0.35), (320, 240, 12, 0.6), 900, width=2)
    gray[disk((120, 160), 45)] = 0.1
    line = line_drawing(edge_map(gray))
    layout = _layout(gray.shape)
    # mm of contour cores per mm²: the scribble overflows it about threefold, so a fifth of it
    # is kept (OVERFLOW_POWER), still room for the disk's outline.
    budget = 0.06
    free = edge_strokes(line, layout, clutter=2.0, max_lines=1)
    capped = edge_strokes(line, layout, clutter=2.0, max_lines=1, budget=budget)
    area = gray.size * layout.mm_per_px**2

    def length(paths):
        return sum(float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) for p in paths)

    assert length(free) > 0.2 * area  # without the budget: a scribble
    # The further the contours overflow a budget, the more of them are texture: at a budget
    # they overflow twentyfold, far less than the budget is kept (1 / 20^1.5 of it, drawn
    # strokes overshooting their cores), not the budget itself.
    tight = 0.008
    assert length(edge_strokes(line, layout, clutter=2.0, max_lines=1, budget=tight)) < 0.25 * tight * area
    # Drawn strokes overshoot their cores: within three times the budget, a tenth of the scribble.
    assert length(capped) <= 3 * budget * area and length(capped) < 0.1 * length(free)
    # The disk's outline is drawn as on the clean picture.
    rows, cols = np.ogrid[:240, :320]
    rim = np.abs(np.hypot(rows - 120, cols - 160) - 45) <= 3

    def on_rim(paths):
        return ink_on_image_grid(paths, layout, pen_width=0.5)[rim].sum()

    assert on_rim(capped) >= 0.9 * on_rim(
        edge_strokes(line_drawing(edge_map(clean)), layout, clutter=2.0, max_lines=1)
    )
    # An important region (a face) is never trimmed: the texture inside one stays drawn.
    important = np.zeros(gray.shape, np.float32)
    important[:, :80] = 1.0
    kept = edge_strokes(line, layout, clutter=2.0, max_lines=1, budget=budget, important=important)
    left = np.zeros(gray.shape, bool)
    left[:, :70] = True
    drawn = ink_on_image_grid(kept, layout, pen_width=0.5)
    assert drawn[left].sum() >= 0.9 * ink_on_image_grid(free, layout, pen_width=0.5)[left].sum()
