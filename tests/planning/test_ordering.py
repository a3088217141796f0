"""Ordering: a permutation with optional reversal, a local optimum above the lower bound, joins what touches."""

import itertools
import warnings

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pencilbot.paths import Paths
from pencilbot.planning import tour_ends, tour_search
from pencilbot.planning.ordering import (
    greedy_order,
    join_touching,
    order_paths,
    travel_length,
    travel_lower_bound,
)

coord = st.floats(-50, 250, allow_nan=False)
path = st.lists(st.tuples(coord, coord), min_size=1, max_size=5).map(np.array)
paths = st.lists(path, min_size=0, max_size=60).map(Paths.of)
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
    assert isinstance(out, Paths)
    assert sorted(map(canonical, out)) == sorted(map(canonical, ps))
    assert drawn_length(out) == pytest.approx(drawn_length(ps))


@settings(max_examples=60, deadline=None)
@given(paths, start)
def test_improvement_is_never_worse_than_the_greedy_tour_it_starts_from(ps, home):
    ours = travel_length(order_paths(ps, start=home, join_tolerance=-1, rounds=4), home)
    start_tour = travel_length(order_paths(ps, start=home, join_tolerance=-1, rounds=0), home)
    assert ours <= start_tour + 1e-6


@settings(max_examples=60, deadline=None)
@given(paths, start)
def test_improvement_is_never_worse_than_greedy(ps, home):
    ours = travel_length(order_paths(ps, start=home, join_tolerance=-1, rounds=4), home)
    greedy = travel_length(greedy_order(ps, home), home)
    assert ours <= greedy + 1e-6


def brute_force_travel(ps, home):
    """Shortest pen-up travel over every order and direction of a few paths (all of them at
    once in arrays: 5 paths are 3 840 tours)."""
    if not ps:
        return 0.0
    ends = np.array([[p[0], p[-1]] for p in ps], float)  # (paths, first/last, xy)
    order = np.array(list(itertools.permutations(range(len(ps)))))[:, None, :]
    flip = np.array(list(itertools.product((0, 1), repeat=len(ps))))[None, :, :]
    entry, leave = ends[order, flip], ends[order, 1 - flip]  # (orders, flips, paths, xy)
    home_ = np.broadcast_to(np.asarray(home, float), (*entry.shape[:2], 1, 2))
    tails = np.concatenate([home_, leave[:, :, :-1]], axis=2)
    return float(np.linalg.norm(entry - tails, axis=-1).sum(axis=-1).min())


few_paths = st.lists(path, min_size=1, max_size=5).map(Paths.of)


@settings(max_examples=60, deadline=None)
@given(few_paths, start)
def test_lower_bound_is_below_the_best_order(ps, home):
    best = brute_force_travel(ps, home)
    bound = travel_lower_bound(ps, home)
    assert 0.0 <= bound <= best + 1e-9
    assert travel_length(order_paths(ps, start=home, join_tolerance=-1), home) >= bound - 1e-9


def nearest_end_bound(ps, home):
    """The classic bound: half of each end's distance to the nearest end of another path."""
    ends = [(np.asarray(home, float), -1)] + [(p[i], k) for k, p in enumerate(ps) for i in (0, -1)]
    half = [min(np.hypot(*(a - b)) for b, m in ends if m != k) / 2 for a, k in ends]
    return sum(half) - max(half[1:])


def test_lower_bound_raises_the_nearest_end_bound_and_is_exact_for_one_dot():
    assert travel_lower_bound(Paths.of([[[3.0, 4.0]]]), (0.0, 0.0)) == pytest.approx(5.0)
    # Dots in a row from home, 9 mm of travel in the best order: the dual ascent lifts the
    # ends whose nearest neighbour is nearer to someone else.
    dots = Paths.of([[[x, 0.0]] for x in (3.0, 4.0, 6.0, 9.0)])
    assert nearest_end_bound(dots, (0.0, 0.0)) == pytest.approx(7.0)
    assert 7.0 < travel_lower_bound(dots, (0.0, 0.0)) <= 9.0
    assert travel_lower_bound(Paths.empty(), (0.0, 0.0)) == 0.0


