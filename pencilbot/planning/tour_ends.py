"""Path ends as the nodes of a pen tour, and the two greedy tours over them.

Every path contributes two ends (its first and last point) and the pen's home one more; a tour
pairs each path's ends (drawn through) and links an exit to the next entry (pen-up travel).
:class:`Ends` holds the ends, renumbered along a Morton (Z-order) curve so neighbours sit near
each other in memory, with their k nearest other ends. The two tours that start the search
(:mod:`pencilbot.planning.ordering`): greedy nearest neighbour from home, and a greedy matching
of chain ends in vectorised rounds of mutual nearest neighbours.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

_NEIGHBOURS = 10  # nearby ends per end: enough candidate moves, cheap to compute
CHUNK = 8192  # ends per vectorised evaluation: ~80k candidate pairs, temporaries of a few MB


def dist32(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """float32 distances between points a and b of (N,) complex64 ``points`` (x + iy).

    Gathering one 8-byte complex per point is ~4x faster than gathering rows of an (N, 2)
    array; the subtraction is the same float32 one per coordinate.
    """
    delta = (points[a] - points[b]).view(np.float32).reshape(-1, 2)
    return np.sqrt(np.einsum("ij,ij->i", delta, delta))


def morton_order(points: np.ndarray) -> np.ndarray:
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
    with np.errstate(over="ignore"):
        factor = 65535.0 / extent if extent > 0 else 0.0
    if np.isfinite(factor):
        cells = ((points - low) * factor).astype(np.uint64)
    else:  # a subnormal extent: its reciprocal overflows, the fractions of it do not
        cells = ((points - low) / extent * 65535.0).astype(np.uint64)

    def spread(v):  # 16 bits → every other of 32 bits
        v = (v | (v << np.uint64(8))) & np.uint64(0x00FF00FF)
        v = (v | (v << np.uint64(4))) & np.uint64(0x0F0F0F0F)
        v = (v | (v << np.uint64(2))) & np.uint64(0x33333333)
        return (v | (v << np.uint64(1))) & np.uint64(0x55555555)

    key = spread(cells[:, 0]) | (spread(cells[:, 1]) << np.uint64(1))
    return np.argsort(key, kind="stable")


class Ends:
    """Both ends of every path plus the home as node ``n``; nearest neighbours of every end.

    End id ``e`` is end ``e & 1`` (0 = first point, 1 = last point) of node ``e >> 1``. Home's
    end ``2n + 1`` is the start point; its end ``2n`` is the tour's free end (see
    :class:`~pencilbot.planning.tour_search.Tour`), stored at the start point too. Gaps up to
    ``free_gap`` mm cost nothing (they are joined).
    """

    def __init__(self, first: np.ndarray, last: np.ndarray, start, free_gap: float = 0.0) -> None:
        self.n = len(first)
        self.free_gap = free_gap
        points = np.empty((2 * (self.n + 1), 2))
        points[0:-2:2], points[1:-2:2] = first, last
        points[-2:] = np.asarray(start, np.float64)
        self.points = points
        self.points32 = points.astype(np.float32).view(np.complex64).ravel()  # x + iy, see dist32
        count = len(points)
        self.k = min(_NEIGHBOURS, count - 2)  # a node's own two ends are never candidates
        self.tree = cKDTree(points, balanced_tree=False)
        self.neighbours = np.empty((count, self.k), np.int32)
        self.distances = np.empty((count, self.k), np.float32)
        for lo in range(0, count, 16 * CHUNK):  # in chunks: the query's float64 temporaries
            rows = np.arange(lo, min(lo + 16 * CHUNK, count), dtype=np.int32)
            d, idx = self.tree.query(points[rows], k=min(self.k + 2, count))
            d, idx = np.asarray(d).reshape(len(rows), -1), np.asarray(idx, np.int32).reshape(len(rows), -1)
            # Equal distances (regular hatching) in id order, as the matching breaks ties by it.
            tied = np.flatnonzero((d[:, 1:] == d[:, :-1]).any(axis=1))
            by = np.lexsort((idx[tied], d[tied]), axis=1)
            d[tied], idx[tied] = (
                np.take_along_axis(d[tied], by, axis=1),
                np.take_along_axis(idx[tied], by, axis=1),
            )
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


def greedy_tour(ends: Ends) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-neighbour tour from home over both ends of every path: ``(order, reverse)``."""
    n, k = ends.n, ends.k
    used = bytearray(n + 1)
    used[n] = 1  # home
    nbr = np.ascontiguousarray(ends.neighbours).ravel().data  # Python ints per index
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


def adjacency(order: np.ndarray, reverse: np.ndarray) -> np.ndarray:
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


def greedy_matching(ends: Ends) -> np.ndarray:
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
