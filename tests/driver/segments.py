"""Compare what two plots drew, as a multiset of pen-down segments, to a micrometre.

A resumed job may draw one move in two pieces (up to the stop, then from it), and real plans
draw overlapping collinear segments (a hatch line and the joined path that runs back along it,
a stroke passed twice), so pieces are not matched to segments one to one. Instead the reference
segments are grouped by the line they lie on (collinear segments that overlap or touch, to the
tolerance, share a group), and along each group's line the number of times each stretch is
drawn is compared: the reference's count against the count of the pieces that lie on that line.
A piece on no reference line, a stretch missing, or drawn once too often fails, with what and
where. Everything is whole arrays: pairs of segments in blocks, one sort of all the coverage
events.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

TOLERANCE = 1e-3  # mm: 1 µm
_BLOCK = 1 << 21  # pairs tested at a time (bounds the memory of the pair tests)


def pieces(strokes, shortest: float = TOLERANCE) -> np.ndarray:
    """(n, 2, 2) start and end points (mm) of every segment of pen-down polylines longer than
    ``shortest`` mm."""
    parts = [np.stack([s[:-1, :2], s[1:, :2]], axis=1) for s in strokes if len(s) >= 2]
    if not parts:
        return np.zeros((0, 2, 2))
    segments = np.concatenate(parts).astype(float)
    return segments[np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1) > shortest]


def _lying_on(some: np.ndarray, lines: np.ndarray, tolerance: float, touch: bool):
    """Pairs (i, j): segment ``some[i]`` lies on the line of ``lines[j]`` (both ends within
    ``tolerance`` of it) and overlaps it along the line (or touches it, with ``touch``).
    Also each pair's overlap length (mm)."""
    a, d = lines[:, 0], lines[:, 1] - lines[:, 0]
    length = np.linalg.norm(d, axis=1)
    unit = d / length[:, None]
    lo_box = np.minimum(lines[:, 0], lines[:, 1]) - tolerance
    hi_box = np.maximum(lines[:, 0], lines[:, 1]) + tolerance
    s_lo, s_hi = np.minimum(some[:, 0], some[:, 1]), np.maximum(some[:, 0], some[:, 1])
    rows = max(1, _BLOCK // max(len(lines), 1))
    found_i, found_j, found_overlap = [], [], []
    for start in range(0, len(some), rows):
        block = slice(start, start + rows)
        # Boxes first (cheap), then the exact test on the pairs left.
        box = ((s_lo[block, None, :] <= hi_box[None]) & (s_hi[block, None, :] >= lo_box[None])).all(-1)
        i, j = np.nonzero(box)
        i += start
        p, q = some[i, 0] - a[j], some[i, 1] - a[j]
        u = unit[j]
        off_p = np.abs(p[:, 0] * u[:, 1] - p[:, 1] * u[:, 0])
        off_q = np.abs(q[:, 0] * u[:, 1] - q[:, 1] * u[:, 0])
        tp, tq = (p * u).sum(1), (q * u).sum(1)
        overlap = np.minimum(np.maximum(tp, tq), length[j]) - np.maximum(np.minimum(tp, tq), 0.0)
        keep = (off_p <= tolerance) & (off_q <= tolerance) & (overlap > (-tolerance if touch else tolerance))
        found_i.append(i[keep])
        found_j.append(j[keep])
        found_overlap.append(overlap[keep])
    if not found_i:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(found_i), np.concatenate(found_j), np.concatenate(found_overlap)


def _line_groups(reference: np.ndarray, tolerance: float) -> np.ndarray:
    """Group number of each reference segment: collinear segments that overlap or touch."""
    n = len(reference)
    i, j, _ = _lying_on(reference, reference, tolerance, touch=True)
    graph = coo_matrix((np.ones(len(i), bool), (i, j)), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def drawing_differences(got, reference, tolerance: float = TOLERANCE) -> list[str]:
    """What differs between two drawings (pen-down polylines in mm), in words; empty if same."""
    # A drawn piece shorter than the tolerance counts too (a resume that draws the last 0.9 µm of
    # a move draws them); the reference's lines are its segments longer than the tolerance.
    drawn, ref = pieces(got, shortest=1e-9), pieces(reference)
    problems = []
    if not len(ref):
        return [f"drawn where the reference has no stroke: {p.round(4)} -> {q.round(4)}" for p, q in drawn]
    group = _line_groups(ref, tolerance)
    # Each group's axis: its longest segment (the best-defined direction).
    length = np.linalg.norm(ref[:, 1] - ref[:, 0], axis=1)
    order = np.lexsort((-length, group))
    axis_of = order[np.flatnonzero(np.r_[True, group[order][1:] != group[order][:-1]])]
    origin = ref[axis_of, 0]
    unit = (ref[axis_of, 1] - origin) / length[axis_of, None]

    # Every drawn piece goes to the group of the reference segment it overlaps most (a piece up to
    # twice the tolerance long: the one it lies on, overlapping or not; GRBL reports where a stop
    # left the pen to the micrometre, so a resume may draw the last 1.0 µm of a move, and a
    # piece of exactly the tolerance fell either side of it by the float's last bit).
    i, j, overlap = _lying_on(drawn, ref, tolerance, touch=True)
    short = np.linalg.norm(drawn[i, 1] - drawn[i, 0], axis=1) <= 2 * tolerance
    i, j, overlap = (
        i[short | (overlap > tolerance)],
        j[short | (overlap > tolerance)],
        overlap[short | (overlap > tolerance)],
    )
    best = np.lexsort((-overlap, i))
    first = best[np.flatnonzero(np.r_[True, i[best][1:] != i[best][:-1]])] if len(best) else best
    piece_group = np.full(len(drawn), -1)
    piece_group[i[first]] = group[j[first]]
    for p, q in drawn[piece_group < 0]:
        problems.append(f"drawn where the reference has no stroke: {p.round(4)} -> {q.round(4)}")
    placed = drawn[piece_group >= 0]
    placed_group = piece_group[piece_group >= 0]

    def interval(segments, g):
        t = ((segments - origin[g][:, None]) * unit[g][:, None]).sum(-1)
        return t.min(1), t.max(1)

    # Coverage events: +1 where an interval starts, −1 where it ends, for the reference and the
    # drawing apart; sorted by group and position, the running sums are each stretch's counts.
    r0, r1 = interval(ref, group)
    d0, d1 = interval(placed, placed_group)
    g = np.concatenate([group, group, placed_group, placed_group])
    t = np.concatenate([r0, r1, d0, d1])
    n_ref, n_drawn = len(ref), len(placed)
    dref = np.concatenate([np.ones(n_ref), -np.ones(n_ref), np.zeros(2 * n_drawn)])
    ddrawn = np.concatenate([np.zeros(2 * n_ref), np.ones(n_drawn), -np.ones(n_drawn)])
    order = np.lexsort((t, g))
    g, t = g[order], t[order]
    ref_count = np.rint(np.cumsum(dref[order])).astype(int)[:-1]
    drawn_count = np.rint(np.cumsum(ddrawn[order])).astype(int)[:-1]
    lo, hi, same_group = t[:-1], t[1:], g[:-1] == g[1:]
    bad = np.flatnonzero(same_group & (hi - lo > tolerance) & (ref_count != drawn_count))
    for k in bad:
        start, end = origin[g[k]] + lo[k] * unit[g[k]], origin[g[k]] + hi[k] * unit[g[k]]
        want, have = ref_count[k], drawn_count[k]
        what = (
            "drawn where the reference has no stroke"
            if want == 0
            else "missing"
            if have < want
            else f"drawn {have} times"
        )
        problems.append(
            f"{hi[k] - lo[k]:.4f} mm of {start.round(4)} -> {end.round(4)} {what} "
            f"(reference: {want}, drawn: {have})"
        )
    return problems


def assert_same_drawing(got, reference) -> None:
    """Fail unless ``got`` draws exactly the pen-down segments of ``reference`` (to 1 µm)."""
    problems = drawing_differences(got, reference)
    assert not problems, f"{len(problems)} differences: " + "; ".join(problems[:8])
