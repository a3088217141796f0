"""Flat backdrops drawn flat (issue 30): no rings of hatching round a head on a plain backdrop."""

from __future__ import annotations

import numpy as np

from pencilbot.paths import Paths
from pencilbot.planning.backdrop import own_structure
from pencilbot.planning.layout import Layout
from pencilbot.planning.plan import Page
from pencilbot.planning.shading import shade


def _head_on_a_backdrop(n: int = 200) -> tuple[np.ndarray, Layout]:
    """A dark disc (a head, 25 mm across) on an even grey backdrop, 0.5 mm a pixel."""
    rows, cols = np.mgrid[0:n, 0:n]
    picture = np.full((n, n), 0.45, np.float32)
    picture[np.hypot(rows - n / 2, cols - n / 2) < 25] = 0.85
    return picture, Layout.fit((n, n), Page(120.0, 120.0, margin=10.0))


def _directions_round_the_head(layers, layout: Layout, near: float, far: float) -> np.ndarray:
    """|cos| of the angle each hatch segment of the first family makes with the page's 45°,
    for segments between ``near`` and ``far`` mm from the head's rim."""
    x0, y0, x1, y1 = layout.drawing_box
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
    paths = [p for p in layers[0].paths if len(p) > 1]
    steps = np.concatenate([np.diff(p, axis=0) for p in paths])
    mids = np.concatenate([(p[1:] + p[:-1]) / 2 for p in paths])
    rim = np.linalg.norm(mids - centre, axis=1) - 12.5
    ring = (rim > near) & (rim < far)
    diagonal = np.array([1.0, 1.0]) / np.sqrt(2)
    return np.abs(steps[ring] @ diagonal) / np.linalg.norm(steps[ring], axis=1)


def test_the_backdrop_round_a_head_is_hatched_straight_not_in_rings():
    picture, layout = _head_on_a_backdrop()
    layers = shade(picture, layout, Paths.empty(), pen_width=0.5, rounds=1)
    along = _directions_round_the_head(layers, layout, 4.0, 30.0)
    assert along.size > 100
    # Straight, parallel lines at the default 45° (rings would run every way round the head).
    assert np.quantile(along, 0.1) > 0.95


def test_a_form_of_its_own_is_still_followed():
    # A cheek's shading, a slope of darkness of 0.01 a millimetre: the hatching follows it.
    cell = 2.0
    gx = np.full((30, 30), 0.01)
    assert np.all(own_structure(gx, np.zeros_like(gx), cell, calm=0.008) == 1.0)
    # An even backdrop has none; and with calm off (straight hatching) nothing is followed.
    flat = np.zeros((30, 30))
    assert np.all(own_structure(flat, flat, cell, calm=0.008) == 0.0)
    assert np.all(own_structure(gx, flat, cell, calm=np.inf) == 0.0)
