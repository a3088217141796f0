"""GMED: forward differences exactly as formula 3, the documented L element and anchor, denoising."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from pencilbot.imaging.gmed import (
    L_ELEMENTS,
    dilate,
    edge_map,
    element_offsets,
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


def test_median_removes_salt_but_none_keeps_it():
    f = np.full((15, 15), 0.5, np.float32)
    f[7, 7] = 1.0
    assert not edge_map(f).any()
    assert edge_map(f, denoise="none").any()


def test_stages_chain():
    rng = np.random.default_rng(2)
    gray = rng.random((30, 30), dtype=np.float32)
    st_ = gmed_stages(gray, denoise="gaussian", denoise_size=5, magnitude="l1")
    np.testing.assert_array_equal(st_["gradient"], gradient_magnitude(st_["denoised"], "l1"))
    dil = dilate(st_["gradient"])
    np.testing.assert_allclose(st_["edges"], dil / dil.max(), rtol=1e-6)


def test_square_edges_follow_boundary_and_are_deterministic():
    f = np.ones((40, 40), np.float32)
    f[10:30, 10:30] = 0.0
    E = edge_map(f)
    assert np.array_equal(E, edge_map(f))
    # The jump is on rows/cols 9 and 29 (forward differences), dilated one pixel right/down.
    # Peak 1 is the corner (29, 29), where gx and gy both jump: straight sides are 1/√2.
    assert E[29, 29] == 1
    np.testing.assert_allclose(E[20, [9, 10, 29, 30]], np.sqrt(0.5), rtol=1e-6)
    assert E[20, 8] == 0 and E[20, 11] == 0 and E[20, 20] == 0
