"""A style resolved once into what each stage of a photo plan takes (:mod:`pencilbot.planning.build`):
the contours' options, the hatching, the ordering, the faces."""

from __future__ import annotations

from dataclasses import dataclass

from pencilbot.planning.shading import Hatching
from pencilbot.planning.style import Style
from pencilbot.planning.vectorize import EdgeOptions, edge_threshold

#: Darkness of the raster line drawing from which a face's features are drawn with the pen
#: (elsewhere :data:`~pencilbot.planning.vectorize.PEN_DARKNESS`): an eyelid, a brow, the
#: corner of a mouth are faint edges that carry a likeness.
FACE_PEN_DARKNESS = 0.35


@dataclass(frozen=True)
class Ordering:
    """How each layer's paths are ordered (:func:`pencilbot.planning.build._ordered`): joins within ``pen_width`` for
    contours and faces' runs, within ``hatch_join`` for hatch runs from ``1.5 * min_hatch_run``
    long (mm), ``rounds`` of improvement."""

    pen_width: float
    hatch_join: float
    min_hatch_run: float
    rounds: int


@dataclass(frozen=True)
class Stages:
    """A style resolved, once, into what each stage of a plan takes: the contours' options,
    the hatching (None: the style draws contours only), the ordering, whether faces are sought
    and whether their dark lines are drawn with the pen."""

    edges: EdgeOptions
    hatching: Hatching | None
    order: Ordering
    faces: bool
    face_lines: bool


def stages_of(style: Style, line) -> Stages:
    """What ``style`` asks of each stage, for the line drawing ``line`` (its edge threshold)."""
    threshold = edge_threshold(line) if style.edge_threshold is None else style.edge_threshold
    edges = EdgeOptions(
        pen_width=style.pen_width,
        threshold=threshold,
        min_pixels=style.min_edge_pixels,
        join=style.edge_join,
        clutter=style.edge_clutter,
        max_lines=style.edge_lines,
        budget=style.edge_budget / 100 if style.edge_budget > 0 else None,
        fine_threshold=min(threshold, edge_threshold(line, FACE_PEN_DARKNESS)),
    )
    hatching = Hatching(
        pen_width=style.pen_width,
        angles=style.hatch_angles,
        coverage=style.hatch_coverage,
        form_scale=style.hatch_form,
        min_run=style.min_hatch_run,
        blank_below=style.hatch_blank_below,
        wobble=style.hatch_jitter,
        blur=style.hatch_blur,
        seed=style.seed,
        time_budget=style.time_budget,
    )
    order = Ordering(style.pen_width, style.hatch_join, style.min_hatch_run, style.order_rounds)
    return Stages(edges, hatching if style.hatch else None, order, style.faces, style.face_lines)
