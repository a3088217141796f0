"""Reordering a finished drawing: nothing lost, nothing drawn twice, pen-up never longer."""

from collections import Counter

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.paths import Paths
from pencilbot.planning.optimize import pen_up_length, reorder_plan, specks
from pencilbot.planning.ordering import order_paths
from pencilbot.planning.plan import Layer, Page, Plan


def segments(paths) -> Counter:
    """Every drawn segment of non-zero length, as an unordered pair of points."""
    out = Counter()
    for path in paths:
        for a, b in zip(map(tuple, path[:-1]), map(tuple, path[1:])):
            if a != b:
                out[min(a, b), max(a, b)] += 1
    return out


def ink_length(path) -> float:
    return float(np.hypot(*np.diff(path, axis=0).T).sum())


def distance_to(points, paths) -> np.ndarray:
    """Distance from each point to the nearest segment (or dot) of ``paths``."""
    best = np.full(len(points), np.inf)
    for path in paths:
        a, b = (path[:-1], path[1:]) if len(path) > 1 else (path, path)
        ab = b - a
        t = np.clip(np.einsum("pk,sk->ps", points, ab) - np.einsum("sk,sk->s", a, ab), 0, None)
        t = np.minimum(t / np.maximum(np.einsum("sk,sk->s", ab, ab), 1e-300), 1.0)
        nearest = a[None] + t[..., None] * ab[None]
        best = np.minimum(best, np.hypot(*(points[:, None] - nearest).transpose(2, 0, 1)).min(axis=1))
    return best


coordinate = st.integers(0, 60).map(lambda v: v / 2.0)  # a coarse grid: ends often meet exactly
point = st.tuples(coordinate, coordinate)
path = st.lists(point, min_size=1, max_size=5).map(lambda pts: np.array(pts, float))
layer = st.tuples(st.lists(path, max_size=25), st.sampled_from([0.3, 0.5, 1.0]))


@settings(max_examples=150, deadline=None)
@given(st.lists(layer, min_size=1, max_size=3), st.tuples(coordinate, coordinate))
def test_reordering_loses_nothing_draws_nothing_twice_and_never_travels_further(layers, home):
    plan = Plan(Page(40, 40), [Layer(f"l{i}", ps, pen_width=w) for i, (ps, w) in enumerate(layers)])
    result = reorder_plan(plan, start=home)
    assert pen_up_length(result.plan.paths(), home) <= pen_up_length(plan.paths(), home) + 1e-9
    assert [(l.name, l.pen_width, l.role) for l in result.plan.layers] == [
        (l.name, l.pen_width, l.role) for l in plan.layers
    ]
    dropped_total = 0
    for before, after in zip(plan.layers, result.plan.layers):
        speck = (
            np.zeros(len(before.paths), bool)
            if after.paths == before.paths
            else specks(before.paths, before.pen_width)
        )
        kept = [p for p, s in zip(before.paths, speck) if not s]
        for dropped in (p for p, s in zip(before.paths, speck) if s):  # specks only: short, on another line
            assert ink_length(dropped) < before.pen_width
            others = [p for p in kept if ink_length(p) >= before.pen_width]
            assert distance_to(dropped, others).max() <= before.pen_width / 2 + 1e-9
        dropped_total += int(speck.sum())
        want, got = segments(kept), segments(after.paths)
        assert not want - got  # every segment is still drawn...
        extra = got - want  # ...and what is new is only the joins, each within a pen width
        assert all(np.hypot(*np.subtract(a, b)) <= before.pen_width + 1e-9 for a, b in extra.elements())
        assert sum(extra.values()) <= len(kept) - len(after.paths)
        assert sum(len(p) for p in after.paths) <= sum(len(p) for p in kept)  # no point made up
        dots = {tuple(p[0]) for p in kept if len(p) == 1}
        assert dots <= set(map(tuple, after.paths.points))  # every dot still there (two in one place: one)
    assert dropped_total == result.specks


def test_an_ordered_drawing_is_not_made_worse():
    rng = np.random.default_rng(4)
    strokes = list(rng.uniform(0, 200, (400, 2, 2)))
    ordered = order_paths(Paths.of(strokes), start=(0, 0), join_tolerance=-1)
    plan = Plan(Page(200, 200), [Layer("a", ordered, pen_width=0.01)])
    again = reorder_plan(plan, start=(0, 0)).plan
    assert pen_up_length(again.paths(), (0, 0)) <= pen_up_length(plan.paths(), (0, 0))


def test_a_shuffled_drawing_gets_much_shorter_and_layers_chain_from_home():
    rng = np.random.default_rng(5)
    strokes = [rng.uniform(0, 200, 2) + np.cumsum(rng.normal(0, 1, (4, 2)), axis=0) for _ in range(600)]
    plan = Plan(Page(200, 200), [Layer("a", strokes[:300]), Layer("b", strokes[300:])])
    result = reorder_plan(plan, start=(200, 0)).plan
    assert pen_up_length(result.paths(), (200, 0)) < 0.2 * pen_up_length(plan.paths(), (200, 0))
    # The first path starts near home; layer b starts near where layer a ended.
    firsts = plan.layer("a").paths.firsts
    assert (
        np.hypot(*(result.layer("a").paths.firsts[0] - (200, 0)))
        <= np.hypot(*(np.concatenate([firsts, plan.layer("a").paths.lasts]) - (200, 0)).T).min() + 1e-9
    )
    end_a = result.layer("a").paths.points[-1]
    ends_b = np.concatenate([plan.layer("b").paths.firsts, plan.layer("b").paths.lasts])
    assert np.hypot(*(result.layer("b").paths.firsts[0] - end_a)) <= np.sort(np.hypot(*(ends_b - end_a).T))[5]


def test_a_covered_speck_goes_and_an_isolated_dot_stays():
    line = np.array([[0.0, 0.0], [10.0, 0.0]])
    covered = np.array([[4.0, 0.2], [4.3, 0.1]])  # within 0.25 mm of the line, 0.32 mm long
    beside = np.array([[4.0, 0.4], [4.3, 0.4]])  # 0.4 mm away: its ink shows
    dot = np.array([[5.0, 5.0]])
    on_line = np.array([[7.0, 0.0]])  # a dot on the line: covered
    assert specks(Paths.of([line, covered, beside, dot, on_line]), 0.5).tolist() == [
        False,
        True,
        False,
        False,
        True,
    ]
    assert not specks(Paths.of([covered, dot]), 0.5).any()  # nothing long to cover them


@pytest.mark.parametrize("pen", [0.2, 0.3, 2.0])
def test_ends_within_the_pen_width_are_joined(pen):
    a = np.array([[0.0, 0.0], [10.0, 0.0]])
    b = np.array([[10.25, 0.0], [20.0, 0.0]])
    result = reorder_plan(Plan(Page(30, 30), [Layer("a", [b, a], pen_width=pen)])).plan
    assert len(result.paths()) == (1 if pen >= 0.25 else 2)
