"""A one-pen plan's plotting (lifts, corners, pen-up travel) within its budget (planning/plot_budget.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.machine.profile import load_profile
from pencilbot.paths import Paths
from pencilbot.planning import build, plot_budget
from pencilbot.planning.build import plan_from_sketch
from pencilbot.planning.contour_budget import OVERFLOW_POWER
from pencilbot.planning.dither import LEVELS, SPARSEST
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.plan import Layer
from pencilbot.planning.plot_budget import (
    CORNER_MM,
    LIFT_MM,
    SECONDS_PER_MM,
    TRAVEL_WEIGHT,
    corners,
    layer_costs,
    lighter_by,
    plot_cost,
    within_plot_budget,
)
from pencilbot.planning.resolution import at_plot_resolution
from pencilbot.planning.shading import FACE_TONE
from pencilbot.planning.stats import estimate
from pencilbot.planning.style import Style

FAST = Style(order_rounds=2, faces=False)
SHEET_CM2 = 100.0  # the 100 x 100 mm page


@pytest.fixture(scope="module")
def busy_bands():
    """Four bands, darkest at the bottom, under a coarse noise texture: many short hatch strokes
    that ordering cannot join, the kind of picture that plots slowly for its ink."""
    rng = np.random.default_rng(3)
    rows = np.repeat(np.array([0.75, 0.6, 0.45, 0.3]), 60)[:, None]
    blobs = np.kron(rng.normal(0, 0.12, (60, 60)), np.ones((4, 4)))
    gray = np.clip(rows + blobs, 0, 1).astype(np.float32)
    image = image_from_array(gray, source="busy bands")
    page = page_size("100x100", "portrait", image.shape, 5.0)
    return sketch(at_plot_resolution(image, page, FAST.pen_width)), page


@pytest.fixture
def no_budgets(monkeypatch):
    monkeypatch.setattr(build, "PEN_DOWN_BUDGET", float("inf"))  # only the plot's budget acts
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", float("inf"))
    monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", float("inf"))


def _band_ink(plan, drawing, page) -> np.ndarray:
    """Pen-down length of the hatching in each band, top (lightest) first."""
    layout = Layout.fit(drawing.gray.shape, page)
    hatch = plan.paths("hatch")
    owner = hatch.owners()
    step = np.diff(hatch.points, axis=0)[owner[1:] == owner[:-1]]
    middle = (hatch.points[1:] + hatch.points[:-1])[owner[1:] == owner[:-1]] / 2
    rows = layout.mm_to_px(middle)[:, 1] / drawing.gray.shape[0]
    return np.bincount(np.clip((rows * 4).astype(int), 0, 3), weights=np.hypot(*step.T), minlength=4)


def test_corners_count_the_sharp_turns_of_each_path_only():
    zigzag = np.array([[0, 0], [10, 0], [10, 1], [0, 1], [0, 2]], float)  # four 90° turns less one end
    gentle = np.array([[0, 0], [10, 0], [20, 3]], float)  # a 17° bend
    assert corners(Paths.of([zigzag])) == 3
    assert corners(Paths.of([gentle])) == 0
    # Two paths end to end: the joint between them is a lift, not a corner.
    assert corners(Paths.of([zigzag[:2], zigzag[2:4][::-1]])) == 0


def test_the_cost_counts_pen_down_corners_lifts_and_weighted_travel():
    first = np.array([[10.0, 0.0], [20.0, 0.0], [20.0, 5.0]])  # 15 mm, one corner
    second = np.array([[20.0, 10.0], [30.0, 10.0]])  # 10 mm
    cost = plot_cost([Layer("hatch0", [first], role="hatch"), Layer("edges", [second], role="edges")])
    travel = 10.0 + 5.0 + np.hypot(30.0, 10.0)  # home to the first, between them, back home
    assert cost.travel == pytest.approx(travel)
    assert cost.total == pytest.approx(25.0 + CORNER_MM + 2 * LIFT_MM + TRAVEL_WEIGHT * travel)
    assert cost.hatch_total == pytest.approx(15.0 + CORNER_MM + LIFT_MM + TRAVEL_WEIGHT * 10.0)
    assert cost.hatch_travel == pytest.approx(10.0)


def test_each_layer_s_part_of_the_cost_is_its_own_and_they_add_up_to_it():
    first = np.array([[10.0, 0.0], [20.0, 0.0], [20.0, 5.0]])  # 15 mm, one corner
    second = np.array([[20.0, 10.0], [30.0, 10.0]])
    third = np.array([[30.0, 12.0], [40.0, 12.0]])
    layers = [
        Layer("hatch0", [first], role="hatch"),
        Layer("empty", [], role="hatch"),
        Layer("edges", [second, third], role="edges"),
    ]
    hatch, edges = layer_costs(layers)  # the empty layer left out
    assert (hatch.name, hatch.paths, edges.name, edges.paths) == ("hatch0", 1, "edges", 2)
    assert (hatch.drawn, hatch.corners, hatch.lifts, hatch.moved) == pytest.approx(
        (15.0, CORNER_MM, LIFT_MM, 10.0)
    )
    # The travel into each path is its own layer's: from the first layer's end, then between its two.
    assert (edges.drawn, edges.corners, edges.lifts) == pytest.approx((20.0, 0.0, 2 * LIFT_MM))
    assert edges.moved == pytest.approx(5.0 + 2.0)
    assert edges.travel == pytest.approx(TRAVEL_WEIGHT * edges.moved)
    home = np.hypot(40.0, 12.0)
    assert plot_cost(layers).total == pytest.approx(hatch.total + edges.total + TRAVEL_WEIGHT * home)
    assert plot_cost(layers).hatch_total == pytest.approx(hatch.total)


def test_the_factor_is_one_within_the_budgets_and_falls_with_the_excess():
    def cost(total: float, travel: float = 0.0):
        return plot_budget.PlotCost(total, travel, 0.8 * total, 0.8 * travel)

    budget = plot_budget.PLOT_BUDGET * SHEET_CM2
    assert lighter_by(cost(0.99 * budget), SHEET_CM2) == 1.0
    factors = [lighter_by(cost(excess * budget), SHEET_CM2) for excess in (1.01, 1.2, 1.5)]
    assert 1.0 > factors[0] > factors[1] > factors[2] > 0.0
    travel = plot_budget.TRAVEL_BUDGET * SHEET_CM2
    assert lighter_by(cost(0.5 * budget, 1.3 * travel), SHEET_CM2) < 1.0  # the pen-up alone


def test_the_cost_follows_the_plot_time_on_the_servo_plotter(busy_bands, no_budgets):
    drawing, page = busy_bands
    plan = plan_from_sketch(drawing, page, FAST)
    seconds = estimate(plan, load_profile("grbl-servo-a4")).total.seconds
    # SECONDS_PER_MM: the fit over 36 photos (docs/faces.md).
    assert plot_cost(plan.layers).total * SECONDS_PER_MM == pytest.approx(seconds, rel=0.1)


# Pen-up travel falls more slowly than the cost as the dashes thin out (they spread over the same
# area): a smaller cut of it.
@pytest.mark.parametrize(("budget", "cut"), [("PLOT_BUDGET", 0.75), ("TRAVEL_BUDGET", 0.85)])
def test_over_the_budget_the_hatching_is_lighter_in_the_same_order(
    busy_bands, no_budgets, monkeypatch, budget, cut
):
    drawing, page = busy_bands
    # (The contours as a plan past its budgets draws them, not roomier: tests/planning/test_contour_room.py.)
    monkeypatch.setattr(build, "ROOMY_OVERFLOW_POWER", OVERFLOW_POWER)
    free = plan_from_sketch(drawing, page, FAST)
    spent = plot_cost(free.layers)
    allowed = cut * (spent.total if budget == "PLOT_BUDGET" else spent.travel)
    monkeypatch.setattr(plot_budget, budget, allowed / SHEET_CM2)
    held = plan_from_sketch(drawing, page, FAST)
    cost = plot_cost(held.layers)
    assert (cost.total if budget == "PLOT_BUDGET" else cost.travel) <= allowed
    assert cost.hatch_total >= 0.3 * spent.hatch_total  # lighter, not blank
    # The contours stay (ordered from where the lighter hatching ends).
    edges, before = held.layer("edges").paths, free.layer("edges").paths
    assert sorted(edges.drawn_lengths().round(6)) == sorted(before.drawn_lengths().round(6))
    ink = _band_ink(held, drawing, page)
    assert np.all(np.diff(ink) > 0)  # darker bands keep more ink than lighter ones


def test_under_the_budget_the_plan_is_the_same_and_ordered_once(busy_bands, no_budgets, monkeypatch):
    drawing, page = busy_bands
    free = plan_from_sketch(drawing, page, FAST)
    spent = plot_cost(free.layers)
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", 1.001 * spent.total / SHEET_CM2)
    monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", 1.001 * spent.travel / SHEET_CM2)
    orderings = []
    ordered = build._ordered
    monkeypatch.setattr(
        build, "_ordered", lambda layers, order: orderings.append(1) or ordered(layers, order)
    )
    again = plan_from_sketch(drawing, page, FAST)
    assert [layer.paths for layer in again.layers] == [layer.paths for layer in free.layers]
    assert len(orderings) == 1


def test_a_time_budget_scales_every_budget_of_the_plan(busy_bands, no_budgets, monkeypatch):
    drawing, page = busy_bands
    free = plan_from_sketch(drawing, page, FAST)
    spent = plot_cost(free.layers)
    hatched = sum(float(layer.paths.drawn_lengths().sum()) for layer in free.layers if layer.role == "hatch")

    def held(time_budget: float, over: float):
        """The plan over ``time_budget``, its pen-down budget at 0.8 of the free plan's hatching
        and its plot's and pen-up budgets at 0.6 of what the free plan spends, each over ``over``."""
        monkeypatch.setattr(build, "PEN_DOWN_BUDGET", 0.8 * hatched / SHEET_CM2 / over)
        monkeypatch.setattr(plot_budget, "PLOT_BUDGET", 0.6 * spent.total / SHEET_CM2 / over)
        monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", 0.6 * spent.travel / SHEET_CM2 / over)
        return plan_from_sketch(drawing, page, replace(FAST, time_budget=time_budget))

    tight = held(1.0, 1.0)
    assert plot_cost(tight.layers).total <= 0.6 * spent.total and tight.meta["time_budget"] == "1"
    # Twice the time over budgets half as large: the same plan, path for path.
    assert [layer.paths for layer in held(2.0, 2.0).layers] == [layer.paths for layer in tight.layers]
    # Twice the time over the same budgets: a darker plan that takes longer, within its double.
    roomy = held(2.0, 1.0)
    assert plot_cost(tight.layers).total < plot_cost(roomy.layers).total <= 1.2 * spent.total
    assert roomy.meta["time_budget"] == "2"


