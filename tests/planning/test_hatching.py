"""Hatching: layers of parallel lines whose inked fraction follows the darkness."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pencilbot.planning import hatching
from pencilbot.planning.hatching import hatch_coverage, hatch_layers
from pencilbot.planning.layout import Layout
from pencilbot.planning.plan import Page
from pencilbot.render import render_paths

PEN = 0.5


def _layout(shape=(100, 100), mm_per_px=0.5):
    h, w = shape
    return Layout.fit(shape, Page(width=w * mm_per_px + 20, height=h * mm_per_px + 20, margin=10))


def _rendered_coverage(layers, layout, inset=8.0):
    """Mean ink of the layers rendered by the real rasteriser, away from the drawing's border."""
    x0, y0, x1, y1 = layout.drawing_box
    dark = np.zeros(1)
    for layer in layers:
        d = render_paths(layer.paths, x1 - x0, y1 - y0, dpi=254, pen_width=PEN, origin=(x0, y0))
        dark = 1 - (1 - dark) * (1 - d)
    cut = int(inset / 0.1)
    return float(dark[cut:-cut, cut:-cut].mean())


def test_coverage_grows_with_darkness_and_tracks_it():
    layout = _layout()
    measured = []
    for d in (0.05, 0.2, 0.4, 0.6, 0.8, 0.9):
        layers = hatch_layers(np.full((100, 100), d), layout, pen_width=PEN, jitter=0.0)
        measured.append(_rendered_coverage(layers, layout))
        # The real ink follows the dither's promise, which follows the darkness.
        assert measured[-1] == pytest.approx(hatch_coverage(d), abs=0.04)
        assert hatch_coverage(d) == pytest.approx(d, abs=0.04)
    assert np.all(np.diff(measured) > 0)


def test_white_paper_gets_no_hatching():
    layers = hatch_layers(np.zeros((60, 80)), _layout((60, 80)))
    assert [len(layer.paths) for layer in layers] == [0] * 4


def test_a_layer_is_drawn_only_where_the_tone_needs_it():
    # Left half light (only the first layer is needed), right half dark (all four).
    dark = np.full((100, 100), 0.3)
    dark[:, 50:] = 0.9
    layout = _layout()
    layers = hatch_layers(dark, layout, angles=(45, -45, 0, 90), blur=0.5, min_run=1.0)
    assert [layer.name for layer in layers] == ["hatch1-45", "hatch2-135", "hatch3-0", "hatch4-90"]
    x_mid = (layout.drawing_box[0] + layout.drawing_box[2]) / 2
    assert len(layers[0].paths) > 0
    for layer in layers[1:]:
        pts = np.concatenate(layer.paths)
        assert pts[:, 0].min() >= x_mid - 2.0  # 2 mm: the blur softens the step
    left = [p for p in layers[0].paths if p[:, 0].max() < x_mid - 2]
    assert left, "the light half still gets its first layer"


def test_lines_run_at_their_layer_angle_and_keep_the_minimum_length():
    dark = np.tile(np.linspace(0, 1, 80), (80, 1))
    layers = hatch_layers(dark, _layout((80, 80)), angles=(30, 120), min_run=3.0, blur=1.0)
    for layer, angle in zip(layers, (30, 120), strict=True):
        assert layer.paths
        d = np.array([p[1] - p[0] for p in layer.paths])
        assert np.allclose(np.degrees(np.arctan2(d[:, 1], d[:, 0])) % 180, angle % 180)
        assert np.linalg.norm(d, axis=1).min() >= 3.0 - 1e-9


def test_a_layer_is_serpentine():
    layers = hatch_layers(np.full((100, 100), 0.45), _layout(), angles=(0,))
    paths = layers[0].paths
    ys = np.array([p[0, 1] for p in paths])
    dx = np.array([p[1, 0] - p[0, 0] for p in paths])
    assert np.all(np.diff(ys) != 0), "one run per line in a uniform tone"
    assert np.all(np.sign(dx[1:]) == -np.sign(dx[:-1])), "consecutive lines alternate direction"
    # The pen's hop from one line's end to the next line's start is short (no flyback).
    hops = [np.linalg.norm(b[0] - a[1]) for a, b in zip(paths, paths[1:], strict=False)]
    assert max(hops) < 5.0


