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
from pencilbot.planning.face_place import place_gains
from pencilbot.planning.layout import Layout, budget_area
from pencilbot.planning.plan import Layer
from pencilbot.planning.plot_budget import PALE
from pencilbot.planning.shading import FACE_FOLLOWS, FACE_TONE, Hatching


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
    again. The faces are drawn at their place in the sheet's order of tones
    (:mod:`pencilbot.planning.face_place`), found from the first shading and kept for the rest."""
    budget = pen_down_budget * budget_area(layout, hatching.time_budget) - float(
        strokes.drawn_lengths().sum()
    )
    face_darkness = portrait_darkness(tone, 1.0 - drawing.gray, faces) if faces else None
    paper = 1.0 - drawing.gray
    drawn: dict = {}  # every drawing of the faces' runs, for the next one at the same level and scale
    placed: np.ndarray | None = None  # the faces' darkness at their place, once found

    def runs_for(level: RunLevel, face_scale: float) -> Paths:
        if face_darkness is None:
            return Paths.empty()
        return hatching.faces(
            face_darkness if placed is None else placed,
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
        if face_darkness is not None and dithered is not None and placed is None:
            hatches = at_place(hatches, used, level)
        return [layer for layer in hatches if layer.paths], used

    def at_place(hatches: list[Layer], used: float, level: RunLevel) -> list[Layer]:
        """``hatches`` with the faces' runs redrawn at their place, which is kept for every later drawing."""
        nonlocal placed
        assert face_darkness is not None and dithered is not None
        sheet = Paths.concat([strokes, *(layer.paths for layer in hatches)])
        pen = hatching.pen_width
        gains = place_gains(sheet, paper, dithered, face_darkness, layout, pen_width=pen, cut=level.lightest)
        placed = face_darkness if gains is None else np.clip(face_darkness * gains, 0.0, 1.0)
        if gains is None:
            return hatches
        drawn.clear()
        runs = Layer(FACE_TONE, runs_for(level, used**FACE_FOLLOWS), pen_width=pen, role="hatch")
        return [*(layer for layer in hatches if layer.name != FACE_TONE), runs]  # the runs last, as shaded

    def faces_at(level: RunLevel, scale: float) -> Paths:
        return runs_for(level, scale**FACE_FOLLOWS)

    return shade, faces_at
