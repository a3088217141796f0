"""The plot carries the sketch's lines (issue 30): where the line drawing has a line the pen's
contours do not draw, the hatching's tone is darker along it."""

from __future__ import annotations

import numpy as np

from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.planning.build import plan_from_sketch
from pencilbot.planning.fidelity import plotted_darkness
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.resolution import at_plot_resolution
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
