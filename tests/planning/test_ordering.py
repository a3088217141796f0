"""Ordering: a permutation with optional reversal, never worse than greedy, joins what touches."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.planning.ordering import greedy_order, join_touching, order_paths, travel_length

coord = st.floats(-50, 250, allow_nan=False)
path = st.lists(st.tuples(coord, coord), min_size=1, max_size=5).map(np.array)
paths = st.lists(path, min_size=0, max_size=60)
start = st.tuples(coord, coord)


def canonical(p):
    """A path and its reverse compare equal."""
    a, b = tuple(map(tuple, p)), tuple(map(tuple, p[::-1]))
    return min(a, b)


def drawn_length(ps):
    return sum(float(np.hypot(*np.diff(p, axis=0).T).sum()) for p in ps)


@settings(max_examples=80, deadline=None)
@given(paths, start)
def test_order_is_a_permutation_with_reversal(ps, home):
    out = order_paths(ps, start=home, join_tolerance=-1, rounds=4)
    assert sorted(map(canonical, out)) == sorted(map(canonical, ps))
    assert drawn_length(out) == pytest.approx(drawn_length(ps))


@settings(max_examples=60, deadline=None)
@given(paths, start)
def test_improvement_is_never_worse_than_greedy(ps, home):
    ours = travel_length(order_paths(ps, start=home, join_tolerance=-1, rounds=4), home)
    greedy = travel_length(greedy_order(ps, home), home)
    assert ours <= greedy + 1e-6


@settings(max_examples=60, deadline=None)
@given(paths, start)
def test_joining_only_adds_gaps_within_tolerance(ps, home):
    tol = 2.0
    joined = order_paths(ps, start=home, join_tolerance=tol, rounds=4)
    nonempty = [p for p in ps if len(p)]
    extra = drawn_length(joined) - drawn_length(nonempty)
    assert -1e-6 <= extra <= tol * (len(nonempty) - len(joined)) + 1e-6
    gaps = [np.hypot(*(b[0] - a[-1])) for a, b in zip(joined[:-1], joined[1:])]
    assert all(g > tol for g in gaps)


@settings(max_examples=60, deadline=None)
@given(paths, st.floats(0, 30))
def test_join_touching_keeps_every_point_in_order(ps, tol):
    ps = [p for p in ps if len(p)]
    joined = join_touching(ps, tol)
    flat_in = [tuple(q) for p in ps for q in p]
    flat_out = [tuple(q) for p in joined for q in p]
    # only a next path's first point that repeats the previous end exactly may disappear
    assert len(flat_out) <= len(flat_in)
    it = iter(flat_in)
    assert all(any(q == r for r in it) for q in flat_out)  # flat_out is a subsequence
    assert set(flat_out) == set(flat_in)
    gaps = [np.hypot(*(b[0] - a[-1])) for a, b in zip(joined[:-1], joined[1:])]
    assert all(g > tol for g in gaps)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(coord, coord), min_size=2, max_size=40, unique=True), start)
def test_greedy_always_takes_the_nearest_free_end(points, home):
    ps = [np.array([p, (p[0] + 0.5, p[1] + 0.25)]) for p in points]
    out = greedy_order(ps, home)
    pos = np.array(home, float)
    left = [canonical(p) for p in ps]
    for p in out:
        free_ends = np.array([e for q in left for e in (q[0], q[-1])])
        nearest = np.hypot(*(free_ends - pos).T).min()
        assert np.hypot(*(p[0] - pos)) == pytest.approx(nearest, abs=1e-9)
        left.remove(canonical(p))
        pos = p[-1]


def test_travel_length_counts_from_home_and_between_paths():
    ps = [np.array([[3.0, 4.0], [10.0, 4.0]]), np.array([[10.0, 8.0], [0.0, 8.0]])]
    assert travel_length(ps, (0.0, 0.0)) == pytest.approx(5.0 + 4.0)
    assert travel_length([], (0.0, 0.0)) == 0.0


def test_improvement_fetches_what_greedy_leaves_behind():
    # Dots at x = 1..10 and one at −1.2: greedy runs right first and must come all the way back;
    # the best tour takes the lone dot first.
    xs = [*range(1, 11), -1.2]
    ps = [np.array([[x, 0.0]]) for x in xs]
    greedy = travel_length(greedy_order(ps, (0.0, 0.0)), (0.0, 0.0))
    ours = travel_length(order_paths(ps, join_tolerance=-1, rounds=40), (0.0, 0.0))
    assert greedy == pytest.approx(1 + 9 + 11.2)
    assert ours == pytest.approx(1.2 + 2.2 + 9)


def test_parallel_hatch_lines_come_out_serpentine():
    rng = np.random.default_rng(0)
    lines = [np.array([[10.0, y], [100.0, y]]) for y in np.arange(10.0, 60.0, 1.0)]
    shuffled = [lines[i] if rng.random() < 0.5 else lines[i][::-1] for i in rng.permutation(len(lines))]
    out = order_paths(shuffled, start=(0.0, 0.0), join_tolerance=-1, rounds=40)
    directions = np.sign([p[-1, 0] - p[0, 0] for p in out])
    assert np.all(directions[1:] == -directions[:-1])
    assert travel_length(out, (0.0, 0.0)) == pytest.approx(np.hypot(10, 10) + 49 * 1.0)


def test_paths_meeting_within_the_pen_width_are_joined():
    a = np.array([[0.0, 0.0], [10.0, 0.0]])
    b = np.array([[10.3, 0.0], [20.0, 0.0]])  # 0.3 mm after a
    c = np.array([[20.0, 0.0], [20.0, 10.0]])  # exactly at b's end
    d = np.array([[50.0, 50.0], [60.0, 50.0]])  # far away
    out = order_paths([d, c, b, a], start=(0.0, 0.0), pen_width=0.5)
    assert len(out) == 2
    np.testing.assert_allclose(out[0], [[0, 0], [10, 0], [10.3, 0], [20, 0], [20, 10]])
    assert len(order_paths([d, c, b, a], start=(0.0, 0.0), pen_width=0.2)) == 3


def test_join_touching_keeps_distant_paths_apart():
    ps = [np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[5.0, 0.0], [6.0, 0.0]])]
    out = join_touching(ps, 0.5)
    assert len(out) == 2 and all(np.array_equal(x, y) for x, y in zip(out, ps))


def test_empty_and_degenerate_inputs():
    assert order_paths([]) == []
    assert greedy_order([]) == []
    dot = np.array([[5.0, 5.0]])
    out = order_paths([np.zeros((0, 2)), dot, dot.copy()], join_tolerance=-1)
    assert len(out) == 2 and all(np.array_equal(p, dot) for p in out)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(20, 300))
def test_every_improvement_round_really_shortens_the_tour(seed, n):
    """Each applied round of 2-opt / Or-opt moves lowers the travel it claims to lower."""
    from pencilbot.planning import ordering

    rng = np.random.default_rng(seed)
    ps = [rng.uniform(0, 100, 2) + np.cumsum(rng.normal(0, 3, (rng.integers(1, 4), 2)), 0) for _ in range(n)]
    ends = ordering._Ends(ps, (0.0, 0.0))
    neighbours = ends.neighbours()
    tour = ordering._Tour(ends, neighbours, *ordering._greedy(ends, neighbours))

    def travel():
        order, reverse = tour.result()
        return travel_length([ps[i][::-1] if r else ps[i] for i, r in zip(order, reverse)])

    before = travel()
    for step in [tour.two_opt_round, tour.or_opt_round] * 4:
        changed = step()
        after = travel()
        assert after < before - 1e-9 if changed else after == pytest.approx(before)
        before = after


def test_short_paths_are_never_joined_even_when_they_touch():
    from pencilbot.planning.ordering import join_touching

    dash_a = np.array([[0.0, 0.0], [2.0, 0.0]])
    dash_b = np.array([[2.5, 0.0], [4.5, 0.0]])
    run_a = np.array([[0.0, 5.0], [20.0, 5.0]])
    run_b = np.array([[20.0, 6.0], [0.0, 6.0]])
    joined = join_touching([run_a, run_b, dash_a, dash_b], tolerance=1.0, min_length=6.0)
    assert len(joined) == 3  # the two runs zig-zag into one path, the dashes stay apart
    assert len(joined[0]) == 4
    assert len(join_touching([dash_a, dash_b], tolerance=1.0)) == 1  # without the rule they join
