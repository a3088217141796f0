"""The rasteriser: ink model, orientation, accumulation, images on disk."""

import math

import cv2
import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

import pencilbot.render as canvas_module
import pencilbot.render.coverage as coverage_module
from pencilbot.errors import PencilbotError
from pencilbot.render import Canvas, render_paths


def area_in_band(dist, r, wide, narrow, samples=32):
    """Share of a unit pixel's area within ``r`` of a line at ``dist`` from its centre, integrated
    numerically over the pixel (line direction given by |cos|, |sin| = wide, narrow)."""
    g = (np.arange(samples) + 0.5) / samples - 0.5
    sx, sy = np.meshgrid(g, g)
    offset = (sx * narrow + sy * wide).ravel()  # sub-pixel positions projected on the normal
    d = np.asarray(dist)[..., None]
    return (np.abs(d + offset) <= r).mean(axis=-1)


def brute_force(paths, width_mm, height_mm, dpi, pen_width):
    """Reference: every pixel against every segment, straight from the ink model's definition."""
    px = 25.4 / dpi
    h, w = math.ceil(height_mm / px - 1e-6), math.ceil(width_mm / px - 1e-6)
    cx = (np.arange(w) + 0.5) * px
    cy = height_mm - (np.arange(h) + 0.5) * px
    X, Y = np.meshgrid(cx, cy)
    transmit = np.ones((h, w))
    for path in paths:
        path = np.asarray(path, float).reshape(-1, 2)
        segs = list(zip(path[:-1], path[1:])) or [(path[0], path[0])]
        cover = np.zeros((h, w))
        for a, b in segs:
            d = b - a
            t = ((X - a[0]) * d[0] + (Y - a[1]) * d[1]) / max(d @ d, 1e-300)
            t = np.clip(t, 0, 1)
            dist = np.hypot(X - a[0] - t * d[0], Y - a[1] - t * d[1]) / px
            direction = np.abs(d) / np.hypot(*d) if d @ d > 0 else np.array([1.0, 0.0])
            wide, narrow = direction.max(), direction.min()
            cover = np.maximum(cover, area_in_band(dist, pen_width / 2 / px, wide, narrow))
        transmit *= 1 - cover
    return 1 - transmit


point = st.tuples(st.floats(-2, 22), st.floats(-2, 17))
path = st.lists(point, min_size=1, max_size=5)


@settings(max_examples=40, deadline=None)
@given(st.lists(path, min_size=1, max_size=4), st.sampled_from([0.1, 0.4, 1.3]))
def test_matches_brute_force_reference(paths, pen_width):
    got = render_paths(paths, 20, 15, dpi=50.8, pen_width=pen_width)  # 0.5 mm pixels
    want = brute_force(paths, 20, 15, 50.8, pen_width)
    np.testing.assert_allclose(got, want, atol=0.04)  # the reference integrates at 1/32 px


@settings(max_examples=30, deadline=None)
@given(st.floats(0, math.pi), st.floats(0.05, 2.0), st.floats(0, 1), st.floats(0, 1))
def test_coverage_is_the_exact_pixel_area_along_a_line(angle, pen_width, dx, dy):
    """Away from the caps, each pixel's ink is its area inside the pen's band (shapely, exact)."""
    centre = np.array([10.0 + dx, 10.0 + dy])
    half = 8.0 * np.array([math.cos(angle), math.sin(angle)])
    line = np.array([centre - half, centre + half])
    got = render_paths([line], 20, 20, dpi=25.4, pen_width=pen_width)  # 1 mm pixels
    band = shapely.LineString(line).buffer(pen_width / 2, cap_style="flat", quad_segs=1)
    rows, cols = np.mgrid[0:20, 0:20]
    x, y = cols + 0.5, 20 - rows - 0.5
    along = ((x - centre[0]) * half[0] + (y - centre[1]) * half[1]) / (half @ half)
    interior = np.abs(along) < 0.7  # well inside the segment: caps do not reach these pixels
    boxes = shapely.box(x - 0.5, y - 0.5, x + 0.5, y + 0.5)
    exact = shapely.area(shapely.intersection(boxes, band))
    np.testing.assert_allclose(got[interior], exact[interior], atol=1e-6)


