"""A one-pen plan stays within its pen-down budget by drawing every tone lighter by one factor."""

from __future__ import annotations

import numpy as np
import pytest

from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.planning import build
from pencilbot.planning.build import plan_from_sketch
from pencilbot.planning.layout import page_size
from pencilbot.planning.resolution import at_plot_resolution
from pencilbot.planning.style import Style

FAST = Style(order_rounds=2, faces=False)


@pytest.fixture(scope="module")
def dark_steps():
    # Four dark bands, darkest at the bottom, with a little texture so the tone has forms.
    rng = np.random.default_rng(1)
    rows = np.repeat(np.array([0.45, 0.35, 0.25, 0.15]), 60)[:, None]
    gray = np.clip(rows + rng.normal(0, 0.02, (240, 240)), 0, 1).astype(np.float32)
    image = image_from_array(gray, source="dark steps")
    page = page_size("100x100", "portrait", image.shape, 5.0)
    return sketch(at_plot_resolution(image, page, FAST.pen_width)), page


def _pen_down(plan) -> float:
    return sum(float(layer.paths.drawn_lengths().sum()) for layer in plan.layers)


def _band_ink(plan, drawing, page):
    from pencilbot.planning.layout import Layout

    layout = Layout.fit(drawing.gray.shape, page)
    paths = plan.paths()
    rows = layout.mm_to_px(paths.points)[:, 1] / drawing.gray.shape[0]
    return np.bincount(np.clip((rows * 4).astype(int), 0, 3), minlength=4)


def test_over_the_budget_the_tone_is_lighter_in_the_same_order(dark_steps, monkeypatch):
    drawing, page = dark_steps
    free = plan_from_sketch(drawing, page, FAST)
    used = _pen_down(free)
    monkeypatch.setattr(build, "PEN_DOWN_BUDGET", 0.6 * used / (100 * 100 / 100))  # per cm² of the sheet
    held = plan_from_sketch(drawing, page, FAST)
    assert _pen_down(held) <= 0.6 * used * 1.15  # one more shading, aimed at the budget
    assert _pen_down(held) >= 0.3 * used  # lighter, not blank
    # Darker bands keep more ink than lighter ones (points per band, top band lightest).
    ink = _band_ink(held, drawing, page)
    assert np.all(np.diff(ink) > 0)


def test_under_the_budget_nothing_changes(dark_steps, monkeypatch):
    drawing, page = dark_steps
    monkeypatch.setattr(build, "PEN_DOWN_BUDGET", float("inf"))  # (dark steps pass the shipped budget)
    free = plan_from_sketch(drawing, page, FAST)
    monkeypatch.setattr(build, "PEN_DOWN_BUDGET", 10 * _pen_down(free))
    again = plan_from_sketch(drawing, page, FAST)
    assert [layer.paths for layer in again.layers] == [layer.paths for layer in free.layers]
