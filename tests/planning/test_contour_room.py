"""A one-pen plan's contours past their budget: the budget itself where the sheet affords them
(:data:`pencilbot.planning.contour_budget.ROOMY_OVERFLOW_POWER`), fewer where it does not."""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np
import pytest

from pencilbot.imaging.faces import Face
from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.planning import build, plot_budget
from pencilbot.planning.build import plan_from_sketch
from pencilbot.planning.contour_budget import OVERFLOW_POWER
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.plot_budget import plot_cost
from pencilbot.planning.resolution import at_plot_resolution
from pencilbot.planning.style import Style

#: The default contour budget (5 mm per cm²), which the picture below overflows threefold.
BUSY = Style(order_rounds=2, faces=False, edge_budget=5.0)
SHEET_CM2 = 100.0


@pytest.fixture(scope="module")
def street():
    """Forty light and dark boxes on a mid grey, outlined: more contour than the budget allows."""
    rng = np.random.default_rng(7)
    gray = np.full((240, 240), 0.55, np.float32)
    for _ in range(40):
        x, y = rng.integers(0, 220, 2)
        w, h = rng.integers(12, 40, 2)
        cv2.rectangle(gray, (int(x), int(y)), (int(x + w), int(y + h)), float(rng.choice([0.15, 0.9])), -1)
    image = image_from_array(gray, source="street")
    page = page_size("100x100", "portrait", image.shape, 5.0)
    return sketch(at_plot_resolution(image, page, BUSY.pen_width)), page


@pytest.fixture
def no_budgets(monkeypatch):
    monkeypatch.setattr(build, "PEN_DOWN_BUDGET", float("inf"))
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", float("inf"))
    monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", float("inf"))


def _lean(monkeypatch, drawing, page):
    """The plan with the contours a sheet past its budgets gets (the overflow rule's)."""
    with monkeypatch.context() as patch:
        patch.setattr(build, "ROOMY_OVERFLOW_POWER", OVERFLOW_POWER)
        return plan_from_sketch(drawing, page, BUSY)


def _hatch_mm(plan) -> float:
    return float(plan.paths("hatch").drawn_lengths().sum())


def _contour_mm(plan) -> float:
    return float(plan.layer("edges").paths.drawn_lengths().sum())


def test_a_sheet_that_affords_them_draws_its_contours_to_their_budget(street, no_budgets, monkeypatch):
    drawing, page = street
    roomy, lean = plan_from_sketch(drawing, page, BUSY), _lean(monkeypatch, drawing, page)
    area = Layout.fit(drawing.gray.shape, page).drawing_box
    allowed = BUSY.edge_budget / 100 * (area[2] - area[0]) * (area[3] - area[1])  # mm
    assert _contour_mm(roomy) > 2.0 * _contour_mm(lean) > 0  # the overflow rule kept a fraction
    assert _contour_mm(roomy) <= 1.3 * allowed  # and the budget still holds (drawn, with joins)
    # The hatching makes room for their ink (the tone loop counts it).
    assert _hatch_mm(roomy) < _hatch_mm(lean)


def test_past_its_budget_with_them_a_plan_keeps_the_fewer_contours(street, no_budgets, monkeypatch):
    drawing, page = street
    roomy, lean = plan_from_sketch(drawing, page, BUSY), _lean(monkeypatch, drawing, page)
    spent, lean_spent = plot_cost(roomy.layers), plot_cost(lean.layers)
    assert spent.total > lean_spent.total
    # A plot budget the plan affords with the fewer contours, not with all of them: it is that plan.
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", (spent.total + lean_spent.total) / 2 / SHEET_CM2)
    held = plan_from_sketch(drawing, page, BUSY)
    assert [layer.paths for layer in held.layers] == [layer.paths for layer in lean.layers]
    # With twice the time (the style's time_budget) the same sheet affords them.
    longer = plan_from_sketch(drawing, page, replace(BUSY, time_budget=2.0))
    assert [layer.paths for layer in longer.layers] == [layer.paths for layer in roomy.layers]


def test_a_portrait_keeps_the_overflow_rules_contours(street, no_budgets, monkeypatch):
    """A picture whose faces' runs cover 2 % of the drawing or more is a portrait: its plot budget
    is its faces', and its contours are the overflow rule's even where the sheet affords more."""
    drawing, page = street
    side = 80.0  # px of the 240 px picture: its face mask is about a tenth of the drawing
    monkeypatch.setattr(build, "find_faces", lambda picture: [Face(80.0, 80.0, side, 1.0)])
    portrait = replace(BUSY, faces=True)
    drawn = plan_from_sketch(drawing, page, portrait)
    with monkeypatch.context() as patch:
        patch.setattr(build, "ROOMY_OVERFLOW_POWER", OVERFLOW_POWER)
        lean = plan_from_sketch(drawing, page, portrait)
    assert drawn.meta["faces"] != "none" and len(drawn.layer("face-tone").paths)
    assert [layer.paths for layer in drawn.layers] == [layer.paths for layer in lean.layers]
    # Smaller than that, the same face is a detail of a scene: the contours get their budget (the
    # face's own contours left to its runs: about 1.4 times the overflow rule's here).
    monkeypatch.setattr(build, "PORTRAIT_SHARE", 0.5)
    assert _contour_mm(plan_from_sketch(drawing, page, portrait)) > 1.25 * _contour_mm(lean)


def test_a_draft_shows_the_contours_its_plan_draws(street, no_budgets, monkeypatch):
    """The studio's first preview (a draft, unordered) tries the contours the plan tries first."""
    drawing, page = street
    final, lean = plan_from_sketch(drawing, page, BUSY), _lean(monkeypatch, drawing, page)
    draft = plan_from_sketch(drawing, page, BUSY, draft=True)
    assert draft.meta["draft"] == "unordered"
    # The same contours (the plan's are joined where they touch, which adds under a pen width).
    assert _contour_mm(draft) == pytest.approx(_contour_mm(final), rel=0.02)
    assert _contour_mm(draft) > 2.0 * _contour_mm(lean)
    # Past the pen-down budget with them, the draft shows the overflow rule's, as the plan draws.
    monkeypatch.setattr(build, "PEN_DOWN_BUDGET", 1.0)
    draft = plan_from_sketch(drawing, page, BUSY, draft=True)
    assert _contour_mm(draft) == pytest.approx(_contour_mm(plan_from_sketch(drawing, page, BUSY)), rel=0.02)
    assert _contour_mm(draft) == pytest.approx(_contour_mm(lean), rel=0.02)
