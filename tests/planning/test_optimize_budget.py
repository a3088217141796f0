"""Issue 35's reordering: the search runs to its local optimum on a drawing of any kind (the two
rounds it had stopped a flow field half-way), small layers start from nearest neighbour alone,
and a time budget lifts the cap on huge layers' rounds (and stops the search when spent)."""

import time

import numpy as np

from pencilbot.paths import Paths
from pencilbot.planning.optimize import REORDER_ROUNDS, pen_up_length, reorder_plan
from pencilbot.planning.ordering import improve_order
from pencilbot.planning.plan import Layer, Page, Plan

PAGE = Page(210.0, 297.0, 10.0, "A4")


def _flow_field(count: int, seed: int = 11):
    """Streamlines of a smooth field grown from random seeds, in the order grown."""
    rng = np.random.default_rng(seed)
    lines = []
    for p in rng.uniform([20, 20], [190, 277], (count, 2)):
        line = [p]
        for _ in range(rng.integers(10, 40)):
            angle = np.sin(p[0] / 23.0) * 2.0 + np.cos(p[1] / 31.0) * 2.0
            p = p + 0.8 * np.array([np.cos(angle), np.sin(angle)])
            line.append(p)
        lines.append(np.array(line))
    return lines


def _travel(plan, home=(0.0, 0.0)) -> float:
    return pen_up_length(plan.paths(), home)


def test_the_default_search_ends_near_its_local_optimum():
    plan = Plan(PAGE, [Layer("flow", _flow_field(600), pen_width=0.5)])
    default = _travel(reorder_plan(plan).plan)
    converged = _travel(reorder_plan(plan, rounds=200).plan)
    two = _travel(reorder_plan(plan, rounds=2).plan)
    assert REORDER_ROUNDS >= 10
    assert default <= converged * 1.01  # two rounds stopped about 7 % short of it
    assert two > default * 1.01


def test_a_small_layer_is_ordered_well_from_nearest_neighbour_alone():
    rng = np.random.default_rng(5)
    a = rng.uniform(0, 200, (60, 2))
    paths = [np.array([p, p + rng.uniform(-3, 3, 2)]) for p in a]
    order, reverse = improve_order(
        np.array([p[0] for p in paths]),
        np.array([p[-1] for p in paths]),
        (0.0, 0.0),
        rounds=REORDER_ROUNDS,
        matching_from=256,
    )
    assert sorted(order.tolist()) == list(range(60)) and len(reverse) == 60
    plan = Plan(PAGE, [Layer("dots", paths, pen_width=0.1)])
    shuffled = _travel(plan)
    assert _travel(reorder_plan(plan).plan) < 0.5 * shuffled


def test_a_time_budget_lifts_the_cap_on_huge_layers_and_a_spent_one_stops_the_search(monkeypatch):
    from pencilbot.planning import ordering

    monkeypatch.setattr(ordering, "ROUND_WORK", 2000)  # 5000 paths are then "huge": capped at 2 rounds
    rng = np.random.default_rng(2)
    count = 5000
    a = rng.uniform(0, 200, (count, 2))
    b = a + rng.uniform(-1, 1, a.shape)
    paths = Paths(np.stack([a, b], axis=1).reshape(-1, 2), np.arange(0, 2 * count + 1, 2))
    plan = Plan(PAGE, [Layer("bits", paths, pen_width=0.01)])
    capped = _travel(reorder_plan(plan, rounds=40).plan)
    budget = _travel(reorder_plan(plan, rounds=40, time_budget=1e4).plan)  # never reached: ends by rounds
    assert budget < capped * 0.99
    first, last = paths.firsts, paths.lasts
    spent = improve_order(first, last, (0.0, 0.0), rounds=40, deadline=time.process_time() - 1.0)
    none = improve_order(first, last, (0.0, 0.0), rounds=0)
    assert all(np.array_equal(x, y) for x, y in zip(spent, none))  # no improvement once the budget is out
