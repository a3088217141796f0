"""The order the pen draws paths in: short pen-up travel, fewer lifts.

A path may be drawn in either direction. The pen starts at its home position. Three steps:

1. **Two greedy tours**: greedy nearest neighbour over both ends of every path, from home (what
   plotter tools commonly do: :func:`greedy_order`, the baseline), and a greedy matching of path
   ends (repeatedly join the two nearest free ends of different chains of paths, in vectorised
   rounds of mutual nearest neighbours, until one chain from home remains). The matching is
   usually ~15 % shorter on scattered strokes; nearest neighbour can win on contours and
   hatching.
2. **Local improvement** of the shorter one: 2-opt moves (reverse a run of paths, each path
   flipped) and Or-opt moves (move a run of 1–5 paths elsewhere, optionally reversed) between
   nearby ends. Moves are evaluated with numpy in chunks of a few thousand ends; the best move
   of each end is then re-checked on the current tour in float64 and applied if it still gains,
   best first, so every applied move really shortens the tour. The next pass looks only at
   ends near the moves just made; when that runs dry, a full pass confirms a local optimum.
   Work left then improves the other tour the same way, and the shorter result is kept.
3. **Joining**: consecutive paths whose ends meet within ``join_tolerance`` (the pen width) become
   one path, so the pen stays down across the gap.

Work is counted in evaluated ends, not seconds, so the same paths always give the same order (a
plan, and its G-code, are reproducible on any machine). Cost is linear in the number of paths:
paths are renumbered along a Morton (Z-order) curve so that neighbours sit near each other in
memory, indices and coordinates of the bulk arrays are 32-bit, a move costs the same whatever
its span (the tour is a linked cycle of ends, see :class:`~pencilbot.planning.tour_search.Tour`), and no temporary grows beyond
a few arrays of the number of paths.

The tour is open: it starts at home and ends wherever the last path ends.
"""

from __future__ import annotations

import numpy as np

from pencilbot.paths import Paths
from pencilbot.planning.tour_ends import Ends, adjacency, greedy_matching, greedy_tour, morton_order
from pencilbot.planning.tour_search import CALL_COST, Tour, Work, descend
from pencilbot.units import DEFAULT_PEN_WIDTH

# A round of improvement, about one full pass with its checks, costs 1.5 work units per end
# (see tour_search.CALL_COST for the units).
_ROUND_COST = 1.5
DEFAULT_ROUNDS = (
    40  # ~0.74 of greedy's pen-up travel on photo plans (bench/ordering.py: coffee 0.73, astronaut 0.74)
)
# Rounds × paths is capped so that huge layers stay linear in cost: 2 rounds from 100 000
# paths on (1.28x the lower bound there, bench/scale.py), all 40 on photo layers.
ROUND_WORK = 200_000
MIN_ROUNDS = 2


def order_paths(
    paths: Paths,
    *,
    start: tuple[float, float] = (0.0, 0.0),
    join_tolerance: float | None = None,
    join_min_length: float = 0.0,
    pen_width: float = DEFAULT_PEN_WIDTH,
    rounds: int = DEFAULT_ROUNDS,
    matching_from: int = 0,
    nearest_until: int | None = None,
    deadline: float | None = None,
) -> Paths:
    """Reorder and reverse paths to shorten pen-up travel, then join paths that touch.

    Parameters
    ----------
    paths : Paths
        Paths in mm.
    start : (float, float), optional
        Pen position before the first path, mm (the plotter's home).
    join_tolerance : float, optional
        Consecutive paths whose gap is at most this (mm) are joined into one; default
        ``pen_width``. 0 joins only paths that meet exactly; negative disables joining.
    join_min_length : float, optional
        Paths shorter than this (mm) are never joined: a zig-zag between long hatch runs reads
        as one stroke of the hand, between short dashes as a staircase.
    pen_width : float, optional
        Pen width in mm, the default join tolerance.
    rounds : int, optional
        Improvement work after the greedy tours, in passes over all path ends (a pass costs
        about what building both tours does), at most ``ROUND_WORK / len(paths)`` but at least
        ``MIN_ROUNDS``; 0 keeps the shorter greedy tour. The result depends only on the paths
        and this number.
    matching_from : int, optional
        Layers of fewer paths start from the nearest-neighbour tour alone: on a few dozen paths
        the matching's rounds cost more than the whole search, and win nothing.
    nearest_until : int, optional
        Layers of more paths start from the matching alone, without the nearest-neighbour tour
        (a Python step per path; the matching is usually the shorter start on huge layers).
    deadline : float, optional
        ``time.process_time()`` at which to stop improving; with it ``rounds`` is not capped by
        the layer's size, so a huge layer gets as many rounds as fit (the order then depends on
        the machine's speed).

    Returns
    -------
    Paths
        The same strokes, each possibly reversed, in drawing order, some joined.
    """
    tolerance = pen_width if join_tolerance is None else join_tolerance
    # (The improvement counts every gap within the tolerance as joined, also those next to a
    # path too short to join: a small bias, and no worse a tour for the pen-up it actually pays.)
    order, reverse = improve_order(
        paths.firsts,
        paths.lasts,
        start,
        rounds=rounds,
        join_tolerance=tolerance,
        matching_from=matching_from,
        nearest_until=nearest_until,
        deadline=deadline,
    )
    ordered = paths.take(order, reverse)
    return join_touching(ordered, tolerance, min_length=join_min_length) if tolerance >= 0 else ordered