@settings(max_examples=40, deadline=None)
@given(st.lists(path, min_size=1, max_size=12).map(Paths.of), start)
def test_lower_bound_is_at_least_the_nearest_end_bound(ps, home):
    assert travel_lower_bound(ps, home) >= nearest_end_bound(ps, home) - 1e-9


@settings(max_examples=60, deadline=None)
@given(st.lists(path, min_size=1, max_size=4).map(Paths.of), start)
def test_no_reversal_of_a_run_shortens_the_result(ps, home):
    """With at most 4 paths every end neighbours every other, so the descent's 2-opt is complete."""
    ordered = order_paths(ps, start=home, join_tolerance=-1, rounds=40)
    travel, out = travel_length(ordered, home), list(ordered)
    for i in range(len(out)):
        for j in range(i, len(out)):
            turned = out[:i] + [p[::-1] for p in out[i : j + 1][::-1]] + out[j + 1 :]
            # The ordering compares moves in float32 (issue 16): ties within its rounding
            # (~1e-7 of the coordinates) are not a shorter order missed.
            assert travel_length(Paths.of(turned), home) >= travel - 1e-6 * max(1.0, travel)


def test_improvement_beats_greedy_nearest_neighbour_on_random_strokes():
    rng = np.random.default_rng(3)
    for n in (30, 300, 3000):
        start = rng.uniform(0, 200, (n, 2))
        ps = Paths.of(np.stack([start, start + rng.normal(0, 2.0, (n, 2))], axis=1))
        ours = travel_length(order_paths(ps, join_tolerance=-1))
        greedy = travel_length(greedy_order(ps))
        assert ours < (0.95 if n < 100 else 0.85) * greedy
        assert ours < 1.35 * travel_lower_bound(ps)


@settings(max_examples=60, deadline=None)
@given(paths, start)
def test_joining_only_adds_gaps_within_tolerance(ps, home):
    tol = 2.0
    joined = order_paths(ps, start=home, join_tolerance=tol, rounds=4)
    extra = drawn_length(joined) - drawn_length(ps)
    assert -1e-6 <= extra <= tol * (len(ps) - len(joined)) + 1e-6
    gaps = [np.hypot(*(b[0] - a[-1])) for a, b in zip(joined[:-1], joined[1:])]
    assert all(g > tol for g in gaps)


@settings(max_examples=60, deadline=None)
@given(paths, st.floats(0, 30))
def test_join_touching_keeps_every_point_in_order(ps, tol):
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


def joined_one_by_one(ps, tolerance, min_length):
    """join_touching as a loop over the paths: each path joins the one before when the gap is
    within the tolerance and neither is short, dropping its first point if it repeats the end."""
    out, out_short = [], False
    for p in ps:
        short = np.linalg.norm(np.diff(p, axis=0), axis=1).sum() < min_length
        if out and not short and not out_short and np.hypot(*(p[0] - out[-1][-1])) <= tolerance:
            out[-1] = np.concatenate([out[-1], p[1:] if np.array_equal(p[0], out[-1][-1]) else p])
        else:
            out.append(p)
        out_short = short
    return out


@settings(max_examples=80, deadline=None)
@given(paths, st.sampled_from([0.0, 0.5, 3.0, 40.0]), st.sampled_from([0.0, 2.0, 30.0]))
def test_join_touching_joins_as_a_loop_over_the_paths_would(ps, tol, min_length):
    # Paths that share ends exactly, as hatch runs and contours do.
    snapped = Paths.of(
        p if k == 0 or k % 3 else np.concatenate([ps[k - 1][-1:], p]) for k, p in enumerate(ps)
    )
    want = joined_one_by_one(list(snapped), tol, min_length)
    got = join_touching(snapped, tol, min_length=min_length)
    assert len(got) == len(want)
    assert all(np.array_equal(a, b) for a, b in zip(got, want))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(coord, coord), min_size=2, max_size=40, unique=True), start)