def test_jitter_moves_lines_but_keeps_the_tone():
    layout = _layout()
    ruled = hatch_layers(np.full((100, 100), 0.4), layout, angles=(0,), jitter=0.0)
    wobbly = hatch_layers(np.full((100, 100), 0.4), layout, angles=(0,), jitter=0.8, seed=5)
    assert not np.allclose(ruled[0].paths[0], wobbly[0].paths[0])
    assert _rendered_coverage(wobbly, layout) == pytest.approx(_rendered_coverage(ruled, layout), abs=0.04)


@example(seed=0, shape=(19, 19), rotate=90, angles=[0.2], pen=0.2)  # float32 sampling overshot by 3 µm
@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    shape=st.tuples(st.integers(10, 60), st.integers(10, 60)),
    rotate=st.sampled_from([0, 90, 180, 270]),
    angles=st.lists(st.floats(-180, 180), min_size=1, max_size=4),
    pen=st.floats(0.2, 1.5),
)
def test_hatching_stays_inside_the_drawing_box(seed, shape, rotate, angles, pen):
    rng = np.random.default_rng(seed)
    layout = Layout.fit(shape, Page(width=120, height=90, margin=12), rotate=rotate)
    layers = hatch_layers(rng.random(shape), layout, pen_width=pen, angles=tuple(angles), jitter=0.5)
    x0, y0, x1, y1 = layout.drawing_box
    for layer in layers:
        assert layer.pen_width == pen
        for p in layer.paths:
            assert np.all((p[:, 0] >= x0 - 1e-9) & (p[:, 0] <= x1 + 1e-9))
            assert np.all((p[:, 1] >= y0 - 1e-9) & (p[:, 1] <= y1 + 1e-9))


@settings(max_examples=50, deadline=None)
@given(d=st.floats(0, 1), f=st.floats(0.2, 0.8), k=st.integers(1, 6))
def test_ideal_coverage_is_monotone_and_capped(d, f, k):
    a = hatch_coverage(d, coverage=f, n_layers=k)
    b = hatch_coverage(min(1.0, d + 0.05), coverage=f, n_layers=k)
    assert b >= a - 1e-12
    assert 0 <= a <= 1 - (1 - f) ** k + 1e-12
    assert abs(a - min(d, 1 - (1 - f) ** k)) <= f / 16 + 1e-9


def test_the_lightest_tones_stay_paper():
    layout = _layout()
    faint = np.full((100, 100), 0.04)
    assert any(layer.paths for layer in hatch_layers(faint, layout, blank_below=0.0))
    assert not any(layer.paths for layer in hatch_layers(faint, layout, blank_below=0.06))
    assert any(layer.paths for layer in hatch_layers(faint + 0.04, layout, blank_below=0.06))


def test_runs_found_block_by_block_are_those_of_the_whole_sheet(monkeypatch):
    # Runs are extracted per block of lines (memory); block edges must not move or drop any.
    rng = np.random.default_rng(1)
    darkness = rng.random((80, 120)).astype(np.float32)
    layout = Layout.fit(darkness.shape, Page(200, 150, margin=10), rotate=90)
    whole = hatch_layers(darkness, layout, pen_width=0.3, jitter=0.3, seed=2)
    monkeypatch.setattr(hatching, "_SAMPLES_PER_BLOCK", 5_000)  # a few lines per block
    blocks = hatch_layers(darkness, layout, pen_width=0.3, jitter=0.3, seed=2)
    assert sum(len(layer.paths) for layer in whole) > 100
    for a, b in zip(whole, blocks, strict=True):
        for p, q in zip(a.paths, b.paths, strict=True):
            np.testing.assert_array_equal(p, q)
