"""A one-pen photo plan's shading: the hatching and the faces' runs, as functions of the tone's
scale and the faces' level, for the budgets that redraw them (:mod:`pencilbot.planning.build`,
:mod:`pencilbot.planning.plot_budget`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pencilbot.imaging.faces import portrait_darkness
from pencilbot.imaging.pencil import Sketch
from pencilbot.paths import Paths
from pencilbot.planning.dither import LEVELS, RunLevel
from pencilbot.planning.layout import Layout, budget_area
from pencilbot.planning.plan import Layer
from pencilbot.planning.plot_budget import PALE
from pencilbot.planning.shading import FACE_FOLLOWS, Hatching


def one_pen_shading(
    drawing: Sketch,
    tone: np.ndarray,
    layout: Layout,
    hatching: Hatching,
    strokes: Paths,
    important,
    dithered,
    faces,
    pen_down_budget: float,
):
    """The one-pen hatching of ``drawing`` to its darkness ``tone``
    (:func:`~pencilbot.planning.sketch_tone.sketch_darkness`, found once for every try of the
    contours), and its faces' runs, within ``pen_down_budget`` (mm per cm² of the sheet), as a
    function of the tone's scale and the faces' level: its non-empty layers and the scale it was
    drawn at (see
    :meth:`~pencilbot.planning.shading.Hatching.shade_within`); and the faces' runs alone at a
    level, as that shading draws them at a scale. With ``pale`` the hatching's palest tones are
    left paper (:data:`~pencilbot.planning.plot_budget.PALE`). The faces' runs are drawn once per
    level and scale: a close portrait's are most of its planning, and the budgets ask for them
    again."""
    budget = pen_down_budget * budget_area(layout, hatching.time_budget) - float(
        strokes.drawn_lengths().sum()
    )
    face_darkness = portrait_darkness(tone, 1.0 - drawing.gray, faces) if faces else None
    paper = 1.0 - drawing.gray
    drawn: dict = {}  # every drawing of the faces' runs, for the next one at the same level and scale

    def runs_for(level: RunLevel, face_scale: float) -> Paths:
        if face_darkness is None:
            return Paths.empty()
        return hatching.faces(
            face_darkness,
            layout,
            strokes,
            paper=paper,
            dithered=dithered,
            level=level,
            face_scale=face_scale,
            drawn=drawn,
        )

    def shade(scale: float, level: RunLevel = LEVELS[0], pale: bool = False) -> tuple[list[Layer], float]:
        hatches, used = (replace(hatching, pale=PALE) if pale else hatching).shade_within(
            budget,
            tone,
            layout,
            strokes,
            paper=paper,
            important=important,
            dithered=dithered,
            face_darkness=face_darkness,
            scale=scale,
            level=level,
            runs_for=runs_for,
        )
        return [layer for layer in hatches if layer.paths], used

    def faces_at(level: RunLevel, scale: float) -> Paths:
        return runs_for(level, scale**FACE_FOLLOWS)

    return shade, faces_at
