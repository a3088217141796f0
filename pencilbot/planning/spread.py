"""Hatch lines spread evenly across the gaps their dither leaves.

A family's lines are level lines φ = k·s, and which of them a tone switches on is an ordered
dither (:mod:`pencilbot.planning.hatching`): line k is drawn where the share of lines the tone
asks for exceeds its golden rank frac(k·γ). The lines on at one share are nested in those on at a
larger one, so a tone that changes along a line switches few lines on or off; but nested sets
cannot be evenly spaced at every share. Their gaps take three lengths (within a factor γ of each
other) in runs of one or two, and at a blur of a millimetre those runs show as stripes: on flat
tones of 0.15-0.9 the golden lines vary by 0.05-0.07 in darkness, where lines at even gaps (not
nested) vary by 0.01-0.03.

So each drawn sample moves across its line towards the middle of its drawn neighbours: its
nearest ``REACH`` drawn levels on either side, at its own share, relaxed ``ROUNDS`` times by
``STEP`` of the way (the outermost held), in units of the local spacing between levels, then
averaged along the line over ``SMOOTH`` mm so that a line bends, not kinks, where a neighbour
starts or stops. Lines keep their order and their switching, and the family its ink: only where
its lines lie changes. A flat grey of 0.3 / 0.5 hatched on a 60 mm square (the tone loop's own
two rounds) varies by 0.036 / 0.036 at a 1 mm blur unspread, 0.019 / 0.012 spread
(tests/planning/test_spread.py). bench/fidelity.py --faceset: plot vs own sketch r up on all
21 photos, whole-box rho up on 19 and level on 2, the lowest 0.909 -> 0.914 and 0.941 -> 0.946;
the unseen and stress photos alike (bus 0.952 -> 0.961 and 0.889 -> 0.897, a dark crowd 0.932 ->
0.952); 1 MP planning 1.39-1.46 -> 1.56-1.73 CPU s (docs/faces.md, sixth round).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from pencilbot.planning.hatching import HatchLines

#: Golden-ratio conjugate: the hatching's ranks frac(k·GOLDEN) are as evenly spread as any
#: nested sequence can be (the three-gap theorem).
GOLDEN = 0.6180339887498949
#: Drawn neighbour levels looked at on either side, the relaxation's rounds and the share of the
#: way to the middle of its neighbours a line moves in one.
REACH = 3
ROUNDS = 3
STEP = 0.5
#: Furthest level (in lines) looked at for a drawn neighbour.
LOOK = 24
#: Length (mm) over which a line's moves are averaged along it.
SMOOTH = 2.0


def spread_lines(
    lines: HatchLines, on: np.ndarray, line_share: np.ndarray, offset: float, pen_width: float, step: float
) -> HatchLines:
    """``lines`` (sampled every ``step`` mm) with each drawn sample (``on``) moved across its line by
    :func:`spread_offsets` of its ``line_share``, times the spacing of levels there (the pen
    width over the family's full coverage), averaged along the line over ``SMOOTH`` mm. A sample
    that would leave the box the lines were traced in stays where it was."""
    if not on.any():
        return lines
    move = np.zeros(len(on))
    pitch = pen_width / np.maximum(lines.full[on], 1e-6)
    move[on] = spread_offsets(lines.level[on], line_share[on], offset) * pitch
    # The moves' mean along the line over the drawn samples only: both sums in one pass.
    summed = line_mean(
        np.stack([move, on.astype(np.float64)], axis=1), lines.line, int(round(SMOOTH / (2 * step)))
    )
    move = summed[:, 0] / np.maximum(summed[:, 1], 1e-9)
    moved = lines.points + lines.normal * move[:, None]
    low, high = lines.points.min(axis=0), lines.points.max(axis=0)
    out = np.any((moved < low) | (moved > high), axis=1)
    moved[out] = lines.points[out]
    return replace(lines, points=moved)


def line_mean(values: np.ndarray, line: np.ndarray, half: int) -> np.ndarray:
    """Moving average of per-sample ``values`` (N, or N × k: each column) over ``half`` samples
    either side, within each ``line`` (the samples of one line consecutive)."""
    if half <= 0 or values.size == 0:
        return values
    index = np.arange(len(values))
    first = np.flatnonzero(np.append(True, line[1:] != line[:-1]))
    last = np.append(first[1:], len(values)) - 1
    owner = np.cumsum(np.append(True, line[1:] != line[:-1])) - 1
    lo = np.maximum(index - half, first[owner])
    hi = np.minimum(index + half, last[owner])
    total = np.concatenate([np.zeros((1, *values.shape[1:])), np.cumsum(values, axis=0)])
    return (total[hi + 1] - total[lo]) / (hi - lo + 1).reshape(-1, *[1] * (values.ndim - 1))


def spread_offsets(level: np.ndarray, line_share: np.ndarray, offset: float) -> np.ndarray:
    """(N,) how far (in levels, towards higher ones) each sample's line moves to sit evenly among
    the drawn lines around it: those of the ``REACH`` nearest levels on either side whose golden
    rank (shifted by ``offset``) is below the sample's ``line_share``. 0 for a sample without a
    drawn neighbour on one side within ``LOOK`` levels."""
    level = np.asarray(level, np.int64)
    share = np.asarray(line_share, np.float64)
    if level.size == 0:
        return np.zeros(0)
    base = np.mod(level * GOLDEN + offset, 1.0)  # the sample's own rank: its neighbours' follow
    above, below = _nearest(base, share, 1.0), _nearest(base, share, -1.0)
    found = np.isfinite(above[:, 0]) & np.isfinite(below[:, 0])
    above[~found] = below[~found] = np.arange(1, REACH + 1)  # (not moved: any finite chain)
    # Missing outer neighbours (a sparse share): the last one found, one gap further.
    above, below = _filled(above), _filled(below)
    chain = np.concatenate([-below[:, ::-1], np.zeros((len(level), 1)), above], axis=1)
    for _ in range(ROUNDS):
        middle = (chain[:, :-2] + chain[:, 2:]) / 2.0
        chain[:, 1:-1] += STEP * (middle - chain[:, 1:-1])
    return np.where(found, chain[:, REACH], 0.0)


def _nearest(base: np.ndarray, share: np.ndarray, direction: float) -> np.ndarray:
    """(N, REACH) distances (levels) from each sample's level, of rank ``base``, to the first
    ``REACH`` levels in ``direction`` (±1) drawn at its ``share``; inf where fewer are within LOOK."""
    out = np.full((len(base), REACH), np.inf)
    count = np.zeros(len(base), np.int64)
    active = np.arange(len(base))
    for step in range(1, LOOK + 1):
        hit = active[np.mod(base[active] + direction * step * GOLDEN, 1.0) < share[active]]
        out[hit, count[hit]] = step
        count[hit] += 1
        active = active[count[active] < REACH]
        if not active.size:
            break
    return out


def _filled(distances: np.ndarray) -> np.ndarray:
    """``distances`` with each missing one the one before it plus that one's last gap."""
    out = distances.copy()
    for j in range(1, out.shape[1]):
        gap = out[:, j - 1] - (out[:, j - 2] if j >= 2 else 0.0)
        missing = ~np.isfinite(out[:, j])
        out[missing, j] = out[missing, j - 1] + gap[missing]
    return out