def test_greedy_always_takes_the_nearest_free_end(points, home):
    ps = Paths.of([np.array([p, (p[0] + 0.5, p[1] + 0.25)]) for p in points])
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
    ps = Paths.of([[[3.0, 4.0], [10.0, 4.0]], [[10.0, 8.0], [0.0, 8.0]]])
    assert travel_length(ps, (0.0, 0.0)) == pytest.approx(5.0 + 4.0)
    assert travel_length(Paths.empty(), (0.0, 0.0)) == 0.0


def test_improvement_fetches_what_greedy_leaves_behind():
    # Dots at x = 1..10 and one at −1.2: greedy runs right first and must come all the way back;
    # the best tour takes the lone dot first.
    xs = [*range(1, 11), -1.2]
    ps = Paths.of([[[x, 0.0]] for x in xs])
    greedy = travel_length(greedy_order(ps, (0.0, 0.0)), (0.0, 0.0))
    ours = travel_length(order_paths(ps, join_tolerance=-1, rounds=40), (0.0, 0.0))
    assert greedy == pytest.approx(1 + 9 + 11.2)
    assert ours == pytest.approx(1.2 + 2.2 + 9)


def test_parallel_hatch_lines_come_out_serpentine():
    rng = np.random.default_rng(0)
    lines = [np.array([[10.0, y], [100.0, y]]) for y in np.arange(10.0, 60.0, 1.0)]
    shuffled = [lines[i] if rng.random() < 0.5 else lines[i][::-1] for i in rng.permutation(len(lines))]
    out = order_paths(Paths.of(shuffled), start=(0.0, 0.0), join_tolerance=-1, rounds=40)
    directions = np.sign([p[-1, 0] - p[0, 0] for p in out])
    assert np.all(directions[1:] == -directions[:-1])
    assert travel_length(out, (0.0, 0.0)) == pytest.approx(np.hypot(10, 10) + 49 * 1.0)


def test_paths_meeting_within_the_pen_width_are_joined():
    a = np.array([[0.0, 0.0], [10.0, 0.0]])
    b = np.array([[10.3, 0.0], [20.0, 0.0]])  # 0.3 mm after a
    c = np.array([[20.0, 0.0], [20.0, 10.0]])  # exactly at b's end
    d = np.array([[50.0, 50.0], [60.0, 50.0]])  # far away
    out = order_paths(Paths.of([d, c, b, a]), start=(0.0, 0.0), pen_width=0.5)
    assert len(out) == 2
    np.testing.assert_allclose(out[0], [[0, 0], [10, 0], [10.3, 0], [20, 0], [20, 10]])
    assert len(order_paths(Paths.of([d, c, b, a]), start=(0.0, 0.0), pen_width=0.2)) == 3


def test_join_touching_keeps_distant_paths_apart():
    ps = Paths.of([[[0.0, 0.0], [1.0, 0.0]], [[5.0, 0.0], [6.0, 0.0]]])
    assert join_touching(ps, 0.5) == ps


def test_empty_and_degenerate_inputs():
    assert order_paths(Paths.empty()) == Paths.empty()
    assert greedy_order(Paths.empty()) == Paths.empty()
    assert join_touching(Paths.empty(), 1.0) == Paths.empty()
    dot = np.array([[5.0, 5.0]])
    out = order_paths(Paths.of([dot, dot]), join_tolerance=-1)
    assert len(out) == 2 and all(np.array_equal(p, dot) for p in out)
    # two dots in one place, joined: one dot (its repeated point is not drawn twice)
    assert order_paths(Paths.of([dot, dot]), join_tolerance=0) == Paths.of([dot])


def random_tour(seed, n):
    rng = np.random.default_rng(seed)
    ps = Paths.of(
        [rng.uniform(0, 100, 2) + np.cumsum(rng.normal(0, 3, (rng.integers(1, 4), 2)), 0) for _ in range(n)]
    )
    ends = tour_ends.Ends(ps.firsts, ps.lasts, (0.0, 0.0))
    return ps, tour_search.Tour(ends, tour_ends.greedy_matching(ends))


