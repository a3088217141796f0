"""GMED: forward differences exactly as formula 3, the documented L element and anchor, denoising."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from pencilbot.imaging.gmed import (
    EDGE_FLOOR,
    EDGE_FULL,
    EDGE_FULL_MIN,
    EDGE_FULL_OVER_P99,
    L_ELEMENTS,
    dilate,
    edge_map,
    element_offsets,
    full_strength,
    gmed_stages,
    gradient_magnitude,
)


def test_forward_differences_exact_on_ramp():
    a, b = 0.01, 0.003  # grey levels per column / per row
    rows, cols = np.mgrid[0:20, 0:30]
    f = (0.1 + a * cols + b * rows).astype(np.float32)
    g = gradient_magnitude(f, "l2")
    np.testing.assert_allclose(g[:-1, :-1], np.hypot(a, b), rtol=1e-4)
    np.testing.assert_allclose(g[:-1, -1], b, rtol=1e-3)  # last column: gx = 0 by the border rule
    np.testing.assert_allclose(g[-1, :-1], a, rtol=1e-3)  # last row: gy = 0
    assert g[-1, -1] == 0
    np.testing.assert_allclose(gradient_magnitude(f, "l1")[:-1, :-1], a + b, rtol=1e-4)


def test_forward_not_backward_or_central():
    # A step between columns 4 and 5: only f(x+1) − f(x) puts the whole jump on column 4.
    f = np.zeros((6, 10), np.float32)
    f[:, 5:] = 1.0
    g = gradient_magnitude(f)
    assert np.array_equal(np.nonzero(g[2])[0], [4])
    assert g[2, 4] == 1.0
    # Same along rows.
    g_rows = gradient_magnitude(np.ascontiguousarray(f.T))
    assert np.array_equal(np.nonzero(g_rows[:, 2])[0], [4])


def test_default_element_is_down_right_l_anchored_at_corner():
    assert L_ELEMENTS["down-right"].tolist() == [[True, True], [True, False]]
    assert sorted(map(tuple, element_offsets())) == [(0, 0), (0, 1), (1, 0)]
    impulse = np.zeros((7, 7), np.float32)
    impulse[3, 3] = 0.8
    out = dilate(impulse)
    assert sorted(zip(*np.nonzero(out))) == [(3, 3), (3, 4), (4, 3)]
    assert np.all(out[out > 0] == np.float32(0.8))


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("down-left", [(0, 0), (0, -1), (1, 0)]),  # corner (0,1) is the anchor
        ("up-right", [(-1, 0), (0, 0), (0, 1)]),
        ("up-left", [(-1, 0), (0, -1), (0, 0)]),
    ],
)
def test_alternative_elements(name, expected):
    assert sorted(map(tuple, element_offsets(name))) == sorted(expected)


def test_explicit_anchor_and_bad_anchor():
    # Anchoring element a at its right arm: the impulse spreads left and down-left instead.
    assert sorted(map(tuple, element_offsets("down-right", (0, 1)))) == [(0, -1), (0, 0), (1, -1)]
    with pytest.raises(ValueError):
        element_offsets("down-right", (1, 1))  # not a pixel of the element
    with pytest.raises(ValueError):
        element_offsets("sideways")


def brute_dilate(f, offsets):
    h, w = f.shape
    out = np.full_like(f, -np.inf)
    for r in range(h):
        for c in range(w):
            for dr, dc in offsets:
                sr, sc = r - dr, c - dc
                if 0 <= sr < h and 0 <= sc < w:
                    out[r, c] = max(out[r, c], f[sr, sc])
    return out


@settings(max_examples=30, deadline=None)
@given(
    arrays(np.float32, st.tuples(st.integers(1, 7), st.integers(1, 7)), elements=st.floats(0, 1, width=32)),
    st.sampled_from(sorted(L_ELEMENTS)),
)
def test_dilation_matches_definition(f, name):
    np.testing.assert_array_equal(dilate(f, name), brute_dilate(f, element_offsets(name)))


def test_edge_map_range_and_flat_image():
    rng = np.random.default_rng(1)
    E = edge_map(rng.random((40, 50), dtype=np.float32))
    assert E.dtype == np.float32 and E.min() >= 0 and E.max() == pytest.approx(1.0)
    assert not edge_map(np.full((10, 10), 0.4, np.float32)).any()


def _quantised(gray):
    return (np.round(np.asarray(gray, np.float64) * 255) / 255).astype(np.float32)


@pytest.mark.parametrize(
    "gray",
    [
        # a smooth 8-bit ramp: one grey level every few columns, each step a 1/255 jump
        _quantised(np.tile(np.linspace(0.2, 0.9, 600), (100, 1))),
        _quantised(np.tile(np.linspace(0.0, 1.0, 300), (120, 1)).T),
        # a blank page with ±2 grey levels of noise, at coffee size and at 12 MP scale
        _quantised(0.97 + np.random.default_rng(0).integers(-2, 3, (400, 600)) / 255),
        _quantised(0.5 + np.random.default_rng(1).integers(-2, 3, (1500, 2000)) / 255),
        np.ones((50, 70), np.float32),
    ],
    ids=["ramp-rows", "ramp-cols", "noisy-page", "noisy-page-3mp", "white"],
)
def test_paper_stays_paper(gray):
    # Lu's max-normalisation made banding and noise full-strength edges; the absolute floor does not.
    assert not edge_map(gray).any()


def test_edge_strength_is_absolute_and_floored():
    # A vertical step of contrast c: the gradient is c on one column (two after dilation).
    def step(contrast):
        f = np.full((20, 40), 0.5, np.float32)
        f[:, 20:] += contrast
        return edge_map(f, scale=1.0, full=EDGE_FULL).max()

    assert step(EDGE_FLOOR * 0.9) == 0  # below the floor: nothing
    assert step(EDGE_FULL) == pytest.approx(1.0)  # at full: black, whatever else is in the picture
    half = (EDGE_FLOOR + EDGE_FULL) / 2
    assert step(half) == pytest.approx(0.5, abs=1e-5)
    # The same step beside a much stronger one keeps its strength (no division by the maximum).
    f = np.full((20, 80), 0.5, np.float32)
    f[:, 20:40] += half
    f[:, 60:] = 0.0
    E = edge_map(f, scale=1.0, full=EDGE_FULL)
    assert E[:, 19:21].max() == pytest.approx(0.5, abs=1e-5) and E[:, 59:61].max() == 1.0


def test_full_strength_follows_the_photo_within_bounds():
    rng = np.random.default_rng(3)
    assert full_strength(np.zeros((50, 50), np.float32)) == EDGE_FULL_MIN  # most gain, bounded
    assert full_strength(np.ones((50, 50), np.float32)) == EDGE_FULL  # crisp: no less than 0.4
    soft = rng.uniform(0, 0.1, (200, 200)).astype(np.float32)
    assert full_strength(soft) == pytest.approx(EDGE_FULL_OVER_P99 * np.percentile(soft, 99), rel=1e-5)
    # A soft photo's contour (a 0.1 step) is drawn darker than on the absolute scale alone ...
    f = np.full((40, 40), 0.5, np.float32)
    f[:, 20:] += 0.1
    assert edge_map(f, scale=1.0).max() > 2 * edge_map(f, scale=1.0, full=EDGE_FULL).max()
    # ... but the floor stays: the same page at a contrast under the floor is still paper.
    f[:, 20:] -= 0.1 - 0.9 * EDGE_FLOOR
    assert not edge_map(f, scale=1.0).any()


def test_a_blurred_contour_keeps_its_strength_at_higher_resolution():
    # The same soft disk at 1× and 6× the reference size: E (strength and band width in
    # reference pixels) is about the same, where per-pixel differences would fall six-fold.
    def disk(side):
        yy, xx = (np.mgrid[0:side, 0:side] + 0.5) / side
        r = np.hypot(yy - 0.5, xx - 0.5)
        gray = 0.8 - 0.5 / (1 + np.exp(-(0.3 - r) * side / (side / 500) / 0.6))  # 0.6 ref-px soft edge
        return edge_map(gray.astype(np.float32))

    small, large = disk(500), disk(3000)
    assert small.max() > 0.3
    assert large.max() == pytest.approx(small.max(), rel=0.1)
    # Band area in reference pixels (36 pixels each at 6×): about as wide on paper at both
    # sizes; the 3-pixel L dilation is not scaled, so the large band is somewhat narrower.
    assert 0.6 < (large > 0.25).sum() / 36 / (small > 0.25).sum() < 1.1


def test_bad_scale_and_floor_are_refused():
    f = np.zeros((8, 8), np.float32)
    with pytest.raises(ValueError):
        edge_map(f, scale=0.5)
    with pytest.raises(ValueError):
        edge_map(f, floor=0.3, full=0.3)


def test_median_removes_salt_but_none_keeps_it():
    f = np.full((15, 15), 0.5, np.float32)
    f[7, 7] = 1.0
    assert not edge_map(f).any()
    assert edge_map(f, denoise="none").any()


def test_stages_chain():
    rng = np.random.default_rng(2)
    gray = rng.random((30, 30), dtype=np.float32) * 0.3
    st_ = gmed_stages(gray, denoise="gaussian", denoise_size=5, magnitude="l1", scale=1.0, full=EDGE_FULL)
    np.testing.assert_array_equal(st_["gradient"], gradient_magnitude(st_["denoised"], "l1"))
    expected = np.clip((dilate(st_["gradient"]) - EDGE_FLOOR) / (EDGE_FULL - EDGE_FLOOR), 0, 1)
    np.testing.assert_allclose(st_["edges"], expected, rtol=1e-5, atol=1e-6)
    # On a larger image the gradient is per reference pixel: averaged, then times the scale.
    big = gmed_stages(np.kron(gray, np.ones((4, 4), np.float32)), denoise="none", scale=4.0)
    assert big["gradient"].max() <= 4 * gradient_magnitude(big["denoised"]).max() + 1e-6
    np.testing.assert_allclose(big["gradient"], 4 * gradient_magnitude(big["denoised"]), rtol=1e-5)


def test_square_edges_follow_boundary_and_are_deterministic():
    f = np.ones((40, 40), np.float32)
    f[10:30, 10:30] = 0.0
    E = edge_map(f)
    assert np.array_equal(E, edge_map(f))
    # The jump is on rows/cols 9 and 29 (forward differences), dilated one pixel right/down;
    # a full black-to-white jump is far above EDGE_FULL, so the edge is full strength.
    assert E[29, 29] == 1
    np.testing.assert_array_equal(E[20, [9, 10, 29, 30]], 1.0)
    assert E[20, 8] == 0 and E[20, 11] == 0 and E[20, 20] == 0
