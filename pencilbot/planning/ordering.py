"""The order the pen draws paths in: short pen-up travel, fewer lifts.

A path may be drawn in either direction. The pen starts at its home position. Three steps:

1. **Two greedy tours**: greedy nearest neighbour over both ends of every path, from home (what
   plotter tools commonly do: :func:`greedy_order`, the baseline), and a greedy matching of path
   ends (repeatedly join the two nearest free ends of different chains of paths, in vectorised
   rounds of mutual nearest neighbours, until one chain from home remains). The matching is
   usually ~15 % shorter on scattered strokes; nearest neighbour can win on contours and
   hatching.
2. **Local improvement** of the shorter one: 2-opt moves (reverse a run of paths, each path
   flipped) and Or-opt moves (move a run of 1–3 paths elsewhere, optionally reversed) between
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
its span (the tour is a linked cycle of ends, see :class:`_Tour`), and no temporary grows beyond
a few arrays of the number of paths.

The tour is open: it starts at home and ends wherever the last path ends.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

_NEIGHBOURS = 10  # nearby ends per end: enough candidate moves, cheap to compute
_MAX_RUN = 5  # Or-opt moves runs of up to this many paths
_EPS = 1e-9  # mm: gains below this are float noise (decided in float64)
_CHUNK = 8192  # ends per vectorised evaluation: ~80k candidate pairs, temporaries of a few MB
# Work is counted in units that track time (measured): evaluating an end costs 1 (~1.3 µs), a
# float64 check of a move 2, a call's numpy overhead 250; a round, about one full pass with
# its checks, 1.5 per end.
_CALL_COST = 250
_TRY_COST = 2
_ROUND_COST = 1.5
DEFAULT_ROUNDS = 40  # ~0.76 of greedy's pen-up travel on photo plans (bench/ordering.py)
# Rounds × paths is capped so that huge layers stay linear in cost: 2 rounds from 100 000
# paths on (1.28x the lower bound there, bench/scale.py), all 40 on photo layers.
ROUND_WORK = 200_000
MIN_ROUNDS = 2
_REFRESH_HELD = 64  # refresh once 2-opt moves wait at 1/64 of the paths


def order_paths(
    paths: Sequence[np.ndarray],
    *,
    start: tuple[float, float] = (0.0, 0.0),
    join_tolerance: float | None = None,
    join_min_length: float = 0.0,
    pen_width: float = 0.5,
    rounds: int = DEFAULT_ROUNDS,
) -> list[np.ndarray]:
    """Reorder and reverse paths to shorten pen-up travel, then join paths that touch.

    Parameters
    ----------
    paths : sequence of (N, 2) arrays
        Paths in mm; empty paths are dropped.
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

    Returns
    -------
    list of (N, 2) arrays
        The same strokes, each possibly reversed, in drawing order, some joined.
    """
    arrays = _nonempty(paths)
    first, last = _path_ends(arrays)
    tolerance = pen_width if join_tolerance is None else join_tolerance
    # (The improvement counts every gap within the tolerance as joined, also those next to a
    # path too short to join: a small bias, and no worse a tour for the pen-up it actually pays.)
    order, reverse = improve_order(first, last, start, rounds=rounds, join_tolerance=tolerance)
    ordered = _apply(arrays, order, reverse)
    return join_touching(ordered, tolerance, min_length=join_min_length) if tolerance >= 0 else ordered


def greedy_order(paths: Sequence[np.ndarray], start: tuple[float, float] = (0.0, 0.0)) -> list[np.ndarray]:
    """Baseline: nearest neighbour with reversal from ``start``, no improvement, no joining."""
    arrays = _nonempty(paths)
    if not arrays:
        return []
    first, last = _path_ends(arrays)
    renumber = _morton_order((first + last) / 2)
    order, reverse = _greedy(_Ends(first[renumber], last[renumber], start))
    return _apply(arrays, renumber[order], reverse)


def travel_length(paths: Sequence[np.ndarray], start: tuple[float, float] = (0.0, 0.0)) -> float:
    """Pen-up travel in mm: from ``start`` to the first path, then between consecutive paths."""
    arrays = _nonempty(paths)
    if not arrays:
        return 0.0
    first, last = _path_ends(arrays)
    tails = np.concatenate([np.asarray(start, np.float64).reshape(1, 2), last[:-1]])
    return float(np.hypot(*(first - tails).T).sum())


def travel_lower_bound(paths: Sequence[np.ndarray], start: tuple[float, float] = (0.0, 0.0)) -> float:
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
    paths : sequence of (N, 2) arrays
        Paths in mm; empty paths are dropped.
    start : (float, float), optional
        Pen position before the first path, mm.

    Returns
    -------
    float
        mm; 0 for no paths.
    """
    arrays = _nonempty(paths)
    if not arrays:
        return 0.0
    first, last = _path_ends(arrays)
    ends = _Ends(first, last, start)
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
    # Renumber along a space-filling curve: the tree, the neighbour graph and the tour's arrays
    # are then read nearly in order instead of at random (2-4x faster at a million paths).
    renumber = _morton_order((first + last) / 2)
    ends = _Ends(first[renumber], last[renumber], start, free_gap=max(join_tolerance, 0.0))
    # Two greedy tours: the matching is usually ~15 % shorter, but nearest neighbour from home
    # follows contours and hatching (its serpentine starts at the corner near home). Descend
    # from the shorter; work left after its local optimum goes to descending from the other.
    starts = sorted((_greedy_matching(ends), _adjacency(*_greedy(ends))), key=ends.tour_length)
    tour = _Tour(ends, starts[0])
    if rounds > 0 and n >= 2:
        # A round is one full pass: its ends and its call.
        rounds = min(int(rounds), max(MIN_ROUNDS, ROUND_WORK // n))
        work = _Work(round(rounds * (_ROUND_COST * len(ends.points) + _CALL_COST)))
        _descend(tour, work)
        if work.left > 0:
            other = _Tour(ends, starts[1])
            _descend(other, work)
            if ends.tour_length(other.adj) < ends.tour_length(tour.adj):
                tour = other
    order, reverse = tour.result()
    return renumber[order].astype(np.int64), reverse


def join_touching(paths: Sequence[np.ndarray], tolerance: float, *, min_length: float = 0.0) -> list[np.ndarray]:
    """Join consecutive paths whose gap (end of one to start of the next) is ≤ ``tolerance`` mm,
    unless one of them is shorter than ``min_length`` mm."""
    arrays = _nonempty(paths)
    if len(arrays) < 2:
        return arrays
    first, last = _path_ends(arrays)
    gap = np.hypot(*(first[1:] - last[:-1]).T)
    apart = gap > tolerance
    if min_length > 0:
        short = np.array([np.linalg.norm(np.diff(p, axis=0), axis=1).sum() < min_length for p in arrays])
        apart |= short[1:] | short[:-1]
    breaks = np.flatnonzero(apart) + 1
    joined = []
    for group in np.split(np.arange(len(arrays)), breaks):
        if len(group) == 1:
            joined.append(arrays[group[0]])
            continue
        parts = [arrays[group[0]]]
        for prev, k in zip(group[:-1], group[1:]):
            # drop the next path's first point when it repeats the previous end exactly
            same = gap[prev] == 0.0
            parts.append(arrays[k][1:] if same else arrays[k])
        joined.append(np.concatenate(parts))
    return joined


def _nonempty(paths: Sequence[np.ndarray]) -> list[np.ndarray]:
    # (N, 2) float64 arrays as they are: asarray and reshape cost ~0.4 µs a path, at 1M paths.
    f64 = np.dtype(np.float64)
    arrays = [
        p if type(p) is np.ndarray and p.dtype is f64 and p.ndim == 2 and p.shape[1] == 2
        else np.asarray(p, np.float64).reshape(-1, 2)
        for p in paths
    ]
    return [p for p in arrays if len(p)]


def _path_ends(arrays: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) first and last points of non-empty paths."""
    if not arrays:
        return np.zeros((0, 2)), np.zeros((0, 2))
    flat = np.concatenate(arrays)
    lengths = np.fromiter(map(len, arrays), np.int64, len(arrays))
    stops = np.cumsum(lengths)
    return flat[stops - lengths], flat[stops - 1]


def _apply(paths: list[np.ndarray], order: np.ndarray, reverse: np.ndarray) -> list[np.ndarray]:
    return [paths[i][::-1] if r else paths[i] for i, r in zip(order.tolist(), reverse.tolist())]


def _dist32(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """float32 distances between points a and b of (N,) complex64 ``points`` (x + iy).

    Gathering one 8-byte complex per point is ~4x faster than gathering rows of an (N, 2)
    array; the subtraction is the same float32 one per coordinate.
    """
    delta = (points[a] - points[b]).view(np.float32).reshape(-1, 2)
    return np.sqrt(np.einsum("ij,ij->i", delta, delta))


def _morton_order(points: np.ndarray) -> np.ndarray:
    """Indices that sort ``points`` along a Z-order curve on a 65 536² grid over their extent."""
    if not np.isfinite(points).all():  # no place on the curve: NaN ends first, infinities at the edges
        points = np.nan_to_num(points, nan=-np.finfo(np.float64).max)
    low = points.min(axis=0)
    with np.errstate(over="ignore"):
        extent = float((points.max(axis=0) - low).max())
    if not np.isfinite(extent):  # ends near the float limit: their differences overflow, halves do not
        points = points / 2
        low = points.min(axis=0)
        extent = float((points.max(axis=0) - low).max())
    cells = ((points - low) * (65535.0 / extent if extent > 0 else 0.0)).astype(np.uint64)

    def spread(v):  # 16 bits → every other of 32 bits
        v = (v | (v << np.uint64(8))) & np.uint64(0x00FF00FF)
        v = (v | (v << np.uint64(4))) & np.uint64(0x0F0F0F0F)
        v = (v | (v << np.uint64(2))) & np.uint64(0x33333333)
        return (v | (v << np.uint64(1))) & np.uint64(0x55555555)

    key = spread(cells[:, 0]) | (spread(cells[:, 1]) << np.uint64(1))
    return np.argsort(key, kind="stable")


class _Ends:
    """Both ends of every path plus the home as node ``n``; nearest neighbours of every end.

    End id ``e`` is end ``e & 1`` (0 = first point, 1 = last point) of node ``e >> 1``. Home's
    end ``2n + 1`` is the start point; its end ``2n`` is the tour's free end (see :class:`_Tour`),
    stored at the start point too. Gaps up to ``free_gap`` mm cost nothing (they are joined).
    """

    def __init__(self, first: np.ndarray, last: np.ndarray, start, free_gap: float = 0.0) -> None:
        self.n = len(first)
        self.free_gap = free_gap
        points = np.empty((2 * (self.n + 1), 2))
        points[0:-2:2], points[1:-2:2] = first, last
        points[-2:] = np.asarray(start, np.float64)
        self.points = points
        self.points32 = points.astype(np.float32).view(np.complex64).ravel()  # x + iy, see _dist32
        count = len(points)
        self.k = min(_NEIGHBOURS, count - 2)  # a node's own two ends are never candidates
        self.tree = cKDTree(points, balanced_tree=False)
        self.neighbours = np.empty((count, self.k), np.int32)
        self.distances = np.empty((count, self.k), np.float32)
        for lo in range(0, count, 16 * _CHUNK):  # in chunks: the query's float64 temporaries
            rows = np.arange(lo, min(lo + 16 * _CHUNK, count), dtype=np.int32)
            d, idx = self.tree.query(points[rows], k=min(self.k + 2, count))
            d, idx = np.asarray(d).reshape(len(rows), -1), np.asarray(idx, np.int32).reshape(len(rows), -1)
            # Equal distances (regular hatching) in id order, as the matching breaks ties by it.
            tied = np.flatnonzero((d[:, 1:] == d[:, :-1]).any(axis=1))
            by = np.lexsort((idx[tied], d[tied]), axis=1)
            d[tied], idx[tied] = np.take_along_axis(d[tied], by, axis=1), np.take_along_axis(idx[tied], by, axis=1)
            other = (idx >> 1) != (rows >> 1)[:, None]
            # The first k other-node ends, nearest first (at least k among k + 2 answers).
            keep = other & (np.cumsum(other, axis=1, dtype=np.int8) <= self.k)
            self.neighbours[rows] = idx[keep].reshape(len(rows), self.k)
            self.distances[rows] = d[keep].astype(np.float32).reshape(len(rows), self.k)
        self.distances[self.distances <= free_gap] = 0

    def tour_length(self, adj: np.ndarray) -> float:
        """Cost (mm, float64) of a tour given by travel partners; the free end costs 0."""
        free, ids = len(adj) - 2, np.arange(len(adj))
        ends = np.flatnonzero((ids < adj) & (adj != free) & (ids != free))
        gaps = np.hypot(*(self.points[ends] - self.points[adj[ends]]).T)
        return float(gaps[gaps > self.free_gap].sum())


def _greedy(ends: _Ends) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-neighbour tour from home over both ends of every path: ``(order, reverse)``."""
    n, k = ends.n, ends.k
    used = bytearray(n + 1)
    used[n] = 1  # home
    nbr = memoryview(np.ascontiguousarray(ends.neighbours).ravel())
    order, reverse = [], []  # lists: a numpy scalar store costs more than the step's search
    tree, tree_ids, stale = ends.tree, np.arange(2 * (n + 1), dtype=np.int32), 0
    current = 2 * n + 1  # end id at which the pen stands: home
    for _ in range(n):
        chosen = -1
        for c in range(current * k, current * k + k):
            e = nbr[c]
            if not used[e >> 1]:
                chosen = e
                break
        if chosen < 0:
            if stale > len(tree_ids) // 2:  # most of the tree is used up: rebuild with free ends
                alive = np.frombuffer(bytes(used), np.uint8)[tree_ids >> 1] == 0
                tree_ids = tree_ids[alive]
                tree, stale = cKDTree(ends.points[tree_ids], balanced_tree=False), 0
            q = 16
            while chosen < 0:
                q = min(q, len(tree_ids))
                _, idx = tree.query(ends.points[current], k=q)
                for e in tree_ids[np.atleast_1d(idx)].tolist():
                    if not used[e >> 1]:
                        chosen = e
                        break
                q *= 4
        node = chosen >> 1
        used[node] = 1
        stale += 2
        order.append(node)
        reverse.append(chosen & 1)  # entered at its last point
        current = chosen ^ 1  # leave by the other end
    return np.array(order, np.int64), np.array(reverse, bool)


def _adjacency(order: np.ndarray, reverse: np.ndarray) -> np.ndarray:
    """Travel partner of every end for paths drawn in ``order`` (``reverse``: last point first).

    Home → entry of the first path, exit of each → entry of the next, last exit → the free end.
    """
    n = len(order)
    entry = 2 * order.astype(np.int32) + reverse
    walk = np.concatenate([[2 * n + 1], np.stack([entry, entry ^ 1], axis=1).ravel(), [2 * n]])
    adj = np.empty(2 * (n + 1), np.int32)
    adj[walk[0::2]] = walk[1::2]
    adj[walk[1::2]] = walk[0::2]
    return adj


def _greedy_matching(ends: _Ends) -> np.ndarray:
    """Join path ends greedily into one chain from home: the travel partner of every end.

    Every path starts as a chain of its own; home is a chain from the tour's free end to the
    start point. Each round, every free chain end picks its nearest free end on another chain;
    pairs that picked each other are joined (the shortest join of each is the one a sequential
    greedy matching would make next), except that a ring of chains joined in one round drops
    its longest pair. When most free ends have no candidate left, the free ends are queried
    afresh. The last free end is joined to the tour's free end.
    """
    n, points = ends.n, ends.points
    count, free_end = 2 * (n + 1), 2 * n
    partner = np.full(count, -1, np.int32)
    opposite = np.arange(count, dtype=np.int32) ^ 1  # the other end of each free end's chain
    free = np.ones(count, bool)
    free[free_end] = False
    ids = np.flatnonzero(free).astype(np.int32)
    candidates, k = ends.neighbours[ids], ends.k
    while len(ids) > 1:
        valid = free[candidates] & (candidates != opposite[ids][:, None])
        if np.count_nonzero(valid.any(axis=1)) < len(ids) // 2:
            q = min(k + 1, len(ids))
            _, idx = cKDTree(points[ids]).query(points[ids], k=q)
            candidates = ids[np.asarray(idx).reshape(len(ids), q)]
            valid = (candidates != opposite[ids][:, None]) & (candidates != ids[:, None])
        has = valid.any(axis=1)
        choice = np.full(count, -1, np.int32)
        choice[ids[has]] = candidates[has, np.argmax(valid[has], axis=1)]
        a = ids[has]
        b = choice[a]
        mutual = (choice[b] == a) & (a < b)
        if not mutual.any():
            k *= 2  # every free end's candidates lie on its own chain: look further
            candidates = candidates[:, :0]
            continue
        a, b = _without_rings(a[mutual], b[mutual], ids, opposite, points, free_end)
        partner[a], partner[b] = b, a
        free[a] = free[b] = False
        ends_of_chains = _chain_ends(a, b, ids, opposite, free_end)
        opposite[ends_of_chains[0]], opposite[ends_of_chains[1]] = ends_of_chains[1], ends_of_chains[0]
        keep = free[ids]
        ids, candidates = ids[keep], candidates[keep]
    partner[ids[0]], partner[free_end] = free_end, ids[0]
    return partner


def _chain_graph(a, b, ids, opposite, free_end):
    """Graph of free ends (and the free end) with an edge per chain and per proposed join."""
    # Imported here: scipy.sparse.csgraph adds 60 ms to every pencilbot command's start-up.
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    nodes = np.concatenate([ids, [free_end]])
    local = np.full(len(opposite), -1, np.int64)
    local[nodes] = np.arange(len(nodes))
    chain = (ids < opposite[ids]) | (opposite[ids] == free_end)
    u = np.concatenate([local[ids[chain]], local[a]])
    v = np.concatenate([local[opposite[ids[chain]]], local[b]])
    graph = coo_matrix((np.ones(len(u), np.int8), (u, v)), shape=(len(nodes), len(nodes)))
    return nodes, local, u, v, connected_components(graph, directed=False)


def _without_rings(a, b, ids, opposite, points, free_end):
    """Drop the longest proposed join of each ring of chains (joining all would close a cycle)."""
    _, local, u, _, (count, label) = _chain_graph(a, b, ids, opposite, free_end)
    ring = np.bincount(label[u], minlength=count) == np.bincount(label, minlength=count)
    if not ring.any():
        return a, b
    of = label[local[a]]
    length = np.hypot(*(points[a] - points[b]).T)
    by_ring = np.lexsort((-length, of))
    longest = by_ring[np.r_[True, of[by_ring][1:] != of[by_ring][:-1]]]
    drop = np.zeros(len(a), bool)
    drop[longest[ring[of[longest]]]] = True
    return a[~drop], b[~drop]


def _chain_ends(a, b, ids, opposite, free_end):
    """The two ends of every chain the joins (a, b) made: (ends, their opposite ends)."""
    nodes, local, u, v, (_, label) = _chain_graph(a, b, ids, opposite, free_end)
    degree = np.bincount(u, minlength=len(nodes)) + np.bincount(v, minlength=len(nodes))
    tips = np.flatnonzero(degree == 1)
    joined = np.zeros(label.max() + 1, bool)
    joined[label[local[a]]] = True
    tips = tips[joined[label[tips]]]
    tips = tips[np.argsort(label[tips], kind="stable")]  # a chain's two tips side by side
    return nodes[tips[0::2]], nodes[tips[1::2]]


class _Work:
    """Improvement work left, in the units of ``_CALL_COST``."""

    def __init__(self, units: int) -> None:
        self.left = units

    def spend(self, units: int) -> bool:
        """Pay for a call doing ``units`` of work; False (and nothing paid) when the budget is out."""
        if self.left <= 0:
            return False
        self.left -= units + _CALL_COST
        return True


def _descend(tour: _Tour, work: _Work) -> None:
    """Passes of 2-opt and Or-opt moves until a full pass on a fresh tour finds none.

    Each pass looks at the ends near the last pass's moves. 2-opt moves held back for stale
    records wait for a refresh, made when enough of them wait, when so much has moved that
    most would, or when nothing else is left.
    """
    everything = tour.movable_ends()
    active, fresh, waiting = everything, True, []
    while work.spend(len(active)):
        touched, _ = tour.improve(active)
        work.left -= _TRY_COST * tour.tries
        waiting.append(tour.held)
        held = sum(map(len, waiting))
        if touched.size and held < (tour.n + 1) // _REFRESH_HELD and tour.moved < (tour.n + 1) // 8:
            active, fresh = tour.ends_of(touched), False
            continue
        if not touched.size and not held and fresh and active is everything:
            return  # local optimum
        work.spend(tour.n // 8)  # a refresh: ~1/9 of a pass
        tour.refresh()
        retry = np.concatenate([touched, *waiting])
        active, fresh, waiting = (tour.ends_of(retry) if retry.size else everything), True, []


class _Tour:
    """A tour as a cycle of path ends: ``adj[x]`` is the end the pen travels to or from at x.

    Home is node ``n``: its end ``2n + 1`` is the start point and its end ``2n`` (``free``) is
    a point at distance 0 from everything, so the move from the last path to it costs nothing
    and the tour is a cycle: the open tour is read from the start point, away from ``free``.
    2-opt and Or-opt moves are then a few changes of ``adj``, whatever their span.

    Or-opt moves are valid in any cycle. A 2-opt move is valid only between two
    ends that are both exits (or both entries) in one direction of travel. :meth:`refresh`
    walks the cycle and records each node's position and each end's role. Until the next
    refresh, nodes that Or-opt moves carry elsewhere are ``dirty`` (their record is
    stale), and 2-opt moves are accepted only between clean ends and only if, as intervals of
    recorded positions, they nest in or stay apart from the 2-opt moves already made: a run
    between them then turned round together with both ends or with neither, so the recorded
    roles still decide validity.
    """

    def __init__(self, ends: _Ends, adj: np.ndarray) -> None:
        self.n = n = ends.n
        self.free, self.home = 2 * n, 2 * n + 1
        self.points32, self.free_gap = ends.points32, ends.free_gap
        self.neighbours, self.distances = ends.neighbours, ends.distances
        self.adj = adj
        self.travel = self._dist(np.arange(2 * (n + 1)), adj)  # end → length of its travel edge
        self.pos = np.zeros(n + 1, np.int32)  # node → position at the last refresh (home: 0)
        self.exits = np.zeros(2 * (n + 1), np.int8)  # end → 1 if its path is left there
        self.dirty = np.zeros(n + 1, np.uint8)  # per node: moved since the last refresh
        # memoryviews give Python ints and floats from the arrays, for the scalar code below
        self._adj, self._pos, self._exits = memoryview(adj), memoryview(self.pos), memoryview(self.exits)
        self._dirty, self._travel = memoryview(self.dirty), memoryview(self.travel)
        self._xy = memoryview(ends.points.ravel())
        self.refresh()

    # -- state ------------------------------------------------------------------------------
    def refresh(self) -> None:
        """Walk the cycle from home: positions and roles for 2-opt, nothing dirty."""
        adj, x = self._adj, self.home
        walk = [x]  # the exit end of each node, in travel order (the loop does only the walk)
        step = walk.append
        for _ in range(self.n):
            x = adj[x] ^ 1
            step(x)
        walk = np.array(walk, np.int32)
        self.pos[walk >> 1] = np.arange(self.n + 1, dtype=np.int32)
        self.exits[walk] = 1
        self.exits[walk ^ 1] = 0
        self.dirty[:] = 0
        self.moved = 0
        self.reversed = _Intervals(self.n + 1)
        self.held = np.zeros(0, np.int32)  # nodes of the 2-opt moves the last pass held back

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        """``(order, reverse)`` of the open tour from home."""
        self.refresh()
        seq = np.empty(self.n + 1, np.int64)
        seq[self.pos] = np.arange(self.n + 1)
        order = seq[1:]
        return order, self.exits[2 * order] == 1  # left at its first point: drawn reversed

    def movable_ends(self) -> np.ndarray:
        return np.arange(2 * self.n + 2, dtype=np.int32)

    def ends_of(self, nodes: np.ndarray) -> np.ndarray:
        # Sorted and distinct, as np.unique gives them; a mask over the nodes is cheaper.
        nodes = self._distinct_nodes(nodes)
        return np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel().astype(np.int32)

    def _distinct_nodes(self, nodes) -> np.ndarray:
        """Sorted distinct node ids (``np.unique``, by a mask over all nodes: no sort, no hash)."""
        mask = np.zeros(self.n + 1, bool)
        mask[nodes] = True
        return np.flatnonzero(mask).astype(np.int32)

    # -- vectorised candidate moves ---------------------------------------------------------
    def improve(self, ends: np.ndarray) -> tuple[np.ndarray, float]:
        """Apply the improving moves found from ``ends``: the nodes whose edges changed, mm gained."""
        found = [self._candidates(ends[lo : lo + _CHUNK]) for lo in range(0, len(ends), _CHUNK)]
        found.append(self._candidates(self._near_the_end(), with_free=True))
        kind, e, f, gain = (np.concatenate(x) for x in zip(*found))
        self.held, self.tries = np.zeros(0, np.int32), 0
        if not gain.size:
            return np.zeros(0, np.int32), 0.0
        # The best move of each end, applied best first after a fresh check on the current tour.
        best = np.lexsort((-gain, e))
        best = best[np.r_[True, e[best][1:] != e[best][:-1]]]
        best = best[np.argsort(-gain[best], kind="stable")]
        touched: list[int] = []
        self._held: list[int] = []
        gained, attempt = 0.0, self._try
        for kd, ee, ff in zip(kind[best].tolist(), e[best].tolist(), f[best].tolist()):
            gained += attempt(kd, ee, ff, touched)
        self.held, self.tries = np.array(self._held, np.int32), len(best)
        return self._distinct_nodes(np.array(touched, np.int32)), gained

    def _near_the_end(self) -> np.ndarray:
        """Ends whose moves to or from the tour's free end can gain: around the last exit."""
        last = self.adj[self.free]
        near = self.neighbours[last]
        return np.unique(np.concatenate([[last], near, self.adj[near]]))

    def _dist(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """float32 costs of travel between ends: 0 to or from ``free`` and for joined gaps."""
        d = _dist32(self.points32, a, b)
        d[(a == self.free) | (b == self.free) | (d <= self.free_gap)] = 0
        return d

    def _candidates(self, ends: np.ndarray, with_free: bool = False):
        """Improving moves from pairs (end, nearby end): arrays (kind, e, f, gain).

        Each end is paired with its k nearest ends, or with ``free`` both ways round (moves to
        and from the end of the tour). kind 0 is 2-opt, 1..3 Or-opt of a run of that many paths
        from f. Gains are float32 estimates; :meth:`_try` decides in float64.
        """
        if with_free:
            free = np.full(len(ends), self.free, np.int32)
            e, f = np.concatenate([ends, free]), np.concatenate([free, ends])
            d = np.zeros(len(e), np.float32)
        else:
            e = np.repeat(ends, self.neighbours.shape[1])
            f = self.neighbours[ends].ravel()
            d = self.distances[ends].ravel()
            d[(e == self.free) | (f == self.free)] = 0  # free is in the tree too, at home
        de, df = self.travel[e], self.travel[f]
        # A move that shortens the tour adds an edge shorter than one it removes next to it
        # (the gain criterion of Lin–Kernighan), so other pairs cannot start an improving move.
        # (Masks as indices: converted once, then taken from every array.)
        m = np.flatnonzero((d < np.maximum(de, df)) & ((e >> 1) != (f >> 1)))
        e, f, d, de, df = (x[m] for x in (e, f, d, de, df))
        adj = self.adj
        ae, af = adj[e], adj[f]
        m = np.flatnonzero(f != ae)
        e, f, ae, af, d, de, df = (x[m] for x in (e, f, ae, af, d, de, df))
        kinds, es, fs, gains = [], [], [], []

        def keep(kind, sel, gain):
            good = gain > 1e-6
            kinds.append(np.full(int(good.sum()), kind, np.int8))
            es.append(e[sel][good])
            fs.append(f[sel][good])
            gains.append(gain[good])

        # 2-opt: travel e–f and ae–af instead of e–ae and f–af (a run between them turns round).
        s = self.exits[e] == self.exits[f]
        keep(0, s, de[s] + df[s] - d[s] - self._dist(ae[s], af[s]))
        # Or-opt: the run of `length` paths from f (away from af) goes between e and ae, f to e.
        g, inside = f ^ 1, (f >> 1) == (e >> 1)
        for length in range(1, _MAX_RUN + 1):
            if length > 1:
                g = adj[g] ^ 1
                inside |= (g >> 1) == (e >> 1)
            ag = adj[g]
            removed = df + self.travel[g] + de - d  # minus the two other new edges: a bound first
            ok = ~inside & (e != af) & (e != ag) & (g != af) & (removed > 1e-6)
            gain = removed[ok] - self._dist(af[ok], ag[ok]) - self._dist(g[ok], ae[ok])
            keep(length, ok, gain)
        return tuple(np.concatenate(x) for x in (kinds, es, fs, gains))

    # -- scalar check and application --------------------------------------------------------
    def _gap(self, a: int, b: int) -> float:
        free = self.free
        if a == free or b == free:
            return 0.0
        xy, a, b = self._xy, 2 * a, 2 * b
        d = math.hypot(xy[a] - xy[b], xy[a + 1] - xy[b + 1])
        return d if d > self.free_gap else 0.0

    def _link(self, a: int, b: int) -> None:
        """Make a and b travel partners."""
        adj = self._adj
        adj[a] = b
        adj[b] = a
        self._travel[a] = self._travel[b] = self._gap(a, b)

    def _mark(self, node: int) -> None:
        if not self._dirty[node]:
            self._dirty[node] = 1
            self.moved += 1

    def _try(self, kind: int, e: int, f: int, touched: list[int]) -> float:
        """Recompute move (kind, e, f) on the current tour in float64; apply it if it gains.

        Returns the gain in mm (0 when not applied); the nodes around the changed edges are
        added to ``touched``.
        """
        adj, gap = self._adj, self._gap  # (locals: this runs about once per path and pass)
        ae, af = adj[e], adj[f]
        if (e >> 1) == (f >> 1) or f == ae:
            return 0.0
        if kind == 0:
            exits = self._exits
            if exits[e] != exits[f]:
                return 0.0
            # Recorded positions of the two travel edges (edge t leaves position t), in order.
            pos, dirty = self._pos, self._dirty
            a, b = pos[e >> 1], pos[f >> 1]
            if not exits[e]:
                a, b = (a - 1) % (self.n + 1), (b - 1) % (self.n + 1)
            if a > b:
                a, b = b, a
            if dirty[e >> 1] or dirty[f >> 1] or not self.reversed.fits(a, b):
                self._held.append(e >> 1)  # may be valid: retried after a refresh
                return 0.0
            gain = gap(e, ae) + gap(f, af) - gap(e, f) - gap(ae, af)
            if gain <= _EPS:
                return 0.0
            self.reversed.add(a, b)
            self._link(e, f)
            self._link(ae, af)
            touched += (e >> 1, ae >> 1, f >> 1, af >> 1)
            return gain
        run = [f >> 1]
        g = f ^ 1
        for _ in range(kind - 1):
            g = adj[g] ^ 1
            run.append(g >> 1)
        ag = adj[g]
        if (e >> 1) in run or e == af or e == ag or g == af or len(set(run)) < kind:
            return 0.0
        gain = gap(f, af) + gap(g, ag) + gap(e, ae)
        gain -= gap(af, ag) + gap(e, f) + gap(g, ae)
        if gain <= _EPS:
            return 0.0
        for node in run:
            self._mark(node)
        self._link(af, ag)
        self._link(e, f)
        self._link(g, ae)
        touched += (e >> 1, ae >> 1, af >> 1, ag >> 1, *run)
        return gain


class _Intervals:
    """A laminar set of intervals [a, b] of 0..size-1: does a new one nest or stay apart?

    Each interval XORs a random 62-bit tag into a cell at both ends, so the XOR of the cells
    a < t < b is 0 exactly when every interval with an end inside has both ends inside (up to a
    2^-62 chance of a false match per test). Ends are never shared. Tests far outnumber
    intervals, so prefix XORs are kept in blocks of ``2^shift`` cells: a test reads four
    numbers, an interval rewrites two slices of about √size each.
    """

    def __init__(self, size: int) -> None:
        self.shift = max(4, (max(size, 1).bit_length() + 1) // 2)
        self.within = np.zeros(size, np.uint64)  # XOR of the cells from the block start to t
        self.before = np.zeros((size >> self.shift) + 2, np.uint64)  # XOR of the blocks before
        self._within, self._before = memoryview(self.within), memoryview(self.before)
        self.used = bytearray(size)
        self.rng = random.Random(size)

    def _toggle(self, t: int, tag: int) -> None:
        block = t >> self.shift
        self.within[t : (block + 1) << self.shift] ^= tag
        self.before[block + 1 :] ^= tag

    def fits(self, a: int, b: int) -> bool:
        if self.used[a] or self.used[b]:
            return False
        # XOR of the cells a+1..b-1: (XOR of 0..b-1) ^ (XOR of 0..a).
        within, before, shift = self._within, self._before, self.shift
        x = before[a >> shift] ^ within[a]
        if b:
            x ^= before[(b - 1) >> shift] ^ within[b - 1]
        return x == 0

    def add(self, a: int, b: int) -> None:
        tag = self.rng.getrandbits(62)
        self._toggle(a, tag)
        self._toggle(b, tag)
        self.used[a] = self.used[b] = 1