def tour_travel(ps, tour):
    order, reverse = tour.result()
    return travel_length(ps.take(order, reverse))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(8, 300))
def test_every_improvement_pass_shortens_the_tour_by_what_it_claims(seed, n):
    """Each pass of 2-opt / Or-opt moves lowers travel by the gain it reports."""
    ps, tour = random_tour(seed, n)
    before = tour_travel(ps, tour)
    active = tour.movable_ends()
    for _ in range(12):
        touched, gain = tour.improve(active)
        after = tour_travel(ps, tour)  # also refreshes: later 2-opt moves see fresh roles
        assert after == pytest.approx(before - gain, abs=1e-6)
        assert gain >= 0 and (gain > 0) == (touched.size > 0)
        before = after
        active = tour.ends_of(touched) if touched.size else tour.movable_ends()


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(100, 300))
def test_vectorised_gains_match_the_float64_check(seed, n):
    """The numpy estimate of every candidate move equals the gain the scalar check applies."""
    _ps, tour = random_tour(seed, n)
    kind, e, f, gain = tour._candidates(tour.movable_ends())
    assert len(kind)  # a matching always leaves something to improve on a few hundred strokes
    adj, travel = tour.adj.copy(), tour.travel.copy()
    for kd, ee, ff, g in zip(kind.tolist(), e.tolist(), f.tolist(), gain.tolist()):
        exact = tour._try(kd, ee, ff, [])
        tour.adj[:], tour.travel[:] = adj, travel  # back to the tour the estimates were made on
        tour.refresh()
        assert exact == pytest.approx(g, abs=1e-3)


def test_short_paths_are_never_joined_even_when_they_touch():
    dash_a = np.array([[0.0, 0.0], [2.0, 0.0]])
    dash_b = np.array([[2.5, 0.0], [4.5, 0.0]])
    run_a = np.array([[0.0, 5.0], [20.0, 5.0]])
    run_b = np.array([[20.0, 6.0], [0.0, 6.0]])
    joined = join_touching(Paths.of([run_a, run_b, dash_a, dash_b]), tolerance=1.0, min_length=6.0)
    assert len(joined) == 3  # the two runs zig-zag into one path, the dashes stay apart
    assert len(joined[0]) == 4
    assert len(join_touching(Paths.of([dash_a, dash_b]), tolerance=1.0)) == 1  # without the rule they join


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 300), st.lists(st.tuples(st.integers(0, 299), st.integers(0, 299)), max_size=40))
def test_interval_set_accepts_exactly_the_intervals_that_nest_or_stay_apart(size, proposed):
    """The 2-opt interval test against a direct check over every accepted interval (the block
    prefix XORs span several blocks once size > 16, and position 0 is the home's edge)."""
    intervals, accepted = tour_search.Intervals(size), []
    for a, b in proposed:
        a, b = sorted((a % size, b % size))
        used = {t for iv in accepted for t in iv}
        # An accepted [c, d] with exactly one end strictly inside (a, b) crosses it.
        crossing = any((a < c < b) != (a < d < b) for c, d in accepted)
        expected = a not in used and b not in used and not crossing
        assert intervals.fits(a, b) == expected
        if expected and a < b:
            intervals.add(a, b)
            accepted.append((a, b))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(allow_nan=True, allow_infinity=True, width=64),
            st.floats(allow_nan=True, allow_infinity=True, width=64),
        ),
        min_size=1,
        max_size=30,
    )
)
@example([(0.0, 0.0), (5e-324, 0.0), (0.0, 1e-323)])
def test_the_z_order_of_any_points_is_a_permutation_without_overflow(points):
    # Extents from subnormal to the float limit, NaN and infinities: a permutation, computed
    # without an overflow or an invalid cast (both warn, and the warning is an error here).
    from pencilbot.planning.tour_ends import morton_order

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        order = morton_order(np.array(points, dtype=np.float64))
    assert sorted(order.tolist()) == list(range(len(points)))
