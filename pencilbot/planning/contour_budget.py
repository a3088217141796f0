"""The contours' budget (a style's ``edge_budget``): which chains of contour strokes stay when a
picture has more contour than the budget allows (:func:`pencilbot.planning.vectorize.edge_strokes`)."""

from __future__ import annotations

import numpy as np

from pencilbot.planning.chaining import chain_ids

#: The further a picture's contours overflow the budget, the more of them are texture: the length
#: kept is the budget over (overflow ** OVERFLOW_POWER). A painting's brush strokes (4.2x the
#: budget) keep a ninth of it, a street scene (2.2x) a third, a portrait (1.2-1.3x) four fifths;
#: bench/fidelity.py whole-box rho, with the tone loop's finer correction: starry_night 0.913 -> 0.941.
OVERFLOW_POWER = 1.5
#: The same where the sheet affords its contours (a one-pen plan still within its pen-down and
#: plot budgets with them, :mod:`pencilbot.planning.build`): the budget itself. A street scene
#: overflows as much as a painting (bus.jpg 3.9x, starry_night 4.2x) and kept 5 contour paths,
#: its bus and people without an outline (docs/faces.md, eighth round).
ROOMY_OVERFLOW_POWER = 0.0


def budget_length(budget: float | None, shape: tuple[int, ...], mm_per_px: float) -> float:
    """The contour length (mm) a ``budget`` (mm per mm², None: none) allows over a picture of
    ``shape`` pixels laid out at ``mm_per_px``."""
    return 0.0 if budget is None else budget * shape[0] * shape[1] * mm_per_px**2


def within_budget(strokes, links, texture, keep, allowed, protected, power=OVERFLOW_POWER) -> np.ndarray:
    """Which components stay when the kept chains may be ``allowed`` px long in all (less, the
    more they overflow it: ``power``, :data:`OVERFLOW_POWER`).

    Chains are dropped by (1 + clutter) / length, most first (short and cluttered) until the rest fit;
    ``protected`` components (a face) are never dropped and count against the budget first.
    """
    chain = chain_ids(strokes.n, links)
    length = np.bincount(chain, weights=strokes.extent * keep)
    if length.sum() <= allowed:
        return np.ones(strokes.n, bool)
    allowed = allowed / (length.sum() / allowed) ** power
    weight = np.maximum(strokes.extent, 1e-9)
    clutter = np.bincount(chain, weights=texture * weight) / np.bincount(chain, weights=weight)
    safe = np.zeros(len(length), bool)
    if protected is not None:
        safe = np.bincount(chain, weights=protected.astype(np.float64)) > 0
    # Long and coherent first: the chains kept are a prefix of the order of (1 + clutter) / length.
    rank = (1.0 + clutter) / np.maximum(length, 1e-9)
    rank[safe] = -np.inf
    order = np.argsort(rank, kind="stable")
    within = np.cumsum(length[order]) <= allowed
    stay = np.zeros(len(length), bool)
    stay[order[within]] = True
    stay |= safe
    return stay[chain]
