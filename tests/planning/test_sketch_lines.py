"""The plot carries the sketch's lines (issue 30): where the line drawing has a line the pen's
contours do not draw, the hatching's tone is darker along it."""

from __future__ import annotations

import cv2
import numpy as np
import skimage.data

from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.planning import sketch_tone
from pencilbot.planning.build import plan_from_sketch
from pencilbot.planning.fidelity import likeness, pearson, plotted_darkness
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.resolution import at_plot_resolution
from pencilbot.planning.sketch_tone import FOLLOW_SKETCH, SKETCH_LINES, sketch_darkness
from pencilbot.planning.style import Style


def test_a_line_of_the_sketch_without_a_contour_is_drawn_as_tone_along_it():
    # Two flat greys side by side: the tone target is flat on each side, the line drawing has
    # its line along the boundary. No contour is drawn (threshold out of reach).
    photo = np.full((200, 200), 0.75, np.float32)
    photo[:, 100:] = 0.45
    image = image_from_array(photo)
    page = page_size("A5", "portrait", image.shape, 10.0)
    style = Style(order_rounds=1, edge_threshold=1e9, faces=False)
    drawing = sketch(at_plot_resolution(image, page, style.pen_width))
    assert (1.0 - drawing.line.drawing)[:, 96:104].max() > 0.5  # the sketch's line is there
    plan = plan_from_sketch(drawing, page, style)
    assert not len(plan.layers[-1].paths)  # and the pen draws no contour
    layout = Layout.fit(drawing.gray.shape, page)
    ink = plotted_darkness(plan.paths(), layout.drawing_box, pen_width=style.pen_width).mean(axis=0)
    middle = ink.size // 2
    beside, light = ink[middle - 25 : middle].mean(), ink[ink.size // 10 : 4 * ink.size // 10].mean()
    # Along the line (2.5 mm on its light side) the hatching lays clearly more than on the flat
    # light grey: without the line's share of the tone (SKETCH_LINES = 0) 0.10 against 0.05.
    assert beside - light > 0.08


def _sketch_of(name: str):
    """A real picture's sketch on A5 and its pixels per mm."""
    picture = np.asarray(getattr(skimage.data, name)(), np.float32)
    image = image_from_array((picture - picture.min()) / np.ptp(picture))  # its full range
    page = page_size("A5", "portrait", image.shape, 10.0)
    drawing = sketch(at_plot_resolution(image, page, Style().pen_width))
    return drawing, page, 1.0 / Layout.fit(drawing.gray.shape, page).mm_per_px


def _follows(darkness: np.ndarray, drawing, px_per_mm: float) -> float:
    blur = (0, 0), px_per_mm
    return pearson(cv2.GaussianBlur(darkness, *blur), cv2.GaussianBlur(1.0 - drawing.result, *blur))


def test_a_busy_picture_lays_more_of_its_lines_until_its_tone_follows_the_sketch():
    # Bricks: the sketch is mostly mortar lines; the tone target alone departs from it.
    drawing, _, px_per_mm = _sketch_of("brick")
    lines = 1.0 - drawing.line.drawing
    usual = 1.0 - drawing.tone * (1.0 - np.float32(SKETCH_LINES) * lines)
    assert _follows(usual, drawing, px_per_mm) < FOLLOW_SKETCH - 0.03
    darkness = sketch_darkness(drawing, px_per_mm)
    assert _follows(darkness, drawing, px_per_mm) >= FOLLOW_SKETCH
    # More of the lines, never less: darker along them, the same where there is none.
    along = lines > 0.5
    assert (darkness[along] - usual[along]).mean() > 0.02
    np.testing.assert_allclose(darkness[lines == 0], usual[lines == 0], atol=1e-6)


def test_a_picture_whose_tone_follows_its_sketch_keeps_the_usual_share_of_lines():
    drawing, _, px_per_mm = _sketch_of("rocket")
    usual = 1.0 - drawing.tone * (1.0 - np.float32(SKETCH_LINES) * (1.0 - drawing.line.drawing))
    np.testing.assert_array_equal(sketch_darkness(drawing, px_per_mm), usual)


def test_the_plot_of_a_busy_picture_follows_its_sketch_more_closely(monkeypatch):
    drawing, page, _ = _sketch_of("brick")
    style = Style(order_rounds=1, faces=False)

    def against_sketch() -> float:
        plan = plan_from_sketch(drawing, page, style)
        layout = Layout.fit(drawing.gray.shape, page)
        plotted = plotted_darkness(plan.paths(), layout.drawing_box, pen_width=style.pen_width)
        return likeness(plotted, 1.0 - drawing.result).r

    now = against_sketch()
    monkeypatch.setattr(sketch_tone, "FOLLOW_SKETCH", 0.0)  # the usual share alone
    assert now > against_sketch() + 0.01