def _layers(face_strokes: int, hatch_scale: float) -> list[Layer]:
    """A hatch layer of 40 strokes 10 mm long (fewer as its tone is lighter) and a faces' layer
    of ``face_strokes`` dots, on a line so that travel is short."""
    hatch = Paths.of([np.array([[x, 0.0], [x, 10.0]]) for x in range(int(40 * hatch_scale))])
    runs = Paths.of([np.array([[x * 0.5, 20.0], [x * 0.5 + 0.5, 20.0]]) for x in range(face_strokes)])
    return [
        Layer("hatch1-0", hatch, pen_width=0.5, role="hatch"),
        Layer(FACE_TONE, runs, pen_width=0.5, role="hatch"),
    ]


def _replanned(strokes: dict) -> tuple[list, object, object]:
    """The plans asked for, a plan's ``redraw`` and ``faces_at`` with ``strokes`` runs at each level."""
    asked: list[tuple[float, object]] = []

    def redraw(scale: float, level) -> list[Layer]:
        asked.append((scale, level))
        return _layers(strokes[level], scale)

    def faces_at(level) -> Paths:
        return _layers(strokes[level], 1.0)[1].paths

    return asked, redraw, faces_at


def test_past_the_budget_the_faces_runs_get_thriftier_before_the_hatching_is_lighter(monkeypatch):
    strokes = dict(zip(LEVELS, np.linspace(70, 30, len(LEVELS)).astype(int).tolist(), strict=True))
    asked, redraw, faces_at = _replanned(strokes)
    # (The foretelling keeps the first plan's travel: a little more than fewer runs travel.)
    within = plot_cost(_layers(strokes[LEVELS[-2]], 1.0)).total
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", 1.02 * within / SHEET_CM2)
    monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", float("inf"))
    kept = within_plot_budget(_layers(strokes[LEVELS[0]], 1.0), redraw, SHEET_CM2, faces_at=faces_at)
    # The runs alone foretell the last level but one within the budget: one plan more, the tone
    # as it is.
    assert asked == [(1.0, LEVELS[-2])]
    assert len(kept[1].paths) == strokes[LEVELS[-2]] and len(kept[0].paths) == 40

    asked.clear()
    tight = plot_cost(_layers(strokes[LEVELS[-1]], 1.0)).total * 0.9
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", tight / SHEET_CM2)
    within_plot_budget(_layers(strokes[LEVELS[0]], 1.0), redraw, SHEET_CM2, faces_at=faces_at)
    assert asked[0] == (1.0, LEVELS[-1])  # no level is enough: the thriftiest, then ...
    assert asked[1][0] < 1.0 and asked[1][1] == LEVELS[-1]  # ... the hatching lighter, still thrifty
    assert plot_cost(_layers(strokes[LEVELS[-1]], asked[-1][0])).total <= tight


