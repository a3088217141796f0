"""Reordering a finished drawing for the plotter: drop covered specks, order, join what touches.

A drawing made by another tool (a hatching or contour tracer, Inkscape) keeps the order it was
generated in, which can double the pen-up travel. Each layer, in its place and starting where
the previous one ended (the first at the plotter's home), is reordered with
:func:`~pencilbot.planning.ordering.order_paths`: paths may be reversed, and paths whose ends
come within the pen width of each other are joined with a pen-down move, which draws no more
than the round pen tips already cover. Specks, paths shorter than the pen width lying within
half a pen width of another path, are dropped: the other path's ink already covers them, and
each would cost a lift. An isolated dot stays (a stipple is made of them).

Nothing else changes: every segment of every other path is drawn exactly once, and a layer whose
new order would travel further than the file's own keeps the file's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from pencilbot.paths import Paths, ramps
from pencilbot.planning.ordering import ROUND_WORK, order_paths
from pencilbot.planning.plan import Plan
from pencilbot.planning.tour_ends import morton_order

_NEAREST = 16  # pieces of ink looked at around each point of a speck
#: Improvement rounds per layer. Ten end the search at (or within 0.5 % of) its local optimum on
#: every drawing of bench/optimize.py; two, the default before issue 35, stopped it half-way (a
#: flow field's pen-up 4.30 m where ten give 4.04, vpype's ``linesort --two-opt`` 4.33). Huge
#: layers stay linear: ``ordering.ROUND_WORK`` caps rounds × paths; ``--time-budget`` lifts it.
REORDER_ROUNDS = 10
#: Layers of fewer paths start from the nearest-neighbour tour alone (see ``order_paths``): on
#: a 60-path portrait the matching cost half the time and gave a longer tour.
MATCHING_FROM = 256
#: Layers of more paths start from the matching alone: the nearest-neighbour walk costs seconds
#: at a million paths, and on 750 000 tiny paths its tour was the longer start.
NEAREST_UNTIL = ROUND_WORK


@dataclass(frozen=True)
class Reordering:
    """What :func:`reorder_plan` made: the plan, and how many specks it dropped."""

    plan: Plan
    specks: int


def reorder_plan(
    plan: Plan,
    *,
    start: tuple[float, float] = (0.0, 0.0),
    rounds: int = REORDER_ROUNDS,
    time_budget: float | None = None,
) -> Reordering:
    """Reorder every layer of ``plan`` for short pen-up travel, joining and dropping as above.

    Parameters
    ----------
    plan : Plan
    start : (float, float), optional
        Where the pen stands before the first layer, page mm (the plotter's home there).
    rounds : int, optional
        Improvement work per layer (see :func:`~pencilbot.planning.ordering.order_paths`).
    time_budget : float, optional
        CPU seconds the improvement may take in all, shared among the layers by their number of
        paths: ``rounds`` is then not capped by a layer's size, and the search stops when its
        share is spent (or at its local optimum, or after ``rounds``). The order then depends on
        the machine's speed; without it, only on the drawing.

    Returns
    -------
    Reordering
        The layers in their order, each reordered; pen-up travel (from ``start`` and back)
        never longer than ``plan``'s.
    """
    layers, dropped, position = [], 0, (start[0], start[1])
    began, total = time.process_time(), max(1, sum(len(layer.paths) for layer in plan.layers))
    share = 0
    for layer in plan.layers:
        speck = specks(layer.paths, layer.pen_width)
        kept = layer.paths.take(np.flatnonzero(~speck)) if speck.any() else layer.paths
        share += len(layer.paths)
        deadline = None if time_budget is None else began + time_budget * share / total
        ordered = order_paths(
            kept,
            start=position,
            join_tolerance=layer.pen_width,
            pen_width=layer.pen_width,
            rounds=rounds,
            matching_from=MATCHING_FROM,
            nearest_until=NEAREST_UNTIL,
            deadline=deadline,
        )
        if len(layer.paths) and pen_up_length(ordered, position) > pen_up_length(layer.paths, position):
            ordered, kept = layer.paths, layer.paths  # the file's own order is the shorter
        dropped += len(layer.paths) - len(kept)
        layers.append(replace(layer, paths=ordered))
        if len(ordered):
            position = (ordered.points[-1][0], ordered.points[-1][1])
    result = replace(plan, layers=tuple(layers))
    if pen_up_length(result.paths(), start) > pen_up_length(plan.paths(), start):
        return Reordering(plan, 0)  # the layers' new ends lengthened the moves between them
    return Reordering(result, dropped)


def pen_up_length(paths: Paths, start: tuple[float, float]) -> float:
    """Pen-up travel in mm: from ``start`` to the first path, between paths, and back to ``start``."""
    home = np.asarray(start, np.float64).reshape(1, 2)
    tails = np.concatenate([home, paths.lasts])
    heads = np.concatenate([paths.firsts, home])
    return float(np.hypot(*(heads - tails).T).sum())


def specks(paths: Paths, pen_width: float) -> np.ndarray:
    """Which of ``paths`` are specks: shorter than ``pen_width`` (mm), every point within half a
    pen width of another, longer path. ``(P,)`` bool.

    The other paths are cut into pieces no longer than the pen width, so a piece within half a
    pen width of a point has its midpoint within one pen width; the exact point-to-piece distance
    of the nearest few decides.
    """
    none = np.zeros(len(paths), bool)
    if len(paths) < 2:
        return none
    step = np.diff(paths.points, axis=0)
    owner = paths.owners()
    within = owner[1:] == owner[:-1]
    seg_length = np.where(within, np.hypot(*step.T), 0.0)
    length = np.bincount(owner[1:], weights=seg_length, minlength=len(paths))
    short = length < pen_width
    if not short.any() or short.all():
        return none
    # Pieces of the longer paths' segments, each at most a pen width long.
    long_segment = within & ~short[owner[1:]] & (seg_length > 0)
    starts, vectors, lengths = paths.points[:-1][long_segment], step[long_segment], seg_length[long_segment]
    cuts = np.ceil(lengths / pen_width).astype(np.int64)
    segment = np.repeat(np.arange(len(cuts)), cuts)
    index = ramps(cuts)
    a = starts[segment] + vectors[segment] * (index / cuts[segment])[:, None]
    b = starts[segment] + vectors[segment] * ((index + 1) / cuts[segment])[:, None]
    tree = cKDTree((a + b) / 2, balanced_tree=False, compact_nodes=False)
    candidate_points = short[owner]
    covered_point = _covered(tree, a, b, paths.points[candidate_points], pen_width)
    # A speck is dropped when all its points are covered.
    uncovered = np.bincount(owner[candidate_points], weights=~covered_point, minlength=len(paths))
    return short & (uncovered == 0)


def _covered(tree: cKDTree, a: np.ndarray, b: np.ndarray, query: np.ndarray, pen_width: float) -> np.ndarray:
    """Whether each point of ``query`` lies within half a pen width of one of the pieces a–b
    whose midpoints (in ``tree``) are among its ``_NEAREST`` nearest within a pen width. ``(Q,)``.

    The nearest piece alone covers most points (nine in ten of a million stipples); only the
    others are asked for their ``_NEAREST``, and distances are measured to the pieces found, not
    to a full row of them. The points are asked in Z order, so that each query walks the tree
    where the one before did (three times faster than in file order).
    """
    covered = np.zeros(len(query), bool)
    if not len(query):
        return covered
    query = query[order := morton_order(query)]
    distance, nearest = tree.query(query, k=1, distance_upper_bound=pen_width)
    found = np.flatnonzero(np.isfinite(distance))
    gap = _point_segment_distance(query[found], a[nearest[found]], b[nearest[found]])
    covered[found[gap <= pen_width / 2]] = True
    rest = np.flatnonzero(~covered)
    k = min(_NEAREST, len(a))
    if len(rest) and k > 1:
        distance, nearest = tree.query(query[rest], k=k, distance_upper_bound=pen_width)
        row, column = np.nonzero(np.isfinite(distance.reshape(len(rest), k)))
        piece = nearest.reshape(len(rest), k)[row, column]
        gap = _point_segment_distance(query[rest[row]], a[piece], b[piece])
        covered[rest[row[gap <= pen_width / 2]]] = True
    unsorted = np.empty_like(covered)
    unsorted[order] = covered
    return unsorted


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from points ``p`` to segments ``a``–``b`` (broadcast over leading axes), mm."""
    ab = b - a
    squared = np.einsum("...i,...i->...", ab, ab)
    t = np.clip(np.einsum("...i,...i->...", p - a, ab) / np.where(squared > 0, squared, 1.0), 0.0, 1.0)
    return np.hypot(*np.moveaxis(p - (a + ab * t[..., None]), -1, 0))
