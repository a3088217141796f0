"""Hatch lines spread evenly across the gaps their ordered dither leaves."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage as ndi

from pencilbot.paths import Paths
from pencilbot.planning import spread
from pencilbot.planning.layout import Layout
from pencilbot.planning.plan import Page
from pencilbot.planning.shading import shade
from pencilbot.planning.spread import GOLDEN, spread_offsets
from pencilbot.render import render_paths


def _drawn(share: float, offset: float, count: int = 600) -> np.ndarray:
    """The levels 0..count−1 the golden dither draws at ``share``."""
    levels = np.arange(count)
    return levels[np.mod(levels * GOLDEN + offset, 1.0) < share]


@settings(max_examples=60, deadline=None)
@given(share=st.floats(0.2, 0.95), offset=st.floats(0.0, 1.0, exclude_max=True))
def test_a_flat_share_s_lines_end_up_more_evenly_spaced_and_in_order(share, offset):
    drawn = _drawn(share, offset)
    moved = drawn + spread_offsets(drawn, np.full(drawn.size, share), offset)
    inner = slice(10, -10)  # (the first and last lines' neighbours beyond the block are not drawn)
    before, after = np.diff(drawn)[inner], np.diff(moved)[inner]
    assert np.all(after > 0)  # no line crosses another
    assert after.std() <= 0.7 * before.std() + 1e-9
    # Lines move within their gaps, not the family as a whole: the mean spacing is kept.
    assert after.mean() == pytest.approx(before.mean(), rel=0.02)
    assert np.all(np.abs(moved - drawn)[inner] < np.maximum(np.diff(drawn)[9:-10], np.diff(drawn)[10:-9]))


def test_every_line_drawn_or_no_neighbour_means_no_move():
    levels = np.arange(-50, 50)
    assert np.all(spread_offsets(levels, np.ones(levels.size), 0.3) == 0.0)
    # A share so small that no neighbour is drawn within reach on one side.
    assert np.all(spread_offsets(levels, np.full(levels.size, 1e-4), 0.3) == 0.0)
    assert spread_offsets(np.zeros(0, np.int64), np.zeros(0), 0.0).size == 0


def _blurred_tone(darkness: float, monkeypatch, step: float):
    """A flat tone hatched on a 60 mm square, drawn by the real rasteriser: its 1 mm blur away from
    the border, its mean and standard deviation."""
    monkeypatch.setattr(spread, "STEP", step)
    layout = Layout.fit((120, 120), Page(width=80, height=80, margin=10))
    layers = shade(np.full((120, 120), darkness), layout, Paths.empty(), pen_width=0.5, form_scale=0.0)
    x0, y0, x1, y1 = layout.drawing_box
    paths = [p for layer in layers for p in layer.paths]
    ink = render_paths(paths, x1 - x0, y1 - y0, dpi=254, pen_width=0.5, origin=(x0, y0))
    seen = ndi.gaussian_filter(ink.astype(np.float64), 10.0)[80:-80, 80:-80]  # 0.1 mm pixels
    return seen.mean(), seen.std()


@pytest.mark.parametrize("darkness", [0.3, 0.5])
def test_spread_lines_show_fewer_stripes_at_a_millimetre_and_lay_the_same_ink(darkness, monkeypatch):
    step = spread.STEP
    plain_mean, plain_std = _blurred_tone(darkness, monkeypatch, 0.0)
    mean, std = _blurred_tone(darkness, monkeypatch, step)
    assert std <= 0.75 * plain_std
    assert mean == pytest.approx(plain_mean, abs=0.02)