@settings(max_examples=15, deadline=None)
@given(st.floats(0, math.pi), st.floats(1.0, 4.0), st.floats(0, 0.1), st.floats(0, 0.1))
def test_thick_pens_on_fine_grids_keep_exact_areas(angle, pen_width, dx, dy):
    """A pen 10–40 pixels wide. Coverage is computed in float32 from distances of up to ~r px, so
    it carries ~r·6e-8 of rounding: measured ≤ 3e-6 at r = 20 px, far below 8-bit resolution."""
    centre = np.array([3.0 + dx, 3.0 + dy])
    half = 2.5 * np.array([math.cos(angle), math.sin(angle)])
    line = np.array([centre - half, centre + half])
    got = render_paths([line], 6, 6, dpi=254, pen_width=pen_width)  # 0.1 mm pixels
    band = shapely.LineString(line).buffer(pen_width / 2, cap_style="flat", quad_segs=1)
    rows, cols = np.mgrid[0:60, 0:60]
    x, y = (cols + 0.5) * 0.1, 6 - (rows + 0.5) * 0.1
    along = ((x - centre[0]) * half[0] + (y - centre[1]) * half[1]) / (half @ half)
    interior = np.abs(along) < 0.2
    boxes = shapely.box(x - 0.05, y - 0.05, x + 0.05, y + 0.05)
    exact = shapely.area(shapely.intersection(boxes, band)) / 0.1**2
    np.testing.assert_allclose(got[interior], exact[interior], atol=1e-5)


@settings(max_examples=30, deadline=None)
@given(st.floats(0, math.pi), st.floats(0.2, 2.0))
def test_ink_is_conserved_at_any_angle(angle, pen_width):
    """Total ink of one segment = its area (length × width plus two half-disc caps)."""
    length = 30.0
    centre = np.array([25.0, 25.0])
    half = 0.5 * length * np.array([math.cos(angle), math.sin(angle)])
    d = render_paths([np.array([centre - half, centre + half])], 50, 50, dpi=254, pen_width=pen_width)
    area = d.sum() * 0.1**2
    assert area == pytest.approx(length * pen_width + math.pi * pen_width**2 / 4, rel=0.01)


def test_y_up_maps_to_top_rows_and_x_to_columns():
    c = Canvas(100, 50, dpi=25.4)  # 1 mm pixels
    c.draw_paths([np.array([[10.5, 45.5], [10.5, 45.5]])])  # near the top-left corner
    rows, cols = np.nonzero(c.darkness > 0)
    assert rows.max() < 6 and cols.max() < 12
    assert c.darkness[4, 10] == c.darkness.max()  # y = 45.5 → row 50 − 45.5 − 0.5 = 4
    assert c.darkness.shape == (50, 100)


def test_origin_shifts_the_window():
    line = [np.array([[12.0, 7.0], [18.0, 7.0]])]
    whole = render_paths(line, 40, 20, dpi=25.4)
    window = render_paths(line, 20, 10, dpi=25.4, origin=(10.0, 5.0))
    np.testing.assert_allclose(window, whole[5:15, 10:30])


def test_a_path_inks_each_pixel_once_but_paths_stack():
    there_and_back = np.array([[5.0, 5.0], [15.0, 5.0], [5.0, 5.0], [15.0, 5.0]])
    once = render_paths([there_and_back[:2]], 20, 10, dpi=254, pen_width=0.05)
    retraced = render_paths([there_and_back], 20, 10, dpi=254, pen_width=0.05)
    twice = render_paths([there_and_back[:2]] * 2, 20, 10, dpi=254, pen_width=0.05)
    np.testing.assert_allclose(retraced, once, atol=1e-6)
    np.testing.assert_allclose(twice, 1 - (1 - once) ** 2, atol=1e-6)
    assert twice.max() > once.max() > 0


