"""A close portrait's faces within what half an hour of plotting affords (planning/face_budget.py)."""

from __future__ import annotations

import numpy as np

from pencilbot.paths import Paths
from pencilbot.planning.dither import LEVELS, face_runs
from pencilbot.planning.face_budget import FACE_BUDGET, run_cost, thriftier, within_budget
from pencilbot.planning.layout import Layout
from pencilbot.planning.plan import Page
from pencilbot.planning.shading import FACE_TONE, shade

PEN = 0.5


def _layout() -> Layout:
    return Layout.fit((120, 120), Page(80.0, 80.0, margin=10.0))  # a 60 mm drawing on 64 cm²


def _face(share: float) -> np.ndarray:
    """A square face over ``share`` of the 120 px drawing, centred."""
    face = np.zeros((120, 120), np.float32)
    half = round(60 * np.sqrt(share))
    face[60 - half : 60 + half, 60 - half : 60 + half] = 1.0
    return face


def _runs(darkness: np.ndarray, face: np.ndarray) -> Paths:
    layers = shade(darkness, _layout(), Paths.empty(), pen_width=PEN, dithered=face, rounds=1)
    return next(layer.paths for layer in layers if layer.name == FACE_TONE)


def test_a_face_that_fills_a_sheet_is_drawn_lighter_within_the_budget():
    dark = np.full((120, 120), 0.85, np.float32)
    face = _face(1.0)
    allowed = FACE_BUDGET * 64.0
    # As the runs were drawn before (the faces' tone as it is): well past the budget.
    before = face_runs(dark, face, _layout(), Paths.empty(), pen_width=PEN, blank_below=0.04, paper=dark)
    assert run_cost(before) > 1.3 * allowed
    runs = _runs(dark, face)
    assert run_cost(runs) <= 1.05 * allowed < run_cost(before)
    assert len(runs) > 0  # lighter, not bare


def test_faces_within_the_budget_are_drawn_as_they_are():
    grey = np.full((120, 120), 0.5, np.float32)
    face = _face(0.1)
    before = face_runs(grey, face, _layout(), Paths.empty(), pen_width=PEN, blank_below=0.04, paper=grey)
    assert run_cost(before) < FACE_BUDGET * 64.0
    assert np.array_equal(_runs(grey, face).points, before.points)


def test_the_scale_is_one_at_the_budget_and_falls_continuously_past_it():
    def scales_for(length: float) -> list[float]:
        asked: list[float] = []

        def draw(scale: float, bias: float) -> Paths:
            asked.append(scale)
            return Paths.of([np.array([[0.0, 0.0], [length, 0.0]])])

        within_budget(draw, 1021.0 / FACE_BUDGET)  # a budget of 1021 mm: 1000 mm and one lift
        return asked

    assert scales_for(1000.0) == [1.0]
    assert scales_for(1001.0)[1] > 0.999  # no step past the budget
    assert scales_for(2021.0)[:2] == [1.0, 0.5**0.75]


def test_past_the_budget_the_runs_get_thriftier_before_the_faces_get_lighter():
    asked: list[tuple[float, object]] = []

    def draw(scale: float, level) -> Paths:
        asked.append((scale, level))
        # Each thriftier level saves a lift's worth; still past the budget until the tone falls.
        return Paths.of([np.array([[0.0, 0.0], [2000.0 * scale - 30.0 * len(asked), 0.0]])])

    within_budget(draw, 1021.0 / FACE_BUDGET, thriftier(LEVELS[0]))
    assert [level for _, level in asked[: len(LEVELS)]] == list(LEVELS)
    assert all(scale == 1.0 for scale, _ in asked[: len(LEVELS)])  # the tone as it is meanwhile
    assert asked[len(LEVELS)][0] < 1.0 and asked[len(LEVELS)][1] == LEVELS[-1]


def test_runs_within_the_budget_at_a_thriftier_level_keep_their_tone():
    asked: list[tuple[float, object]] = []

    def draw(scale: float, level) -> Paths:
        asked.append((scale, level))
        return Paths.of([np.array([[0.0, 0.0], [1000.0 - 100.0 * len(asked), 0.0]])])  # 900, 800, ...

    within_budget(draw, 821.0 / FACE_BUDGET, thriftier(LEVELS[0]))  # 800 mm and one lift
    assert asked == [(1.0, LEVELS[0]), (1.0, LEVELS[1])]
    assert thriftier(LEVELS[1]) == LEVELS[1:]
