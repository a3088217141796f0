"""What a portrait's faces may cost in plotting, so that a close portrait stays within half an hour.

The sheet's pen-down budget (:data:`pencilbot.planning.build.PEN_DOWN_BUDGET`) lightens the
hatching, never the faces' runs: they are what a portrait is plotted for. In a close portrait the
runs are most of the plot (Tom_Cruise_avp_2014_4, a face over three quarters of the drawing:
994 strokes, 20.7 m of the 32 m pen-down, 29.6 min), and spreading their rows
(:func:`pencilbot.planning.dither.face_pitch`) saves lifts only: the ink, and with it the
pen-down, stays. A face closer or darker than that one went past 30 minutes whatever the rows.

Here the runs are costed as a plotter spends its time: their pen-down plus ``LIFT_MM`` for each
stroke (a lift, a move and a drop take as long as that much drawing). Within ``FACE_BUDGET`` they
are drawn as they are; past it they are drawn with fewer, longer runs first
(:data:`pencilbot.planning.dither.LEVELS`), and then the faces' tone lighter by
(budget / cost)^¾ (again, if still past it), as the
hatching is past its budget: one factor over every face, so their order of tones stays, and the
factor is 1 at the budget, so the rule has no step.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from pencilbot.paths import Paths
from pencilbot.planning.dither import LEVELS, RunLevel

#: A stroke's lift, move and drop in mm of pen-down of the same plotting time: on the face set
#: (bench/fidelity.py --faceset, grbl-servo-a4) plot time grew by 0.43 min per m of pen-down and
#: 0.54 s per stroke: 0.54 s / 25.8 s per m.
LIFT_MM = 21.0
#: What the faces' runs may cost, mm per cm² of the sheet (45 m on A4): the plot of a sheet at
#: its pen-down budget (39 m on A4) with some 1300 strokes is half an hour; the closest portrait of
#: the face set costs 41.5 m on A4, so its runs stay as they are.
FACE_BUDGET = 72.0
#: The faces' tone falls as (budget / cost)^DAMPING: their ink falls faster than their tone (more
#: of the skin falls under the runs' cut), as the hatching's does.
DAMPING = 0.75
#: Most redraws: a face of one even dark tone (no skin under the cut) loses ink only as fast as
#: its tone, and needs a second.
ROUNDS = 3


def run_cost(runs: Paths) -> float:
    """Plotting cost of ``runs`` in mm of pen-down: their length and ``LIFT_MM`` per stroke."""
    return float(runs.drawn_lengths().sum()) + LIFT_MM * len(runs)


def within_budget(
    draw: Callable[[float, RunLevel], Paths], sheet_cm2: float, levels: Sequence[RunLevel] = LEVELS[:1]
) -> Paths:
    """The faces' runs ``draw(1, levels[0])``; while they cost more than ``FACE_BUDGET`` over a
    sheet of ``sheet_cm2``, drawn at each thriftier level of ``levels`` in turn (fewer, longer runs,
    more of the lightest skin bare), then (at most ``ROUNDS`` times) at the last, their tone scaled
    by a further (budget / cost)^DAMPING each time."""
    allowed, scale = FACE_BUDGET * sheet_cm2, 1.0
    for level in levels:
        runs = draw(scale, level)
        if run_cost(runs) <= allowed:
            return runs
    for _ in range(ROUNDS):
        cost = run_cost(runs)
        if cost <= allowed:
            break
        scale *= (allowed / cost) ** DAMPING
        runs = draw(scale, levels[-1])
    return runs


def thriftier(level: RunLevel) -> tuple[RunLevel, ...]:
    """``level`` and the levels of ``LEVELS`` after it (all of them, for one not among them)."""
    return LEVELS[LEVELS.index(level) :] if level in LEVELS else (level, *LEVELS)
