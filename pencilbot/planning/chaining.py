"""Strokes chained along their contours into pen-down paths (step 4 of :mod:`pencilbot.planning.vectorize`).

A stroke's end and the next stroke's along the same contour lie within a pixel or two; mutual
best pairs of such ends (continuing in direction, within ``join`` · ℓ) are chained into one
pen-down path that goes out to the first stroke's tip, back to the crossing point of the two
strokes and out along the second: the ends still cross, as in the raster and as a hand draws,
the pen retraces its own overshoot instead of drawing a chord, and it lifts once per contour
rather than once per stroke. Collinear pieces (a straight contour broken by a weak spot or by
label flicker) chain the same way into one longer stroke.

Whole-array numpy and scipy (a KD-tree, connected components, a depth-first order); no loop per
stroke.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, depth_first_order
from scipy.spatial import cKDTree

from pencilbot.paths import Paths, ramps

#: Largest turn between two chained strokes, degrees (two of the 22.5° direction steps).
MAX_TURN = 50.0
#: No links at all: the empty table of rows (end a, end b, X col, X row) :func:`link_strokes` returns.
NO_LINKS = np.zeros((0, 4))


class Strokes:
    """Per component: its polyline in pixels, its two core ends and its direction.

    ``points`` (M, 2) (col, row) of all polylines back to back, ``offsets`` (n + 1) into it;
    ``core`` (n, 2, 2) where each component's pixels start and stop (before the overshoot);
    ``outward`` (n, 2, 2) the unit direction in which each end's tip leaves its core end;
    ``unit`` (n, 2) the direction of its label in (col, row); ``extent`` (n,) its length
    along that direction and ``overshoot`` (n,) how far its tips reach past the core, px.
    """

    def __init__(self, points, offsets, core, outward, unit, extent, overshoot):
        self.points, self.offsets, self.core, self.outward = points, offsets, core, outward
        self.unit, self.extent, self.overshoot = unit, extent, overshoot

    @property
    def n(self) -> int:
        return len(self.unit)

    def take(self, which: np.ndarray, shift_px: float = 0.0) -> Strokes:
        """The ``which`` components (boolean mask), moved ``shift_px`` across their direction."""
        keep = np.flatnonzero(which)
        sizes = np.diff(self.offsets)[keep]
        index = np.repeat(self.offsets[keep], sizes) + ramps(sizes)
        across = np.column_stack([-self.unit[:, 1], self.unit[:, 0]])  # (sin θ, cos θ): +v
        points = self.points[index] + shift_px * np.repeat(across[keep], sizes, axis=0)
        offsets = np.append(0, np.cumsum(sizes))
        core = self.core[keep] + shift_px * across[keep][:, None, :]
        return Strokes(
            points,
            offsets,
            core,
            self.outward[keep],
            self.unit[keep],
            self.extent[keep],
            self.overshoot[keep],
        )


def chain_ids(n: int, links: np.ndarray) -> np.ndarray:
    """Index of the chain (connected component of the link graph) of each of ``n`` components."""
    ca, cb = links[:, 0].astype(np.intp) // 2, links[:, 1].astype(np.intp) // 2
    graph = coo_matrix((np.ones(len(ca)), (ca, cb)), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def relinked(links: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """``links`` between kept components only, their end ids renumbered for the kept ones."""
    new = np.cumsum(keep) - 1
    ends = links[:, :2].astype(np.intp)
    both = keep[ends[:, 0] // 2] & keep[ends[:, 1] // 2]
    ends = 2 * new[ends[both] // 2] + ends[both] % 2
    return np.column_stack([ends, links[both, 2:]])


def link_strokes(strokes: Strokes, reach: float) -> np.ndarray:
    """Pairs of core ends that continue one contour: rows (end a, end b, X col, X row).

    End id ``2 · component + side`` (side 0 = start, 1 = end). Candidates lie within ``reach`` px,
    point away from each other within ``MAX_TURN``, and do not run back past each other; every
    end keeps its best candidate (nearest, then straightest) and only mutual choices are linked,
    for a few rounds so that an end whose choice went elsewhere can take its next best. X is the
    crossing point of the two strokes' lines, or the middle of the two core ends where the lines
    are (nearly) parallel or cross far away.
    """
    if strokes.n < 2:
        return NO_LINKS
    ends = strokes.core.reshape(-1, 2)  # end id e: component e // 2, side e % 2
    outward = strokes.outward.reshape(-1, 2)
    pairs = cKDTree(ends).query_pairs(reach, output_type="ndarray")
    pairs = pairs[pairs[:, 0] // 2 != pairs[:, 1] // 2]
    if pairs.size == 0:
        return NO_LINKS
    a, b = pairs[:, 0], pairs[:, 1]
    gap = ends[b] - ends[a]
    dist = np.hypot(gap[:, 0], gap[:, 1])
    facing = np.einsum("ij,ij->i", outward[a], outward[b])
    ahead_a = np.einsum("ij,ij->i", gap, outward[a])
    ahead_b = -np.einsum("ij,ij->i", gap, outward[b])
    lateral = np.abs(gap[:, 0] * outward[a, 1] - gap[:, 1] * outward[a, 0])
    ok = (facing <= -math.cos(math.radians(MAX_TURN))) & (ahead_a >= -1.5) & (ahead_b >= -1.5)
    ok &= lateral <= 1.5 + 0.5 * np.maximum(ahead_a, 0)
    a, b, dist, facing = a[ok], b[ok], dist[ok], facing[ok]
    cost = dist + 2.0 * (1.0 + facing)  # straighter continuations win near-ties
    linked = np.zeros((0, 2), np.intp)
    free = np.ones(len(ends), bool)
    for _ in range(3):  # rounds of mutual-best matching (each a handful of array passes)
        live = free[a] & free[b]
        if not live.any():
            break
        la, lb, lc = a[live], b[live], cost[live]
        both = np.concatenate([la, lb])
        other = np.concatenate([lb, la])
        order = np.lexsort((np.concatenate([lc, lc]), both))
        both, other = both[order], other[order]
        head = np.append(True, both[1:] != both[:-1])
        best = np.full(len(ends), -1)
        best[both[head]] = other[head]
        mutual = np.flatnonzero((best >= 0) & (best[np.maximum(best, 0)] == np.arange(len(ends))))
        mutual = mutual[mutual < best[mutual]]
        if mutual.size == 0:
            break
        linked = np.concatenate([linked, np.column_stack([mutual, best[mutual]])])
        free[mutual] = free[best[mutual]] = False
    if linked.size == 0:
        return NO_LINKS
    # Two strokes linked at both ends (a small closed curve) keep one link: a chain, not a loop
    # whose pen order the depth-first walk could not tell.
    pair = np.sort(linked // 2, axis=1)
    _, once = np.unique(pair[:, 0] * (len(ends) // 2) + pair[:, 1], return_index=True)
    linked = linked[np.sort(once)]
    reach_past = np.repeat(strokes.overshoot, 2)
    return np.column_stack([linked, _crossing(ends, outward, linked, reach_past)])


def _crossing(ends, outward, linked, overshoot):
    """Crossing point of each linked pair's lines; the middle of the core ends if none nearby.

    ``overshoot`` per end: how far its tip reaches past it (the crossing must lie within that).
    """
    pa, pb = ends[linked[:, 0]], ends[linked[:, 1]]
    da, db = outward[linked[:, 0]], outward[linked[:, 1]]
    denom = da[:, 0] * db[:, 1] - da[:, 1] * db[:, 0]
    gap = pb - pa
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (gap[:, 0] * db[:, 1] - gap[:, 1] * db[:, 0]) / denom
        cross = pa + t[:, None] * da
    middle = (pa + pb) / 2
    near = (np.abs(denom) > 0.05) & (np.abs(t) <= overshoot[linked[:, 0]])
    near &= np.hypot(*(cross - pb).T) <= overshoot[linked[:, 1]]
    return np.where(near[:, None], cross, middle)


def chain_polylines(strokes: Strokes, links: np.ndarray, shape) -> Paths:
    """Polylines (px) of the strokes, linked ones joined through their crossing points: one path
    per chain.

    The links make a graph of degree ≤ 2 on the components (each end has at most one partner):
    paths and cycles. A virtual root joined to one end component of every chain (any member for
    a cycle) makes one depth-first order in which every chain is a contiguous run, in order.
    """
    n = strokes.n
    if n == 0:
        return Paths.empty()
    ca, cb = links[:, 0].astype(np.intp) // 2, links[:, 1].astype(np.intp) // 2
    member = chain_ids(n, links)
    degree = np.bincount(np.concatenate([ca, cb]), minlength=n)
    # Start each chain at its lowest-degree member (a path's end), lowest index on ties.
    pick = np.lexsort((np.arange(n), degree, member))
    starts = pick[np.append(True, member[pick][1:] != member[pick][:-1])]
    root = np.full(starts.size, n)
    rows = np.concatenate([ca, root])
    cols = np.concatenate([cb, starts])
    graph = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n + 1, n + 1)).tocsr()
    order, pred = depth_first_order(graph, n, directed=False, return_predecessors=True)
    order = order[1:]  # drop the root
    parent = pred[order]
    new_chain = parent == n

    # Which side of each component its predecessor is linked to (that is where the pen enters).
    partner = np.full(2 * n, -1)
    partner[links[:, 0].astype(np.intp)] = links[:, 1].astype(np.intp)
    partner[links[:, 1].astype(np.intp)] = links[:, 0].astype(np.intp)
    partner_comp = np.where(partner >= 0, partner // 2, -1)
    enter_at_end = partner_comp[2 * order + 1] == parent
    # A chain's first component leaves towards its successor; it enters at the other side.
    nxt = np.append(order[1:], -1)
    has_next = np.append(~new_chain[1:], False)
    leave_at_start = partner_comp[2 * order] == nxt
    enter_at_end = np.where(new_chain, has_next & leave_at_start, enter_at_end)
    crossing = np.full((2 * n, 2), np.nan)
    crossing[links[:, 0].astype(np.intp)] = links[:, 2:]
    crossing[links[:, 1].astype(np.intp)] = links[:, 2:]

    # Flat list of point indices: each component's polyline (reversed if entered at its end),
    # then, if the chain goes on, the crossing point at the side the pen leaves by.
    sizes = np.diff(strokes.offsets)[order]
    ramp = ramps(sizes)
    index = np.repeat(strokes.offsets[order], sizes) + np.where(
        np.repeat(enter_at_end, sizes), np.repeat(sizes - 1, sizes) - ramp, ramp
    )
    points = strokes.points[index]
    leave_side = 2 * order + np.where(enter_at_end, 0, 1)
    joint = crossing[leave_side]
    has_joint = has_next
    # Interleave: after the last point of component k comes its joint (when it has one).
    ends_at = np.cumsum(sizes)
    insert_at = ends_at[has_joint]
    points = np.insert(points, insert_at, joint[has_joint], axis=0)
    points = _clip_points(points, shape)
    chain_sizes = np.bincount(np.cumsum(new_chain) - 1, weights=sizes + has_joint).astype(np.intp)
    return Paths(points, np.concatenate([[0], np.cumsum(chain_sizes)]))


def _clip_points(points: np.ndarray, shape) -> np.ndarray:
    """Points moved into the image rectangle (overshooting tips stop at the frame)."""
    height, width = shape
    return np.column_stack([np.clip(points[:, 0], 0, width - 1), np.clip(points[:, 1], 0, height - 1)])