def test_separate_calls_accumulate_like_paths():
    a, b = np.array([[1.0, 1.0], [9.0, 9.0]]), np.array([[1.0, 9.0], [9.0, 1.0]])
    c = Canvas(10, 10, dpi=100, pen_width=0.3)
    c.draw_paths([a])
    c.draw_paths([b])
    np.testing.assert_allclose(c.darkness, render_paths([a, b], 10, 10, dpi=100, pen_width=0.3), atol=1e-6)


def test_chunking_does_not_change_the_result(monkeypatch):
    rng = np.random.default_rng(3)
    paths = [rng.uniform(0, 30, (rng.integers(1, 6), 2)) for _ in range(300)]
    # long paths that retrace themselves span many chunks and must still ink each pixel once
    paths[100:100] = [
        np.tile([[2.0, 2.0], [28.0, 28.0]], (20, 1)),
        np.tile([[2.0, 28.0], [28.0, 2.0]], (15, 1)),
    ]
    whole = render_paths(paths, 30, 30, dpi=100, pen_width=0.4)
    for chunk in (5000, 500, 50):
        monkeypatch.setattr(coverage_module, "_CHUNK_CANDIDATES", chunk)
        np.testing.assert_allclose(render_paths(paths, 30, 30, dpi=100, pen_width=0.4), whole, atol=1e-6)
    once = render_paths([paths[100][:2]], 30, 30, dpi=100, pen_width=0.4)
    np.testing.assert_allclose(render_paths([paths[100]], 30, 30, dpi=100, pen_width=0.4), once, atol=1e-6)


def test_empty_and_off_page_paths_leave_paper_white():
    d = render_paths([np.zeros((0, 2)), np.array([[-50.0, -50.0], [-40.0, -60.0]])], 10, 10)
    assert d.shape == (40, 40) and not d.any()


def test_travel_overlay_is_coloured_and_leaves_darkness_alone(tmp_path):
    c = Canvas(20, 10, dpi=50.8)
    c.draw_paths([np.array([[2.0, 2.0], [18.0, 2.0]])])
    before = c.darkness.copy()
    assert c.to_image().ndim == 2
    c.draw_travel([np.array([[2.0, 8.0], [18.0, 8.0]])])
    np.testing.assert_array_equal(c.darkness, before)
    rgb = c.to_image()
    assert rgb.shape == (20, 40, 3) and rgb.dtype == np.uint8
    row = rgb[3, 20]  # y = 8 mm → row 3 at 0.5 mm pixels
    assert int(row[0]) > int(row[1]) + 50  # reddish
    c.save_png(tmp_path / "p.png")
    back = cv2.imread(str(tmp_path / "p.png"))[..., ::-1]
    np.testing.assert_array_equal(back, rgb)


