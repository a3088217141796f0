"""The order the pen draws paths in: short pen-up travel, fewer lifts.

A path may be drawn in either direction. The pen starts at its home position. Three steps:

1. **Greedy nearest neighbour** over both ends of every path (so a path can be entered at either
   end), using a k-nearest-neighbour graph of all ends and a KD-tree of the ends still free when
   the graph's candidates are used up. This alone is what plotter tools commonly do
   (:func:`greedy_order`, the baseline).
2. **Local improvement** for a fixed number of rounds of vectorised moves: every pair of nearby
   ends proposes a 2-opt move (reverse a run of paths, each path flipped) and Or-opt moves (move a
   run of 1–3 paths elsewhere, optionally reversed); the gains of all proposals are computed at
   once with numpy and a set of non-conflicting improving moves is applied per round. Rounds left
   at a local optimum go to iterated local search (double-bridge kicks, keep improvements).
   The budget is counted in rounds, not seconds, so the same paths always give the same order
   (a plan, and its G-code, are reproducible on any machine).
3. **Joining**: consecutive paths whose ends meet within ``join_tolerance`` (the pen width) become
   one path, so the pen stays down across the gap.

The tour is open: it starts at home and ends wherever the last path ends.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

_NEIGHBOURS = 10  # nearby ends per end: enough candidate moves, cheap to compute
_MAX_RUN = 3  # Or-opt moves runs of up to this many paths
_EPS = 1e-9  # mm: gains below this are float noise
DEFAULT_ROUNDS = 40  # reaches ~0.75 of greedy's pen-up travel on photo plans (bench/ordering.py)
# A round costs about one pass over the paths: cap rounds × paths so that 100 000 strokes order
# in seconds (4 rounds there) while photo layers of a few thousand paths get all their rounds.
ROUND_WORK = 400_000


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
        Improvement rounds after the greedy tour (each costs about one pass over the paths),
        at most ``ROUND_WORK / len(paths)`` (but at least 4); 0 keeps the greedy tour. The
        result depends only on the paths and this number.

    Returns
    -------
    list of (N, 2) arrays
        The same strokes, each possibly reversed, in drawing order, some joined.
    """
    arrays = _nonempty(paths)
    order, reverse = improve_order(arrays, start, rounds=rounds)
    ordered = _apply(arrays, order, reverse)
    tolerance = pen_width if join_tolerance is None else join_tolerance
    return join_touching(ordered, tolerance, min_length=join_min_length) if tolerance >= 0 else ordered


def greedy_order(paths: Sequence[np.ndarray], start: tuple[float, float] = (0.0, 0.0)) -> list[np.ndarray]:
    """Baseline: nearest neighbour with reversal from ``start``, no improvement, no joining."""
    arrays = _nonempty(paths)
    ends = _Ends(arrays, start)
    order, reverse = _greedy(ends, ends.neighbours())
    return _apply(arrays, order, reverse)


def travel_length(paths: Sequence[np.ndarray], start: tuple[float, float] = (0.0, 0.0)) -> float:
    """Pen-up travel in mm: from ``start`` to the first path, then between consecutive paths."""
    arrays = _nonempty(paths)
    if not arrays:
        return 0.0
    heads = np.array([p[0] for p in arrays])
    tails = np.array([np.asarray(start, np.float64)] + [p[-1] for p in arrays[:-1]])
    return float(np.hypot(*(heads - tails).T).sum())


