"""Fidelity figures fall when the plan stops drawing its sketch."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest
from skimage import data

from pencilbot.imaging.io import image_from_array
from pencilbot.planning.build import sketch_and_plan
from pencilbot.planning.fidelity import fidelity, sheet_likeness
from pencilbot.planning.layout import Layout


@pytest.fixture(scope="module")
def planned():
    return sketch_and_plan(image_from_array(data.camera()[::2, ::2]), style="default")


def test_a_plan_is_faithful_to_its_own_sketch(planned):
    drawing, plan = planned
    faithful = fidelity(plan, drawing)
    assert faithful.line_r > 0.8 and faithful.tone_r > 0.85 and faithful.tone_mae < 0.1


def test_shifted_edges_and_missing_hatching_lower_the_figures(planned):
    drawing, plan = planned
    good = fidelity(plan, drawing)
    shifted = dataclasses.replace(
        plan,
        layers=[
            dataclasses.replace(layer, paths=[p + (4.0, -3.0) for p in layer.paths]) for layer in plan.layers
        ],
    )
    edges_only = dataclasses.replace(plan, layers=[plan.layer("edges")])
    assert fidelity(shifted, drawing).line_r < good.line_r - 0.3
    assert fidelity(edges_only, drawing).tone_mae > good.tone_mae + 0.05


def test_the_planning_judge_prefers_the_plan_that_looks_like_the_photo(planned):
    drawing, plan = planned
    layout = Layout.fit(drawing.gray.shape, plan.page)
    good = sheet_likeness(plan.layers, layout, drawing)
    assert good > 1.8  # rho against the photo plus r against the sketch, each near 1
    # The same strokes a centimetre off, or only the contours: less alike.
    shifted = [
        dataclasses.replace(layer, paths=layer.paths.with_points(layer.paths.points + 10.0))
        for layer in plan.layers
    ]
    assert sheet_likeness(shifted, layout, drawing) < good - 0.3
    assert sheet_likeness([plan.layer("edges")], layout, drawing) < good - 0.2


def test_a_blank_photo_has_no_line_figure_and_no_warning():
    # A white page has no edges: r is undefined, said as NaN instead of numpy's divide warning.
    drawing, plan = sketch_and_plan(image_from_array(np.ones((40, 40), np.float32)), style="default")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        faithful = fidelity(plan, drawing)
    assert math.isnan(faithful.line_r) and math.isfinite(faithful.tone_mae)
