"""G2/G3 arcs as GRBL 1.1's ``mc_arc`` cuts them: chords whose ends lie on the circle.

The number of chords follows the arc tolerance ``$12`` (the largest distance, in mm, between
a chord and the circle): a chord of the circle of radius r that deviates by at most tol
subtends ``2·acos(1 − tol/r)``, which GRBL approximates from the half chord
``√(tol·(2r − tol))``, so an arc of angle θ gets ``floor(|θ|·r/2 / √(tol·(2r − tol)))`` chords
(at least one: the last always ends exactly on the target). The helical (linear) axis moves in
equal steps per chord. The count is GRBL's ``uint16``: it wraps past 65 535.
"""

from __future__ import annotations

import math

import numpy as np

#: Below this (radians) an arc's start and end count as the same angle: a full circle.
ANGULAR_EPSILON = 5e-7


def arc_chords(
    start, target, offset, radius: float, axes: tuple[int, int, int], clockwise: bool, tolerance: float
) -> tuple[np.ndarray, int]:
    """End points of the chords of one arc, in order (the last is ``target``), and GRBL's count.

    Parameters
    ----------
    start, target : sequence of 3 float
        Machine position before the arc and its end point, mm.
    offset : sequence of 3 float
        Centre minus start, mm (GRBL's I, J, K in machine axes).
    radius : float
        Distance from the centre to the start, mm.
    axes : (int, int, int)
        Indices of the plane's two axes and of the linear (helix) axis, e.g. ``(0, 1, 2)``
        for G17.
    clockwise : bool
        G2 (True) or G3 (False), seen looking down the linear axis towards negative.
    tolerance : float
        ``$12`` arc tolerance, mm (> 0).

    Returns
    -------
    points : ndarray, shape (N, 3)
        N = max(count, 1) chord end points, mm.
    count : int
        GRBL's segment count (0 when the arc is shorter than one chord: one straight move).
    """
    a0, a1, lin = axes
    center0, center1 = start[a0] + offset[a0], start[a1] + offset[a1]
    r0, r1 = -offset[a0], -offset[a1]  # centre → start
    t0, t1 = target[a0] - center0, target[a1] - center1  # centre → target
    angle = math.atan2(r0 * t1 - r1 * t0, r0 * t0 + r1 * t1)
    if clockwise and angle >= -ANGULAR_EPSILON:
        angle -= 2 * math.pi
    elif not clockwise and angle <= ANGULAR_EPSILON:
        angle += 2 * math.pi
    spread = tolerance * (2 * radius - tolerance)
    count = math.floor(abs(0.5 * angle * radius) / math.sqrt(spread)) if spread > 0 else 0
    count &= 0xFFFF
    points = np.empty((max(count, 1), 3))
    if count > 1:
        phi = angle / count * np.arange(1, count)
        cos, sin = np.cos(phi), np.sin(phi)
        points[:-1, a0] = center0 + r0 * cos - r1 * sin
        points[:-1, a1] = center1 + r0 * sin + r1 * cos
        points[:-1, lin] = start[lin] + (target[lin] - start[lin]) / count * np.arange(1, count)
    points[-1] = target
    return points, count