def greedy_order(paths: Paths, start: tuple[float, float] = (0.0, 0.0)) -> Paths:
    """Baseline: nearest neighbour with reversal from ``start``, no improvement, no joining."""
    if not len(paths):
        return paths
    first, last = paths.firsts, paths.lasts
    renumber = morton_order((first + last) / 2)
    order, reverse = greedy_tour(Ends(first[renumber], last[renumber], start))
    return paths.take(renumber[order], reverse)


def travel_length(paths: Paths, start: tuple[float, float] = (0.0, 0.0)) -> float:
    """Pen-up travel in mm: from ``start`` to the first path, then between consecutive paths."""
    if not len(paths):
        return 0.0
    tails = np.concatenate([np.asarray(start, np.float64).reshape(1, 2), paths.lasts[:-1]])
    return float(np.hypot(*(paths.firsts - tails).T).sum())


def travel_lower_bound(paths: Paths, start: tuple[float, float] = (0.0, 0.0)) -> float:
    """A lower bound on the pen-up travel of any order of ``paths`` (with reversal), mm.

    Pen-up moves pair up path ends: home with the first entry, each exit with the next entry;
    one exit (the last) stays free. So travel is at least a minimum-weight matching of home
    and the ends in which a path's two ends may not be paired. Its LP dual gives the bound:
    weights ``y ≥ 0`` with ``y_a + y_b ≤ |a − b|`` for every allowed pair bound each move from
    below, so travel ≥ Σ y − max y (the free end's weight). The weights are raised by dual
    ascent over the k-nearest-neighbour pairs, each end by half its least slack, from 0 (the
    first step is half the distance to the nearest other end, the classic nearest-neighbour
    bound); capping each weight at half its k-th neighbour distance keeps every other pair
    feasible. Costs about one k-d tree query of all ends.

    Parameters
    ----------
    paths : Paths
        Paths in mm.
    start : (float, float), optional
        Pen position before the first path, mm.

    Returns
    -------
    float
        mm; 0 for no paths.
    """
    if not len(paths):
        return 0.0
    ends = Ends(paths.firsts, paths.lasts, start)
    points, count, k = ends.points, len(ends.points), ends.k
    # Home's two ids are one point, matched once: keep its start end, drop the other.
    ids = np.delete(np.arange(count), 2 * ends.n)
    a = np.repeat(ids, k)
    b = ends.neighbours[ids].ravel()
    d = np.hypot(*(points[a] - points[b]).T)
    kept = b != 2 * ends.n
    cap = d.reshape(len(ids), k).max(axis=1) / 2 if count - 2 > k else np.full(len(ids), np.inf)
    a, b, d = a[kept], b[kept], d[kept]
    # Both directions of every pair, grouped by the first end, for per-end minima.
    a, b, d = np.concatenate([a, b]), np.concatenate([b, a]), np.concatenate([d, d])
    by_end = np.argsort(a, kind="stable")
    a, b, d = a[by_end], b[by_end], d[by_end]
    starts = np.flatnonzero(np.r_[True, a[1:] != a[:-1]])
    y = np.zeros(count)
    cap_of = np.zeros(count)  # home's second id keeps weight 0
    cap_of[ids] = cap
    for _ in range(30):  # converges to ~1e-4 relative in ~20 steps on random strokes
        least = np.full(count, np.inf)
        least[a[starts]] = np.minimum.reduceat(d - y[a] - y[b], starts)
        y += np.minimum(least / 2, cap_of - y)
    return float(y.sum() - y[: 2 * ends.n].max())


