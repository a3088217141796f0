"""Compare what two plots drew, as a multiset of pen-down segments, to a micrometre.

A resumed job may draw one move in two pieces (up to the stop, then from it), so pieces are
not compared one to one: every piece drawn must lie on a segment of the reference, and along
every reference segment the pieces must cover each point exactly as often as the reference
does (once, unless the reference itself draws it twice). Anything missing, drawn twice, or
drawn somewhere else fails, with what and where.
"""

from __future__ import annotations

import numpy as np

TOLERANCE = 1e-3  # mm: 1 µm


def pieces(strokes) -> np.ndarray:
    """(n, 2, 2) start and end points (mm) of every non-empty segment of pen-down polylines."""
    parts = [np.stack([s[:-1, :2], s[1:, :2]], axis=1) for s in strokes if len(s) >= 2]
    if not parts:
        return np.zeros((0, 2, 2))
    segments = np.concatenate(parts).astype(float)
    return segments[np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1) > TOLERANCE]


def _groups(reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct reference segments (direction ignored) and how often each is drawn."""
    ordered = np.where((reference[:, 0, 0] > reference[:, 1, 0])[:, None, None], reference[:, ::-1], reference)
    keys = np.round(ordered.reshape(len(ordered), 4) / TOLERANCE).astype(np.int64)
    _, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    return ordered[first], counts


def drawing_differences(got, reference, tolerance: float = TOLERANCE) -> list[str]:
    """What differs between two drawings (pen-down polylines in mm), in words; empty if same."""
    drawn, ref = pieces(got), pieces(reference)
    segments, counts = _groups(ref) if len(ref) else (np.zeros((0, 2, 2)), np.zeros(0, int))
    a, b = segments[:, 0], segments[:, 1]
    d = b - a
    length = np.linalg.norm(d, axis=1)
    unit = d / length[:, None] if len(length) else d
    problems = []
    along = [[] for _ in segments]
    for p, q in drawn:
        # Both ends within tolerance of a reference segment: the piece lies on it.
        tp, tq = ((p - a) * unit).sum(1), ((q - a) * unit).sum(1)
        off_p = np.abs((p - a)[:, 0] * unit[:, 1] - (p - a)[:, 1] * unit[:, 0])
        off_q = np.abs((q - a)[:, 0] * unit[:, 1] - (q - a)[:, 1] * unit[:, 0])
        on = ((off_p <= tolerance) & (off_q <= tolerance) & (np.minimum(tp, tq) >= -tolerance)
              & (np.maximum(tp, tq) <= length + tolerance))
        hits = np.flatnonzero(on)
        if not len(hits):
            problems.append(f"drawn where the reference has no stroke: {p.round(4)} -> {q.round(4)}")
            continue
        k = hits[0]
        along[k].append((min(tp[k], tq[k]), max(tp[k], tq[k])))
    for k, intervals in enumerate(along):
        ends = sorted({0.0, float(length[k]), *(t for iv in intervals for t in iv)})
        for lo, hi in zip(ends, ends[1:]):
            if hi - lo <= tolerance:
                continue
            mid = (lo + hi) / 2
            cover = sum(1 for s, e in intervals if s <= mid <= e)
            if cover != counts[k]:
                what = "missing" if cover < counts[k] else f"drawn {cover} times"
                problems.append(f"{hi - lo:.4f} mm of segment {a[k].round(4)} -> {b[k].round(4)} {what} "
                                f"(reference: {counts[k]})")
    return problems


def assert_same_drawing(got, reference) -> None:
    """Fail unless ``got`` draws exactly the pen-down segments of ``reference`` (to 1 µm)."""
    problems = drawing_differences(got, reference)
    assert not problems, f"{len(problems)} differences: " + "; ".join(problems[:8])