def test_a_plan_of_many_faces_still_past_the_budget_takes_the_sparsest_runs(monkeypatch):
    # The faces' runs are most of this plot: no level and no lighter hatching bring it within.
    strokes = {
        **dict(zip(LEVELS, np.linspace(400, 300, len(LEVELS)).astype(int).tolist(), strict=True)),
        SPARSEST: 150,
    }
    asked, redraw, faces_at = _replanned(strokes)
    within = plot_cost(_layers(strokes[SPARSEST], 1.0)).total
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", 1.02 * within / SHEET_CM2)
    monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", float("inf"))
    kept = within_plot_budget(_layers(strokes[LEVELS[0]], 1.0), redraw, SHEET_CM2, faces_at=faces_at)
    assert (1.0, LEVELS[-1]) in asked and asked[-1][1] == SPARSEST  # the thriftiest level first
    assert len(kept[1].paths) == strokes[SPARSEST]
    assert len(kept[0].paths) == 40  # its hatching from its own tone again, within the budget at it
    assert plot_cost(kept).total <= plot_budget.PLOT_BUDGET * SHEET_CM2


def test_far_past_the_budget_the_last_redo_is_not_drawn(monkeypatch):
    # 300 faces' runs cost more than the budget alone: lightening the hatching cannot bring the
    # plan within it, and a last redo would only scale its tone towards nothing (the busy bands
    # above, a little over after two redos, are polished by it).
    asked, redraw, _ = _replanned({LEVELS[0]: 300})
    runs_alone = plot_cost(_layers(300, 0.0)).total
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", 0.9 * runs_alone / SHEET_CM2)
    monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", float("inf"))
    within_plot_budget(_layers(300, 1.0), redraw, SHEET_CM2)
    assert len(asked) == plot_budget.REDOS - 1
    assert all(scale < 1.0 and level == LEVELS[0] for scale, level in asked)