def improve_order(
    first: np.ndarray,
    last: np.ndarray,
    start: tuple[float, float],
    *,
    rounds: int = DEFAULT_ROUNDS,
    join_tolerance: float = -1.0,
    matching_from: int = 0,
    nearest_until: int | None = None,
    deadline: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Greedy tours then local improvement over paths given by their end points.

    Parameters
    ----------
    first, last : (n, 2) arrays
        First and last point of every path, mm.
    start : (float, float)
        Pen position before the first path, mm.
    rounds : int
        Improvement work in passes over all ends (see :func:`order_paths`).
    join_tolerance : float
        Gaps up to this (mm) will be joined pen-down, so the improvement counts them as no
        travel; negative: every gap counts.
    matching_from, deadline
        See :func:`order_paths`.
    nearest_until : int, optional
        Layers of more paths start from the matching alone (default: no limit).

    Returns
    -------
    order : (n,) int64
        Indices into the paths in drawing order.
    reverse : (n,) bool
        Per drawn path (in drawing order): drawn last point first.
    """
    first = np.asarray(first, np.float64).reshape(-1, 2)
    last = np.asarray(last, np.float64).reshape(-1, 2)
    n = len(first)
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, bool)
    nearest_until = n if nearest_until is None else nearest_until
    # Renumber along a space-filling curve: the tree, the neighbour graph and the tour's arrays
    # are then read nearly in order instead of at random (2-4x faster at a million paths).
    renumber = morton_order((first + last) / 2)
    ends = Ends(first[renumber], last[renumber], start, free_gap=max(join_tolerance, 0.0))
    # Two greedy tours: the matching is usually ~15 % shorter, but nearest neighbour from home
    # follows contours and hatching (its serpentine starts at the corner near home). Descend
    # from the shorter; work left after its local optimum goes to descending from the other.
    if n < matching_from:
        starts = [adjacency(*greedy_tour(ends))]
    elif n > nearest_until:  # its walk is a Python step per path: seconds at a million
        starts = [greedy_matching(ends)]
    else:
        starts = sorted((greedy_matching(ends), adjacency(*greedy_tour(ends))), key=ends.tour_length)
    tour = Tour(ends, starts[0])
    if rounds > 0 and n >= 2:
        # A round is one full pass: its ends and its call.
        rounds = int(rounds) if deadline is not None else min(int(rounds), max(MIN_ROUNDS, ROUND_WORK // n))
        work = Work(round(rounds * (_ROUND_COST * len(ends.points) + CALL_COST)), deadline)
        descend(tour, work)
        if work.left > 0 and len(starts) > 1:
            other = Tour(ends, starts[1])
            descend(other, work)
            if ends.tour_length(other.adj) < ends.tour_length(tour.adj):
                tour = other
    order, reverse = tour.result()
    return renumber[order].astype(np.int64), reverse


def join_touching(paths: Paths, tolerance: float, *, min_length: float = 0.0) -> Paths:
    """Join consecutive paths whose gap (end of one to start of the next) is ≤ ``tolerance`` mm,
    unless one of them is shorter than ``min_length`` mm. A path that starts exactly where the
    one before ends is joined without repeating that point."""
    if len(paths) < 2:
        return paths
    gap = np.hypot(*(paths.firsts[1:] - paths.lasts[:-1]).T)
    apart = gap > tolerance
    if min_length > 0:
        short = paths.drawn_lengths() < min_length
        apart |= short[1:] | short[:-1]
    if apart.all():
        return paths
    heads = paths.offsets[1:-1]  # first point of every path after the first
    repeated = heads[~apart & (gap == 0.0)]
    kept = np.ones(len(paths.points), bool)
    kept[repeated] = False
    # A joined path's first point may go; the first point of every other path stays, moved back
    # by the points dropped before it.
    starts = np.concatenate([[0], heads[apart]])
    starts -= np.searchsorted(repeated, starts)
    points = paths.points[kept] if len(repeated) else paths.points
    return Paths(points, np.concatenate([starts, [len(points)]]))
