"""What a one-pen photo plan may cost in plotting: its lifts, corners and pen-up travel counted, after ordering.

The hatching's pen-down budget (:data:`pencilbot.planning.build.PEN_DOWN_BUDGET`) and the faces'
(:mod:`pencilbot.planning.face_budget`) bound the ink; the plot's time also goes on lifting the
pen, on corners and on travel, which are only known once the paths are ordered (ordering joins
more than half of the hatch strokes into zig-zags). A busy or dark photo within both budgets
still plotted past half an hour and 8 m of pen-up (bench/fidelity.py, grbl-servo-a4: the held-out
group of bald men 28.5 min and 7.98 m; with its contrast raised 35.7 min and 8.29 m).

A plan has no plotter at planning time, so its cost is counted in millimetres of pen-down of the
same plotting time (:func:`plot_cost`): the pen-down length, ``CORNER_MM`` for each turn sharper
than ``CORNER_TURN`` (the motion all but stops there), ``LIFT_MM`` for each path (the lift, the
drop and the stops around them) and ``TRAVEL_WEIGHT`` of the pen-up travel (the travel is faster
than drawing). On 36 photos (the face set, held-out and stress photos) that count times 0.02124 s
per mm (``SECONDS_PER_MM``) is grbl-servo-a4's estimate (:func:`pencilbot.planning.stats.estimate`)
within 0.2 min under and 0.33 min over (rms 0.1 min); :func:`layer_costs` tells it layer by layer.

Past ``PLOT_BUDGET`` or ``TRAVEL_BUDGET`` a plan pays with its faces' runs drawn thriftier, or
with its hatching's palest tones left paper (``PALE``: their dashes, a lift each, are the
dearest ink of the plot), whichever is likelier (:func:`within_plot_budget`). Still past it, the
hatching is shaded again, its tone lighter by one factor predicted from the excess
(:func:`lighter_by`), and ordered again (at most ``REDOS`` times): every tone lighter by one
factor keeps the order of tones, as the pen-down budget does.
The faces' runs and the contours stay: their cost is what the hatching has to make room for. A
plan within both budgets is returned as it is: it pays one sum, not a second ordering.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from pencilbot.paths import Paths
from pencilbot.planning.dither import LEVELS, SPARSEST, RunLevel
from pencilbot.planning.plan import Layer
from pencilbot.planning.shading import FACE_TONE

#: A turn of a drawn path sharper than this many degrees (the motion nearly stops), and what it
#: costs in mm of pen-down: fitted with LIFT_MM and TRAVEL_WEIGHT to grbl-servo-a4's estimate
#: (0.5 mm pen, 3000 / 6000 mm/min, 800 mm/s², a servo's 0.15 + 0.2 s, 25 ms idle lock).
CORNER_TURN = 60.0
CORNER_MM = 2.2
#: A path's lift, drop and the stops around them, mm of pen-down (0.51 s at 0.02124 s per mm).
LIFT_MM = 24.0
#: A mm of pen-up travel in mm of pen-down (the travel runs at twice the drawing feed).
TRAVEL_WEIGHT = 0.55
#: Plotting seconds per mm of cost on grbl-servo-a4 (the fit over 36 photos, see the module).
SECONDS_PER_MM = 0.02124
#: What a plan may cost, mm per cm² of the sheet (80.5 m on A4: 28.5 min on grbl-servo-a4).
PLOT_BUDGET = 129.0
#: Pen-up travel a plan may take, mm per cm² of the sheet (7.36 m on A4; grbl-servo-a4's estimate
#: is up to 0.15 m more, its home being a landscape sheet's top-left corner, not the plan's origin).
TRAVEL_BUDGET = 11.8
#: A plan past a budget is aimed this far inside it at the first redo, the second and the third.
AIMS = (0.97, 0.95, 0.93)
#: The hatching's cost and its travel are taken to fall as (tone factor)^(1 / DAMPING) at the
#: first redo: lighter tones drop dashes faster than their tone falls. Measured on three photos
#: past the budget, scaled by 0.9, 0.8 and 0.7: the cost's exponent 1.05-2.7, the travel's
#: 0.55-1.65. 0.5 (as if 2) errs toward too small a cut (too deep a one costs the photo its
#: tone) and the second redo, with the exponent measured, catches the rest: on seven photos past
#: the budget (bench/fidelity.py) 0.67 landed them 0.5-2.5 min under it, 0.5 within 1.2 min.
DAMPING = 0.5
#: After a redo the damping is measured (:func:`within_plot_budget`), within these: a hatching
#: whose travel hardly falls (dashes spread out as they thin) is not scaled to nothing for it.
DAMPINGS = (0.33, 2.0)
#: The lightest factor of one redo.
LIGHTEST = 0.4
#: Most redos of the hatching (each one a shading and an ordering). The last only polishes: it is
#: drawn when its factor is at least POLISH (two redos left the plan just past its budget: with
#: spread hatch lines, :mod:`pencilbot.planning.spread`, a busy synthetic sheet held to three
#: quarters of its cost came to 0.5 % over it). Far past it, the faces' runs are what costs (a
#: tiling of 96 faces, its pen-up travel 8 % over after two redos: a third scaled its tone by 0.17,
#: whole box 0.862 -> 0.523); the face set's photos never take it.
REDOS = 3
POLISH = 0.85
#: Tone (the hatching's request at its blur, the pen-down budget's scale in it) under which a plan
#: past its plot budget may leave the paper blank instead of drawing its faces thriftier: dashes
#: millimetres apart, in no order at a millimetre's blur, each a lift. Measured (bench/fidelity.py;
#: faces from 25 mm / 12-25 mm meeting their bars, whole box min, plan vs sketch r min): the face
#: set 18 / 32, 0.945, 0.924 -> 18 / 34, 0.945, 0.924; face-api's demo photos and two ultralytics
#: photos, never tuned to: 16 / 3, 0.904 -> 17 / 4, 0.918 (sample5's two lit faces 0.914 / 0.877
#: -> 0.969 / 0.914 and 0.866 / 0.807 -> 0.936 / 0.898: the lifts saved keep their finer runs,
#: and skin that was bare paper has tone). Taken whenever within the budget, unjudged: the same
#: faces, but 2008_001322 0.939 and r 0.917 (its faces want the thriftiest runs). Left blank on
#: every plan, from 0.05: 18 / 33, 0.944; from 0.1: 17 / 35 but camera 0.965 -> 0.955.
PALE = 0.08
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlotCost:
    """What a plan's paths cost in plotting, mm of pen-down (see the module): ``total`` all of
    it, ``travel`` the pen-up travel alone (mm, unweighted); ``hatch_total`` and ``hatch_travel``
    their share in the hatch layers (the faces' runs not counted as hatching)."""

    total: float
    travel: float
    hatch_total: float
    hatch_travel: float


def corners(paths: Paths) -> int:
    """How many turns of ``paths``' drawn segments are sharper than ``CORNER_TURN`` degrees."""
    if len(paths.points) < 3:
        return 0
    owner = paths.owners()
    step = np.diff(paths.points, axis=0)
    step = step[owner[1:] == owner[:-1]]  # each path's own segments, paths one after another
    owner = owner[1:][owner[1:] == owner[:-1]]
    length = np.hypot(*step.T)
    keep = length > 0
    step, owner, length = step[keep], owner[keep], length[keep]
    inside = owner[1:] == owner[:-1]
    cosine = (step[1:] * step[:-1]).sum(axis=1) / (length[1:] * length[:-1])
    return int(np.count_nonzero(inside & (cosine < np.cos(np.radians(CORNER_TURN)))))


@dataclass(frozen=True)
class LayerCost:
    """One ordered layer's part of :func:`plot_cost`, mm of pen-down: its ``drawn`` length, the
    price of its ``corners`` and its ``lifts`` (one a path) and its ``travel`` into each of its
    paths, weighted (``moved`` unweighted): where a plan's plotting time goes (bench/plot_cost.py)."""

    name: str
    role: str
    paths: int
    drawn: float
    corners: float
    lifts: float
    moved: float

    @property
    def travel(self) -> float:
        return TRAVEL_WEIGHT * self.moved

    @property
    def total(self) -> float:
        return self.drawn + self.corners + self.lifts + self.travel


def layer_costs(layers: Sequence[Layer], start: tuple[float, float] = (0.0, 0.0)) -> list[LayerCost]:
    """Each of ordered ``layers``' part of :func:`plot_cost`, drawn one after another from ``start``
    (the travel into a path counted with its layer; empty layers left out)."""
    costs, position = [], np.asarray(start, np.float64)
    for layer in layers:
        paths = layer.paths
        if not len(paths):
            continue
        tails = np.vstack([position, paths.lasts[:-1]])
        moved = float(np.hypot(*(paths.firsts - tails).T).sum())
        costs.append(LayerCost(layer.name, layer.role, len(paths), *_drawing_parts(paths), moved))
        position = paths.lasts[-1]
    return costs


def plot_cost(layers: Sequence[Layer], start: tuple[float, float] = (0.0, 0.0)) -> PlotCost:
    """The plotting cost of ordered ``layers`` drawn one after another from ``start`` and back
    (the plotter's home), the travel into a path counted with its layer."""
    costs = layer_costs(layers, start)
    hatch = [cost for cost in costs if cost.role == "hatch" and cost.name != FACE_TONE]
    last = next((layer.paths.lasts[-1] for layer in reversed(layers) if len(layer.paths)), start)
    home = float(np.hypot(*(np.asarray(last, np.float64) - np.asarray(start, np.float64))))
    return PlotCost(
        sum(cost.total for cost in costs) + TRAVEL_WEIGHT * home,
        sum(cost.moved for cost in costs) + home,
        sum(cost.total for cost in hatch),
        sum(cost.moved for cost in hatch),
    )


def lighter_by(
    cost: PlotCost, sheet_cm2: float, damping: tuple[float, float] = (DAMPING, DAMPING), aim: float = AIMS[0]
) -> float:
    """The factor the hatching's tone is drawn lighter by for ``cost`` to come within both
    budgets over a sheet of ``sheet_cm2`` (1: it is within them), aimed ``aim`` inside them; the
    hatching's cost and travel taken to fall as the factor^(1 / ``damping``), each."""
    factor = 1.0
    for spent, hatched, budget, power in (
        (cost.total, cost.hatch_total, PLOT_BUDGET * sheet_cm2, damping[0]),
        (cost.travel, cost.hatch_travel, TRAVEL_BUDGET * sheet_cm2, damping[1]),
    ):
        if spent > budget and hatched > 0:
            room = max(aim * budget - (spent - hatched), 0.0)  # what the rest leaves the hatching
            factor = min(factor, max((room / hatched) ** power, LIGHTEST))
    return factor


def within_plot_budget(
    layers: list[Layer],
    redraw: Callable[[float, RunLevel], list[Layer]],
    sheet_cm2: float,
    faces_at: Callable[[RunLevel], Paths] | None = None,
    paler: Callable[[], list[Layer]] | None = None,
    judge: Callable[[list[Layer]], float] | None = None,
) -> list[Layer]:
    """``layers`` (ordered), or, while they cost more than a budget over a sheet of ``sheet_cm2``,
    ``redraw(scale, level)``: the plan again, ordered. First its faces' runs at the first of the
    thriftier ``LEVELS`` (fewer, longer runs, more of the lightest skin bare: the faces' finer
    runs are what a plan within the budget can afford) that ``faces_at(level)``, the runs alone,
    foretell within the budget (the last if none: one plan more, not one a level); then, at most
    ``REDOS`` times, its hatching's tone scaled by a further :func:`lighter_by` each time; after
    the first such redo with the damping that redo measured (how fast this picture's hatching
    fell with its tone), aimed further inside (``AIMS``: the fall is not smooth, a few dashes more
    or less). A plan still past the budget then has its faces' runs at ``SPARSEST`` and its
    hatching lightened again from its own tone, kept if that comes nearer the budget.

    With ``paler``, the plan again with its hatching's tones under ``PALE`` left paper (its faces'
    runs at their finest, ordered; every ``redraw`` after it is pale) is drawn too once the faces'
    level is chosen, and its own faces' level chosen from its cost: taken if it is within the
    budget and the thriftier runs are not, or if ``judge`` (how like its photo and its sketch a
    plan is) finds it the likelier of the two; neither within, the pale one is lightened."""
    cost = plot_cost(layers)
    if lighter_by(cost, sheet_cm2) >= 1.0:
        return layers
    foretell = faces_at if any(layer.name == FACE_TONE for layer in layers) else None
    layers, cost, level = _thriftier(layers, cost, redraw, sheet_cm2, foretell)
    if paler is not None:
        log.debug("past the budget: drawn again with the palest hatching left paper")
        pale = paler()
        pale, pale_cost, pale_level = _thriftier(pale, plot_cost(pale), redraw, sheet_cm2, foretell)
        thrifty_within = lighter_by(cost, sheet_cm2) >= 1.0
        if lighter_by(pale_cost, sheet_cm2) >= 1.0 and (
            not thrifty_within or judge is None or judge(pale) > judge(layers)
        ):
            return pale
        if not thrifty_within:  # neither: on from the pale plan (every redraw is pale now)
            layers, cost, level = pale, pale_cost, pale_level
    if lighter_by(cost, sheet_cm2) >= 1.0:
        return layers
    layers, cost = _lighter(layers, cost, level, redraw, sheet_cm2)
    if foretell is not None and lighter_by(cost, sheet_cm2) < 1.0:
        # Still past the budget with its hatching lighter: many faces, whose runs are most of the
        # plot. The sparsest runs, the hatching from its own tone again.
        log.debug(
            "plot cost %.1f m (pen-up %.2f m) still over the budget: the sparsest runs",
            cost.total / 1e3,
            cost.travel / 1e3,
        )
        sparse = redraw(1.0, SPARSEST)
        sparse, within = _lighter(sparse, plot_cost(sparse), SPARSEST, redraw, sheet_cm2)
        if lighter_by(within, sheet_cm2) > lighter_by(cost, sheet_cm2):  # nearer the budget
            return sparse
    return layers


def _thriftier(
    layers: list[Layer],
    cost: PlotCost,
    redraw: Callable[[float, RunLevel], list[Layer]],
    sheet_cm2: float,
    faces_at: Callable[[RunLevel], Paths] | None,
) -> tuple[list[Layer], PlotCost, RunLevel]:
    """``layers`` (costing ``cost``, past a budget) with their faces' runs at the first of the
    thriftier ``LEVELS`` that ``faces_at`` foretells within the budget (the last if none), what
    that costs and the level; as they are without faces or within the budget."""
    runs = [layer.paths for layer in layers if layer.name == FACE_TONE]
    if faces_at is None or not runs or lighter_by(cost, sheet_cm2) >= 1.0:
        return layers, cost, LEVELS[0]
    level = _thrifty_level(cost, _drawing_cost(runs[0]), faces_at, sheet_cm2)
    layers = redraw(1.0, level)
    return layers, plot_cost(layers), level


def _lighter(
    layers: list[Layer],
    cost: PlotCost,
    level: RunLevel,
    redraw: Callable[[float, RunLevel], list[Layer]],
    sheet_cm2: float,
) -> tuple[list[Layer], PlotCost]:
    """``layers`` (costing ``cost``) with the faces' runs at ``level``, their hatching redrawn
    lighter (at most ``REDOS`` times) while past the budget, and what they cost."""
    first = cost
    scale, damping = 1.0, (DAMPING, DAMPING)
    for redo in range(REDOS):
        factor = lighter_by(cost, sheet_cm2, damping, AIMS[redo])
        if factor >= 1.0 or (redo == REDOS - 1 and factor < POLISH):
            break
        scale *= factor
        log.debug(
            "plot cost %.1f m (pen-up %.2f m) over the budget: hatching's tone scaled by %.2f",
            cost.total / 1e3,
            cost.travel / 1e3,
            scale,
        )
        layers = redraw(scale, level)
        cost = plot_cost(layers)
        damping = (
            _measured(first.hatch_total, cost.hatch_total, scale),
            _measured(first.hatch_travel, cost.hatch_travel, scale),
        )
    return layers, cost


def _drawing_parts(paths: Paths) -> tuple[float, float, float]:
    """:func:`plot_cost` of ``paths`` without their travel (which their order sets): their drawn
    length, their corners' price and their lifts'."""
    return float(paths.drawn_lengths().sum()), CORNER_MM * corners(paths), LIFT_MM * len(paths)


def _drawing_cost(paths: Paths) -> float:
    """:func:`plot_cost` of ``paths`` without their travel."""
    return sum(_drawing_parts(paths))


def _thrifty_level(
    cost: PlotCost, runs_cost: float, faces_at: Callable[[RunLevel], Paths], sheet_cm2: float
) -> RunLevel:
    """The first of the thriftier ``LEVELS`` whose faces' runs bring ``cost`` within the budgets,
    the rest of the plan as it is (its travel too: fewer runs travel less), or the last."""
    for level in LEVELS[1:-1]:
        foretold = replace(cost, total=cost.total - runs_cost + _drawing_cost(faces_at(level)))
        if lighter_by(foretold, sheet_cm2) >= 1.0:
            return level
    return LEVELS[-1]


def _measured(before: float, after: float, scale: float) -> float:
    """The damping with which ``before`` fell to ``after`` at the tone's ``scale`` (within
    ``DAMPINGS``; the largest when nothing fell or there was nothing)."""
    if before <= 0 or after <= 0 or after >= before or scale >= 1.0:
        return DAMPINGS[1]
    return float(np.clip(np.log(scale) / np.log(after / before), *DAMPINGS))