def test_faces_at_another_level_keep_the_hatching_and_order_the_rest_from_its_end():
    hatch, faces, _ = (*_layers(12, 1.0), None)
    edges = Layer("edges", Paths.of([np.array([[50.0, 50.0], [60.0, 50.0]])]), pen_width=0.5, role="edges")
    ordered = build._ordered(
        [hatch, faces, edges], build.Ordering(pen_width=0.5, hatch_join=1.0, min_hatch_run=1.0, rounds=1)
    )
    thrifty = Paths.of(
        [np.array([[3.0 * x, 20.0], [3.0 * x + 0.5, 20.0]]) for x in range(5)]
    )  # apart: no joins
    again = build._with_runs(
        ordered, thrifty, build.Ordering(pen_width=0.5, hatch_join=1.0, min_hatch_run=1.0, rounds=1)
    )
    assert again[0] is ordered[0]  # the hatching as it was
    assert again[1].name == FACE_TONE and len(again[1].paths) == 5
    assert sorted(map(tuple, again[1].paths.points.round(6))) == sorted(map(tuple, thrifty.points.round(6)))
    # Ordered from where the hatching ends: its first run is the one nearest that point.
    end = ordered[0].paths.points[-1]
    first = again[1].paths[0]
    nearest = min(np.hypot(*(tip - end)) for path in thrifty for tip in (path[0], path[-1]))
    assert np.hypot(*(first[0] - end)) == pytest.approx(nearest)
    assert [layer.name for layer in again] == [layer.name for layer in ordered]