def improve_order(
    paths: Sequence[np.ndarray],
    start: tuple[float, float],
    *,
    rounds: int = DEFAULT_ROUNDS,
) -> tuple[np.ndarray, np.ndarray]:
    """Greedy tour then local improvement: ``(order, reverse)`` indices into ``paths`` and flags."""
    ends = _Ends(paths, start)
    if ends.n == 0:
        return np.zeros(0, np.int64), np.zeros(0, bool)
    neighbours = ends.neighbours()
    order, reverse = _greedy(ends, neighbours)
    budget = _Budget(min(rounds, max(4, ROUND_WORK // ends.n)))
    tour = _Tour(ends, neighbours, order, reverse)
    _descend(tour, budget)
    # Iterated local search with the rounds left: a local optimum is kicked (double bridge
    # within a short window) and descended again; only improvements are kept.
    rng = np.random.default_rng(0)
    best, best_length = tour.snapshot(), tour.length()
    while budget.take() and ends.n >= 8:
        tour.double_bridge(rng)
        _descend(tour, budget)
        length = tour.length()
        if length < best_length - _EPS:
            best, best_length = tour.snapshot(), length
        else:
            tour.restore(best)
    return tour.result()


class _Budget:
    """Improvement rounds left."""

    def __init__(self, rounds: int) -> None:
        self.rounds = int(rounds)

    def take(self) -> bool:
        """Spend one round if any is left."""
        if self.rounds <= 0:
            return False
        self.rounds -= 1
        return True


def _descend(tour: _Tour, budget: _Budget) -> None:
    """Rounds of Or-opt and 2-opt moves until none improves or the budget is spent."""
    while budget.take():
        improved = tour.or_opt_round()  # first: it gains most per round on a greedy tour
        if not budget.take():
            break
        improved |= tour.two_opt_round()
        if not improved:
            break


def join_touching(paths: Sequence[np.ndarray], tolerance: float, *, min_length: float = 0.0) -> list[np.ndarray]:
    """Join consecutive paths whose gap (end of one to start of the next) is ≤ ``tolerance`` mm,
    unless one of them is shorter than ``min_length`` mm."""
    arrays = _nonempty(paths)
    if len(arrays) < 2:
        return arrays
    heads = np.array([p[0] for p in arrays[1:]])
    tails = np.array([p[-1] for p in arrays[:-1]])
    gap = np.hypot(*(heads - tails).T)
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
    arrays = [np.asarray(p, np.float64).reshape(-1, 2) for p in paths]
    return [p for p in arrays if len(p)]


def _apply(paths: list[np.ndarray], order: np.ndarray, reverse: np.ndarray) -> list[np.ndarray]:
    return [paths[i][::-1] if r else paths[i] for i, r in zip(order.tolist(), reverse.tolist())]


class _Ends:
    """Both ends of every path plus the home as node ``n`` (its two ends are ``start``).

    End id ``e`` is end ``e // (n + 1)`` (0 = first point, 1 = last point) of node ``e % (n + 1)``.
    """

    def __init__(self, paths: Sequence[np.ndarray], start) -> None:
        self.n = len(paths)
        home = np.asarray(start, np.float64).reshape(1, 2)
        first = np.concatenate([np.array([p[0] for p in paths]).reshape(-1, 2), home])
        last = np.concatenate([np.array([p[-1] for p in paths]).reshape(-1, 2), home])
        self.points = np.concatenate([first, last])  # (2(n+1), 2)

    def neighbours(self) -> np.ndarray:
        """(2(n+1), k) nearest other ends of each end, nearest first."""
        count = len(self.points)
        k = min(_NEIGHBOURS + 1, count)
        _, idx = cKDTree(self.points).query(self.points, k=k)
        idx = np.asarray(idx).reshape(count, k)
        keep = idx != np.arange(count)[:, None]
        # each end's own entry is normally first; among duplicate points it may be missing: drop the farthest
        keep[keep.all(axis=1), -1] = False
        return idx[keep].reshape(count, k - 1)


def _greedy(ends: _Ends, neighbours: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-neighbour tour from home over both ends of every path."""
    n, nodes = ends.n, ends.n + 1
    points = ends.points
    used = bytearray(nodes)
    used[n] = 1  # home
    nbr = neighbours.tolist()
    order, reverse = [], []
    free_ids = np.flatnonzero(np.arange(2 * nodes) % nodes != n)
    tree, tree_ids, stale = cKDTree(points[free_ids]), free_ids, 0
    current = n  # end id at which the pen stands: home
    for _ in range(n):
        chosen = next((e for e in nbr[current] if not used[e % nodes]), -1)
        if chosen < 0:
            if stale > len(tree_ids) // 2:  # most of the tree is used up: rebuild with free ends
                alive = np.frombuffer(bytes(used), np.uint8)[tree_ids % nodes] == 0
                tree_ids = tree_ids[alive]
                tree, stale = cKDTree(points[tree_ids]), 0
            k = 16
            while chosen < 0:
                k = min(k, len(tree_ids))
                _, idx = tree.query(points[current], k=k)
                for e in tree_ids[np.atleast_1d(idx)].tolist():
                    if not used[e % nodes]:
                        chosen = e
                        break
                k *= 4
        node = chosen % nodes
        used[node] = 1
        stale += 2
        entered_at_last = chosen >= nodes
        order.append(node)
        reverse.append(entered_at_last)
        current = node if entered_at_last else node + nodes  # leave by the other end
    return np.array(order, np.int64), np.array(reverse, bool)


class _Tour:
    """An open tour home → paths, improved by rounds of vectorised 2-opt and Or-opt moves.

    Positions: 0 is home, 1..n the paths; edge ``t`` joins position ``t`` to ``t + 1``; edge ``n``
    leads to the free end of the tour and costs nothing.
    """

    def __init__(self, ends: _Ends, neighbours: np.ndarray, order, reverse) -> None:
        self.n = ends.n
        self.nodes = ends.n + 1
        self.points = ends.points
        self.seq = np.concatenate([[ends.n], order])  # node at each position
        self.rev = np.zeros(self.nodes, bool)  # per node: drawn last → first
        self.rev[order] = reverse
        pairs_e = np.repeat(np.arange(len(neighbours)), neighbours.shape[1])
        pairs_f = neighbours.ravel()
        keep = pairs_e % self.nodes != pairs_f % self.nodes  # not the other end of the same path
        self.pair_e, self.pair_f = pairs_e[keep], pairs_f[keep]
        self.pair_d = np.hypot(*(self.points[self.pair_e] - self.points[self.pair_f]).T)

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        order = self.seq[1:]
        return order, self.rev[order]

    def snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        return self.seq.copy(), self.rev.copy()

    def restore(self, state: tuple[np.ndarray, np.ndarray]) -> None:
        self.seq, self.rev = state[0].copy(), state[1].copy()

    def length(self) -> float:
        """Pen-up travel of the tour, mm."""
        return float(self._state()[2].sum())

    def double_bridge(self, rng: np.random.Generator, window: int = 30) -> None:
        """Swap two neighbouring runs of paths (A B C D → A C B D), a kick 2-opt cannot undo."""
        n = self.n
        p1 = int(rng.integers(1, n - 1))
        p2 = min(p1 + int(rng.integers(1, window)), n)
        p3 = min(p2 + int(rng.integers(1, window)), n + 1)
        seq = self.seq
        self.seq = np.concatenate([seq[:p1], seq[p2:p3], seq[p1:p2], seq[p3:]])

    def _state(self):
        """Per position: entry point, exit point, cost of the outgoing edge; per end: role and position."""
        seq, rev, nodes = self.seq, self.rev, self.nodes
        first, last = self.points[:nodes], self.points[nodes:]
        r = rev[seq][:, None]
        entry = np.where(r, last[seq], first[seq])
        exit_ = np.where(r, first[seq], last[seq])
        cost = np.zeros(self.n + 1)
        cost[:-1] = np.hypot(*(entry[1:] - exit_[:-1]).T)
        pos = np.empty(nodes, np.int64)
        pos[seq] = np.arange(nodes)

        def role(e):  # True when end e is its node's exit in the current tour
            return (e >= nodes) != rev[e % nodes]

        return entry, exit_, cost, pos, role

    def _promising_pairs(self, cost, pos, role):
        """Pairs of ends (e, f) closer than the tour edge now attached to e or to f.

        A move that shortens the tour adds an edge shorter than an edge it removes next to it
        (the gain criterion of Lin–Kernighan), so other pairs cannot start an improving move.
        """
        e, f = self.pair_e, self.pair_f
        re, rf = role(e), role(f)
        pe, pf = pos[e % self.nodes], pos[f % self.nodes]
        attached_e = cost[np.where(re, pe, np.maximum(pe - 1, 0))]
        attached_f = cost[np.where(rf, pf, np.maximum(pf - 1, 0))]
        m = self.pair_d < np.maximum(attached_e, attached_f)
        return re[m], rf[m], pe[m], pf[m], self.pair_d[m]

    def _to_entry(self, point: np.ndarray, t: np.ndarray, entry: np.ndarray) -> np.ndarray:
        """Distance from points to the entry of position t; position n + 1 is the free end (0)."""
        inside = t <= self.n
        target = entry[np.minimum(t, self.n)]
        return np.where(inside, np.hypot(*(point - target).T), 0.0)

    def two_opt_round(self) -> bool:
        """Reverse runs of paths where reconnecting two nearby ends shortens travel."""
        entry, exit_, cost, pos, role = self._state()
        re, rf, pe, pf, _ = self._promising_pairs(cost, pos, role)
        same = re == rf
        # both exits: edges at their positions; both entries: edges before their positions
        a = pe[same] - (~re[same]).astype(np.int64)
        b = pf[same] - (~rf[same]).astype(np.int64)
        a, b = np.minimum(a, b), np.maximum(a, b)
        ok = (a >= 0) & (a < b)
        a, b = a[ok], b[ok]
        gain = (
            cost[a] + cost[b]
            - np.hypot(*(exit_[a] - exit_[b]).T)
            - self._to_entry(entry[a + 1], b + 1, entry)
        )
        better = gain > _EPS
        a, b, gain = a[better], b[better], gain[better]
        if not len(a):
            return False
        chosen = _disjoint_intervals(a, b, gain)
        seq, rev = self.seq, self.rev
        for lo, hi in chosen:
            run = seq[lo + 1 : hi + 1][::-1].copy()
            seq[lo + 1 : hi + 1] = run
            rev[run] ^= True
        return True

    def or_opt_round(self) -> bool:
        """Move runs of 1–3 paths (optionally reversed) next to a nearby end."""
        entry, exit_, cost, pos, role = self._state()
        n = self.n
        re, rf, pe, pf, d = self._promising_pairs(cost, pos, role)
        cands = []  # (i, j, p, reversed, length of the new edge between the pair's ends)
        for length in range(1, _MAX_RUN + 1):
            span = length - 1
            # exit of p near entry of i: run i..j forward after p
            m = re & ~rf
            cands.append((pf[m], pf[m] + span, pe[m], False, d[m]))
            # entry of q near exit of j: run i..j forward before q
            m = ~re & rf
            cands.append((pf[m] - span, pf[m], pe[m] - 1, False, d[m]))
            # exit of p near exit of j: run i..j reversed after p
            m = re & rf
            cands.append((pf[m] - span, pf[m], pe[m], True, d[m]))
            # entry of q near entry of i: run i..j reversed before q
            m = ~re & ~rf
            cands.append((pf[m], pf[m] + span, pe[m] - 1, True, d[m]))
        i, j, p, dist = (np.concatenate([c[k] for c in cands]) for k in (0, 1, 2, 4))
        flip = np.concatenate([np.full(len(c[0]), c[3]) for c in cands])
        ok = (i >= 1) & (j <= n) & (p >= 0) & ((p < i - 1) | (p > j))
        i, j, p, flip, dist = i[ok], j[ok], p[ok], flip[ok], dist[ok]
        removed = cost[i - 1] + cost[j] + cost[p]
        # The pair's own edge is one of the three added: a cheap bound that rules most out.
        hopeful = removed - dist > _EPS
        i, j, p, flip, removed = i[hopeful], j[hopeful], p[hopeful], flip[hopeful], removed[hopeful]
        bridge = self._to_entry(exit_[i - 1], j + 1, entry)
        run_in = np.where(flip[:, None], exit_[j], entry[i])  # first point drawn of the moved run
        run_out = np.where(flip[:, None], entry[i], exit_[j])  # last point drawn
        added = bridge + np.hypot(*(exit_[p] - run_in).T) + self._to_entry(run_out, p + 1, entry)
        gain = removed - added
        better = gain > _EPS
        if not better.any():
            return False
        i, j, p, flip, gain = i[better], j[better], p[better], flip[better], gain[better]
        keep = _independent_moves(i, j, p, gain, n)
        i, j, p, flip = i[keep], j[keep], p[keep], flip[keep]
        # Re-sort positions: a moved path gets a key just after p, in its new drawing order.
        key = np.arange(n + 1, dtype=np.float64)
        lengths = j - i + 1
        moved = np.concatenate([np.arange(a, b + 1) for a, b in zip(i.tolist(), j.tolist())])
        rank = moved - np.repeat(i, lengths)
        rank = np.where(np.repeat(flip, lengths), np.repeat(lengths, lengths) - 1 - rank, rank)
        key[moved] = np.repeat(p, lengths) + 0.1 * (1 + rank)
        self.rev[self.seq[moved[np.repeat(flip, lengths)]]] ^= True
        self.seq = self.seq[np.argsort(key, kind="stable")]
        return True


def _disjoint_intervals(a: np.ndarray, b: np.ndarray, gain: np.ndarray) -> list[tuple[int, int]]:
    """Best-gain-first set of edge intervals [a, b] that share no edge and do not overlap."""
    starts: list[int] = []
    chosen: dict[int, int] = {}
    for k in np.argsort(-gain, kind="stable").tolist():
        lo, hi = int(a[k]), int(b[k])
        at = bisect.bisect_left(starts, lo)
        if at < len(starts) and starts[at] <= hi:
            continue  # an accepted interval starts inside this one
        if at > 0 and chosen[starts[at - 1]] >= lo:
            continue  # the previous accepted interval reaches into this one
        starts.insert(at, lo)
        chosen[lo] = hi
    return [(lo, chosen[lo]) for lo in starts]


def _independent_moves(i, j, p, gain, n) -> np.ndarray:
    """Best-gain-first Or-opt moves whose touched positions (edges and run) do not overlap."""
    busy = bytearray(n + 2)
    keep = []
    for k in np.argsort(-gain, kind="stable").tolist():
        lo, hi, at = int(i[k]) - 1, int(j[k]) + 1, int(p[k])
        if any(busy[lo : hi + 1]) or busy[at] or busy[at + 1]:
            continue
        busy[lo : hi + 1] = b"\x01" * (hi - lo + 1)
        busy[at] = busy[at + 1] = 1
        keep.append(k)
    return np.array(keep, np.int64)