def test_save_png_round_trips_and_leaves_no_temp_files(tmp_path):
    c = Canvas(30, 20, dpi=50.8, pen_width=1.0)
    c.draw_paths([np.array([[3.0, 3.0], [27.0, 17.0]])])
    c.save_png(tmp_path / "drawing.png")
    back = cv2.imread(str(tmp_path / "drawing.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(back, c.to_image())
    assert back.min() == 0 and back.max() == 255
    assert [p.name for p in tmp_path.iterdir()] == ["drawing.png"]


def test_save_png_into_missing_folder_is_a_user_error(tmp_path):
    with pytest.raises(PencilbotError, match="cannot write"):
        Canvas(10, 10).save_png(tmp_path / "nope" / "x.png")


@pytest.mark.parametrize("args", [(0, 10), (10, -1)])
def test_bad_sizes_are_user_errors(args):
    with pytest.raises(PencilbotError, match="positive"):
        Canvas(*args)


def _scribble(seed=3, count=400, size=40.0):
    rng = np.random.default_rng(seed)
    paths = [rng.uniform(0, size, (rng.integers(1, 6), 2)) for _ in range(count)]
    # Steep, flat and retraced long paths that cross many bands; one off the sheet's top edge.
    paths += [
        np.tile([[1.0, 1.0], [39.0, 38.0]], (12, 1)),
        np.array([[1.0, 20.0], [39.0, 20.3]]),
        np.array([[20.0, 1.0], [20.2, 39.0]]),
        np.array([[5.0, 39.9], [35.0, 41.0]]),
    ]
    return paths


@pytest.mark.parametrize("step", [1, 7, 64])
def test_a_sheet_inked_band_by_band_is_the_whole_sheet_bit_for_bit(step):
    paths = _scribble()
    whole = render_paths(paths, 40, 40, dpi=200, pen_width=0.5)
    bands = canvas_module.Bands(paths, 40, 40, dpi=200, pen_width=0.5)
    rows = whole.shape[0]
    banded = np.vstack([bands.darkness(r, min(r + step, rows)) for r in range(0, rows, step)])
    np.testing.assert_array_equal(banded, whole)
    assert whole.max() > 0.9  # the drawing is there, not an empty page twice
    band = canvas_module.render_band(paths, (100, 140), 40, 40, dpi=200, pen_width=0.5)
    np.testing.assert_array_equal(band, whole[100:140])
    with pytest.raises(ValueError, match="not a band"):
        bands.darkness(rows - 1, rows + 1)


@pytest.mark.parametrize("travel", [False, True])
def test_a_drawing_streamed_to_png_is_the_canvas_picture(tmp_path, travel):
    paths = _scribble(seed=5, count=150)
    moves = [np.array([[0.0, 0.0], [30.0, 12.0]]), np.array([[3.0, 35.0], [36.0, 2.0]])]
    canvas = Canvas(40, 30, dpi=150, pen_width=0.4)
    canvas.draw_paths(paths)
    if travel:
        canvas.draw_travel(moves)
    out = tmp_path / "plot.png"
    shape = canvas_module.save_drawing_png(
        out, paths, 40, 30, dpi=150, pen_width=0.4, travel=moves if travel else None, band_pixels=5000
    )
    back = cv2.imread(str(out), cv2.IMREAD_UNCHANGED)
    if travel:
        back = back[..., ::-1]
    assert shape == canvas.shape and canvas.shape[0] > 5000 // canvas.shape[1]  # several bands
    np.testing.assert_array_equal(back, canvas.to_image())
    assert [p.name for p in tmp_path.iterdir()] == ["plot.png"]


@pytest.mark.parametrize("travel", [False, True])
def test_a_colour_drawing_streamed_to_png_is_the_stacked_canvases(tmp_path, travel):
    # Two pens, each its own ink and width, band by band: the picture color_image makes of one
    # whole canvas per pen (a band that mixed up pens or rows would change the colours).
    cyan, magenta = _scribble(seed=2, count=80), _scribble(seed=3, count=80)
    moves = [np.array([[0.0, 0.0], [30.0, 12.0]])]
    canvases = []
    for paths, width in ((cyan, 0.3), (magenta, 0.6)):
        canvas = Canvas(40, 30, dpi=150, pen_width=width)
        canvas.draw_paths(paths)
        canvases.append(canvas)
    if travel:
        canvases[0].draw_travel(moves)
    colors = ["#00a0e0", "#e0007a"]
    want = canvas_module.color_image(canvases, colors)
    out = tmp_path / "colour.png"
    shape = canvas_module.save_color_png(
        out,
        [(cyan, colors[0], 0.3), (magenta, colors[1], 0.6)],
        40,
        30,
        dpi=150,
        travel=moves if travel else None,
        travel_pen=0.3,
        band_pixels=5000,
    )
    back = cv2.imread(str(out), cv2.IMREAD_UNCHANGED)[..., ::-1]
    assert shape == canvases[0].shape
    assert np.abs(back.astype(int) - want.astype(int)).max() <= 1
    assert (back[..., 0] < 128).any() and (back[..., 1] < 128).any()  # both inks are there