def _pale_fixture(monkeypatch, strokes: dict, pale_hatch: float, budget_runs: int):
    """``_replanned`` with a ``paler`` whose hatching keeps ``pale_hatch`` of its strokes, the
    budget just above a plan of ``budget_runs`` runs at full hatching; what was asked, in order."""
    asked, _, faces_at = _replanned(strokes)
    paled: list = []

    def pale_redraw(scale: float, level) -> list[Layer]:
        asked.append((scale, level, "pale" if paled else "plain"))
        return _layers(strokes[level], scale * (pale_hatch if paled else 1.0))

    def paler() -> list[Layer]:
        paled.append(True)
        asked.append((1.0, LEVELS[0], "paler"))
        return _layers(strokes[LEVELS[0]], pale_hatch)

    monkeypatch.setattr(
        plot_budget, "PLOT_BUDGET", 1.02 * plot_cost(_layers(budget_runs, 1.0)).total / SHEET_CM2
    )
    monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", float("inf"))
    return asked, pale_redraw, faces_at, paler


def test_past_the_budget_the_palest_hatching_or_the_thriftier_runs_whichever_is_likelier(monkeypatch):
    strokes = dict(zip(LEVELS, [70, 50, 30], strict=True))
    start = _layers(strokes[LEVELS[0]], 1.0)
    # Both within the budget: the thriftiest runs under the full hatching (40 strokes), and the
    # finest runs under a quarter of it (10); the judge, here fond of one hatching, chooses.
    for hatch, runs in ((10, strokes[LEVELS[0]]), (40, strokes[LEVELS[-1]]), (None, strokes[LEVELS[0]])):
        _, redraw, faces_at, paler = _pale_fixture(monkeypatch, strokes, 0.25, 30)
        kept = within_plot_budget(
            start,
            redraw,
            SHEET_CM2,
            faces_at=faces_at,
            paler=paler,
            judge=None if hatch is None else lambda layers, hatch=hatch: -abs(len(layers[0].paths) - hatch),
        )
        # (Without a judge the pale plan is taken when it is within the budget.)
        assert (len(kept[0].paths), len(kept[1].paths)) == (hatch or 10, runs)
        assert plot_cost(kept).total <= plot_budget.PLOT_BUDGET * SHEET_CM2


def test_past_the_budget_with_both_plans_over_it_the_pale_one_is_lightened(monkeypatch):
    strokes = dict(zip(LEVELS, [70, 60, 50], strict=True))
    # A budget of 10 runs at full hatching: no level and no pale hatching alone brings it within.
    asked, redraw, faces_at, paler = _pale_fixture(monkeypatch, strokes, 0.8, 10)
    kept = within_plot_budget(
        _layers(strokes[LEVELS[0]], 1.0),
        redraw,
        SHEET_CM2,
        faces_at=faces_at,
        paler=paler,
        judge=lambda _: 0.0,
    )
    after = asked[asked.index((1.0, LEVELS[0], "paler")) + 1 :]
    # The pale plan's runs thriftiest, then its hatching lighter by what the pale plan costs
    # (not by what the full hatching's plan cost).
    assert after[0] == (1.0, LEVELS[-1], "pale")
    pale_thrifty = plot_cost(_layers(strokes[LEVELS[-1]], 0.8))
    assert after[1][0] == pytest.approx(lighter_by(pale_thrifty, SHEET_CM2))
    assert len(kept[0].paths) < 40 * 0.8
