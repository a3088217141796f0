"""From a photo to a plan: the one entry point that ties imaging and planning together.

The pencil sketch gives the line drawing (labels, E, ℓ) and the texture tone T = H^β. The plan
draws the tone first, as hatch layers from light to dark, and the GMED edges last, on top, the
order an artist shades and then outlines (and the order in which a wet pen smears least over
its own contours). Each layer is ordered for short pen-up travel, starting where the previous
layer ended; the first starts at the plotter's home, the page origin.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.imaging.faces import face_mask, find_faces
from pencilbot.imaging.io import LoadedImage
from pencilbot.imaging.pencil import Sketch, sketch
from pencilbot.machine.pens import PenSet, load_pens
from pencilbot.paths import Paths
from pencilbot.planning.contour_budget import ROOMY_OVERFLOW_POWER, budget_length
from pencilbot.planning.dither import LEVELS, RunLevel
from pencilbot.planning.features import features_only, outside_faces
from pencilbot.planning.fidelity import sheet_likeness
from pencilbot.planning.layout import Layout, budget_area, page_size
from pencilbot.planning.one_pen import one_pen_shading
from pencilbot.planning.ordering import order_paths
from pencilbot.planning.plan import Layer, Page, Plan
from pencilbot.planning.plot_budget import lighter_by, plot_cost, within_plot_budget
from pencilbot.planning.resolution import at_plot_resolution
from pencilbot.planning.separation import color_hatching
from pencilbot.planning.shading import FACE_TONE
from pencilbot.planning.sketch_tone import sketch_darkness
from pencilbot.planning.stages import Ordering, Stages, stages_of
from pencilbot.planning.style import DEFAULT_STYLE, Style, load_style
from pencilbot.planning.vectorize import EdgeOptions, edge_strokes

HOME = (0.0, 0.0)
# Every face is drawn at the pen's own scale, as dithered runs (planning/dither.py) to its photo's
# tone, its contours left out but for its dark lines with the style's face_lines; the rest of the
# sheet is hatched to the pencil tone as a picture without a face (docs/faces.md).
#: Pen-down length a one-pen plan aims to stay within, mm per cm² of the sheet (39 m on A4): past
#: it the hatching's tone is drawn lighter by one factor (:meth:`~pencilbot.planning.shading.Hatching.shade_within`). On the face set
#: (bench/fidelity.py --faceset, grbl-servo-a4) plot time grew with pen-down and lifts, 0.43 min
#: per m and 0.54 s per lift; a dark bar photo drew 60 m in 40.9 min (per cm² of the drawing box
#: instead: docs/faces.md). Lifts, corners and pen-up travel are bounded once the plan is ordered
#: (:mod:`pencilbot.planning.plot_budget`).
PEN_DOWN_BUDGET = 63.0
#: Faces' runs covering this share of the drawing make it a portrait, whose plot budget is the
#: faces' (docs/faces.md, eighth round): its contours as the overflow rule keeps them
#: (:data:`~pencilbot.planning.contour_budget.OVERFLOW_POWER`); another picture's to their budget
#: itself where the sheet affords them (``ROOMY_OVERFLOW_POWER``).
PORTRAIT_SHARE = 0.02
log = logging.getLogger(__name__)


def make_plan(
    image: LoadedImage,
    *,
    page: Page | None = None,
    style: Style | str | Path | None = None,
    pens: PenSet | str | Path | None = None,
) -> Plan:
    """Plan the pen drawing of a photo.

    Parameters
    ----------
    image : LoadedImage
        The photo (see :func:`pencilbot.imaging.io.load_image`).
    page : Page, optional
        The sheet; default from the style's ``page``, ``orientation`` and ``margin``.
    style : Style, str or Path, optional
        A :class:`Style`, a shipped style name or a style file; default ``"default"``.
    pens : PenSet, str or Path, optional
        The pens (a :class:`~pencilbot.machine.pens.PenSet`, a shipped set's name or a file);
        default: the plotter's one pen, black. With several pens the plan is of the colour
        sketch (:mod:`pencilbot.planning.separation`).

    Returns
    -------
    Plan
        Hatch layers (lightest first, if the style hatches) then ``"edges"``, each ordered
        for short pen-up travel; ``meta`` records the source and every drawing parameter. With
        pens, every layer names its pen, the pens in load order (lightest first), the edges in
        the darkest.
    """
    return sketch_and_plan(image, page=page, style=style, pens=pens)[1]


def sketch_and_plan(
    image: LoadedImage,
    *,
    page: Page | None = None,
    style: Style | str | Path | None = None,
    pens: PenSet | str | Path | None = None,
    draft: bool = False,
) -> tuple[Sketch, Plan]:
    """:func:`make_plan`, also returning the pencil sketch it was planned from (in colour when
    there are several pens); ``draft``: see :func:`plan_from_sketch`.

    The sketch is of the image at plot resolution (see :func:`at_plot_resolution`), the grid
    the plan was laid out on.
    """
    style = style if isinstance(style, Style) else load_style(style or DEFAULT_STYLE)
    pens = pens if pens is None or isinstance(pens, PenSet) else load_pens(pens)
    if pens is not None:
        style = with_pens(style, pens)
    if page is None:
        page = page_size(style.page, style.orientation, image.shape, style.margin)
    _check_drawable(image, page, style.pen_width)
    image = at_plot_resolution(image, page, style.pen_width)
    drawing = sketch(
        image,
        color=pens is not None and len(pens.pens) > 1,
        line_length=style.line_length,
        stroke_gamma=style.stroke_gamma,
        stroke_width=style.stroke_width,
        texture=style.texture,
        texture_seed=style.seed,
        lines_only=not style.hatch,
    )
    return drawing, plan_from_sketch(drawing, page, style, source=image.source, pens=pens, draft=draft)


def _check_drawable(image: LoadedImage, page: Page, pen_width: float) -> None:
    """Refuse a picture whose narrow side, fitted onto ``page``, is thinner than the pen (mm):
    a 1 x 5000 pixel strip on A4 would be 0.06 mm wide and plan to nothing.

    Raises
    ------
    PencilbotError
        Saying how wide it would be and what to do.
    """
    height, width = image.shape[:2]
    across = min(height, width) * Layout.fit((height, width), page).mm_per_px
    if across < pen_width:
        raise PencilbotError(
            f"{image.source or 'the picture'} is {width} x {height} pixels (as planned): fitted onto the "
            f"{page.width:g} x {page.height:g} mm page it is {across:.2g} mm across, thinner than the "
            f"{pen_width:g} mm pen; crop or pad it to a wider shape"
        )


def with_pens(style: Style, pens: PenSet) -> Style:
    """``style`` drawn with ``pens``: the contours' pen, the darkest, sets the style's pen width."""
    return replace(style, pen_width=pens.darkest.width)


def plan_from_sketch(
    drawing: Sketch,
    page: Page,
    style: Style,
    *,
    source: str = "",
    pens: PenSet | None = None,
    draft: bool = False,
) -> Plan:
    """Plan the pen strokes of an already computed pencil sketch (see :func:`make_plan`).

    Parameters
    ----------
    drawing : Sketch
        Line drawing and, when ``style.hatch``, the texture fit (T); a colour sketch
        (``result`` RGB) when there are several ``pens``.
    page : Page
    style : Style
        (Its pen width is the contours' pen's: see :func:`with_pens`.) Resolved once, at the
        top, into what each stage takes (:func:`stages_of`).
    source : str
        Where the picture came from, for the plan's metadata.
    pens : PenSet, optional
        The pens; default the plotter's one pen.
    draft : bool
        Only to be looked at (a first preview): paths unordered, unjoined (``meta["draft"]``), the
        colour separation unpolished.

    Returns
    -------
    Plan
    """
    line = drawing.line
    layout = Layout.fit(line.edges.shape, page)
    stages = stages_of(style, line)
    faces = find_faces(drawing.gray if drawing.rgb is None else drawing.rgb) if stages.faces else []
    meta = _meta(source, style, stages, page, layout, line, faces, pens)
    important = face_mask(line.edges.shape, faces) if faces else None
    in_color = pens is not None and len(pens.pens) > 1
    hatching = stages.hatching
    dithered = face_mask(line.edges.shape, faces) if faces and hatching and not in_color else None

    def contours(options: EdgeOptions) -> Paths:
        strokes = edge_strokes(line, layout, options, important=important)
        if faces and important is not None:  # (important: the faces' mask)
            strokes = features_only(strokes, layout, 1.0 - drawing.gray, important, faces)
        if dithered is not None:  # the runs draw the faces (and with face_lines, pen lines their dark lines)
            strokes = outside_faces(strokes, layout, 1.0 - drawing.gray, dithered, lines=stages.face_lines)
        return strokes

    draft_meta = {**meta, "draft": "unordered"} if draft else meta
    if hatching is not None and not in_color:
        one_pen = _one_pen_plan(contours, drawing, layout, stages, important, dithered, faces, pens, draft)
        return Plan(page=page, layers=tuple(one_pen), meta=draft_meta)
    strokes = contours(stages.edges)
    layers: list[Layer] = []
    if hatching is not None:  # in colour
        assert pens is not None and drawing.tone is not None  # (in colour: a sketch with its tone)
        if drawing.result.ndim != 3:
            raise ValueError("a plan with several pens needs a colour sketch (sketch(..., color=True))")
        layers += color_hatching(
            drawing.result,
            layout,
            pens.load_order,
            strokes,
            form=1.0 - drawing.tone,
            paper=1.0 - drawing.gray,
            hatching=hatching,
            draft=draft,
        )
    layers = _with_edges(layers, strokes, stages.edges.pen_width, pens)
    ordered = layers if draft else _ordered(layers, stages.order)  # (a draft is only looked at)
    return Plan(page=page, layers=tuple(ordered), meta=draft_meta)


def _one_pen_plan(
    contours, drawing: Sketch, layout: Layout, stages: Stages, important, dithered, faces, pens, draft: bool
):
    """A one-pen plan's layers, ordered: its hatching (and faces' runs) within PEN_DOWN_BUDGET, the
    faces at their own tone, its plotting within PLOT_BUDGET, and its ``contours`` (a function of
    their options) to their budget itself where the sheet affords them and the picture is not a
    portrait (``PORTRAIT_SHARE``). A ``draft``'s are unordered: past the pen-down budget with those
    contours it has the overflow rule's, but the plot's budget is only known once ordered."""
    tone = sketch_darkness(drawing, 1.0 / layout.mm_per_px)  # once, for both tries of the contours
    args = (drawing, tone, layout, stages, important, dithered, faces, pens, draft)
    strokes, roomy = _first_contours(contours, drawing, layout, stages, dithered)
    planned = _one_pen(strokes, *args, roomy=roomy)
    if planned is None:  # past a budget with them: the overflow rule's fewer contours
        lean = contours(stages.edges)
        log.debug("contours %.1f m past the sheet's budgets: %.1f m", _length(strokes), _length(lean))
        strokes = lean
        planned = _one_pen(strokes, *args)
    assert planned is not None
    ordered, (shade, faces_at, scale) = planned
    if draft:
        return ordered
    return _within_plot_budget(ordered, shade, faces_at, scale, strokes, stages, pens, layout, drawing)


def _first_contours(
    contours, drawing: Sketch, layout: Layout, stages: Stages, dithered
) -> tuple[Paths, bool]:
    """The contours a one-pen plan tries first and whether the sheet must afford them: a picture not a
    portrait gets them to their budget itself (``ROOMY_OVERFLOW_POWER``; cut, maybe, from half on)."""
    portrait = dithered is not None and float(np.mean(dithered > 0.5)) >= PORTRAIT_SHARE
    strokes = contours(
        stages.edges if portrait else replace(stages.edges, overflow_power=ROOMY_OVERFLOW_POWER)
    )
    cut = budget_length(stages.edges.budget, drawing.gray.shape, layout.mm_per_px)
    return strokes, not portrait and _length(strokes) * 1e3 >= 0.5 * cut


def _one_pen(
    strokes: Paths,
    drawing: Sketch,
    tone: np.ndarray,
    layout: Layout,
    stages: Stages,
    important,
    dithered,
    faces,
    pens,
    draft: bool,
    *,
    roomy: bool = False,
):
    """A one-pen plan's layers with ``strokes`` for contours, ordered (a ``draft``'s not), and
    what redraws them (:func:`_within_plot_budget`'s shade, faces_at and the scale the hatching
    was drawn at). ``roomy``: None instead when the sheet does not afford them (:func:`_affords`),
    found out before ordering when the pen-down budget already lightens the hatching."""
    assert stages.hatching is not None
    shade, faces_at = one_pen_shading(
        drawing, tone, layout, stages.hatching, strokes, important, dithered, faces, PEN_DOWN_BUDGET
    )
    hatches, scale = shade(1.0)
    if roomy and scale < 1.0:
        return None
    layers = _with_edges(hatches, strokes, stages.edges.pen_width, pens)
    if draft:
        return layers, (shade, faces_at, scale)
    ordered = _ordered(layers, stages.order)
    if roomy and not _affords(ordered, scale, budget_area(layout, stages.hatching.time_budget)):
        return None
    return ordered, (shade, faces_at, scale)


def _affords(ordered: list[Layer], scale: float, area: float) -> bool:
    """Whether a one-pen plan is within its pen-down budget (its hatching drawn at full tone,
    ``scale`` 1) and its plot's (:mod:`pencilbot.planning.plot_budget`) over ``area`` cm², as it is."""
    return scale >= 1.0 and lighter_by(plot_cost(ordered), area) >= 1.0


def _length(paths: Paths) -> float:
    """Pen-down length of ``paths``, m."""
    return float(paths.drawn_lengths().sum()) / 1e3


def _within_plot_budget(
    ordered: list[Layer],
    shade,
    faces_at,
    scale: float,
    strokes: Paths,
    stages: Stages,
    pens,
    layout: Layout,
    drawing: Sketch,
) -> list[Layer]:
    """``ordered`` within the plot's budget (:func:`~pencilbot.planning.plot_budget.within_plot_budget`),
    redrawn by ``shade`` (:func:`~pencilbot.planning.one_pen.one_pen_shading`) from its ``scale``,
    two plans told apart by how like ``drawing``'s photo and sketch they are."""
    assert stages.hatching is not None  # (a one-pen plan hatches)
    plan, pale = ordered, False  # what a redraw at the same tone starts from, and whether it is pale

    def runs_at(level: RunLevel) -> Paths:  # the faces' runs at a level, at the plan's tone
        return faces_at(level, scale)

    def redraw(factor: float, level: RunLevel, paler: bool = False) -> list[Layer]:
        nonlocal plan, pale
        if factor == 1.0 and not paler:  # the faces' runs at another level, the hatching as drawn
            return _with_runs(plan, runs_at(level), stages.order)
        hatches = shade(scale * factor, level, pale or paler)[0]
        layers = _ordered(_with_edges(hatches, strokes, stages.edges.pen_width, pens), stages.order)
        if paler:
            plan, pale = layers, True
        return layers

    return within_plot_budget(
        ordered,
        redraw,
        budget_area(layout, stages.hatching.time_budget),
        faces_at=runs_at,
        paler=lambda: redraw(1.0, LEVELS[0], paler=True),
        judge=lambda layers: sheet_likeness(layers, layout, drawing),
    )


def _with_runs(ordered: list[Layer], runs: Paths, order: Ordering) -> list[Layer]:
    """``ordered`` with other faces' runs: the layers before theirs as they are, theirs and the
    rest ordered again from where those end. (The hatching counted the runs it was drawn with
    round the faces' edges; a thriftier level's differ there by a few runs.)"""
    at = next(i for i, layer in enumerate(ordered) if layer.name == FACE_TONE)
    start = tuple(ordered[at - 1].paths.points[-1]) if at and len(ordered[at - 1].paths) else HOME
    rest = [replace(ordered[at], paths=runs), *ordered[at + 1 :]]
    return [*ordered[:at], *_ordered([layer for layer in rest if len(layer.paths)], order, start)]


def _with_edges(layers: list[Layer], strokes: Paths, pen_width: float, pens: PenSet | None) -> list[Layer]:
    """``layers`` and the edges after them, last; with pens, every layer not yet a pen's and
    the edges in the darkest pen."""
    if pens is None:
        return [*layers, Layer("edges", strokes, pen_width=pen_width, role="edges")]
    in_color = len(pens.pens) > 1
    dark = pens.darkest
    layers = [layer if layer.pen else replace(layer, pen=dark.name, color=dark.color) for layer in layers]
    layers.append(
        Layer(
            f"{dark.name}-edges" if in_color else "edges",
            strokes,
            pen_width=dark.width,
            role="edges",
            pen=dark.name,
            color=dark.color,
        )
    )
    return layers


def _ordered(layers: list[Layer], order: Ordering, start: tuple[float, float] = HOME) -> list[Layer]:
    """Each layer's paths ordered for short pen-up travel, from where the layer before ended
    (the first from ``start``, the plotter's home)."""
    ordered, position = [], start
    for layer in layers:
        started = time.perf_counter()
        # Neighbouring hatch runs are joined pen-down (zig-zag), as a hand hatches without
        # lifting. Edge strokes already come chained along their contours (edge_strokes):
        # joining more than touching ends would draw chords between unrelated strokes.
        # A face's dithered runs come joined where they touch (pencilbot.planning.dither).
        exact = layer.role == "edges" or layer.name == FACE_TONE
        join = order.pen_width if exact else order.hatch_join
        # Only hatch runs of a few shortest strokes are zig-zagged: joined dashes of a light
        # tone would read as a staircase. 1.5 (was 2.5, 3 before): with GRBL's stepper idle lock
        # counted (25 ms at every stop, as the real firmware waits), messi5 came to 30.9 min;
        # joining runs from 1.5 shortest strokes on takes 10-15 % of the lifts off every photo
        # (messi5 1295 -> 1144 paths, 29.8 min) for whole-box rho at most 0.001 lower
        # (bench/fidelity.py), the joins within the pen's own width.
        zigzag = 0.0 if exact else 1.5 * order.min_hatch_run
        paths = order_paths(
            layer.paths, start=position, join_tolerance=join, join_min_length=zigzag, rounds=order.rounds
        )
        ordered.append(replace(layer, paths=paths))
        if len(paths):
            position = tuple(paths.points[-1])
        log.debug(
            "layer %s: %d paths, ordered in %.2f s", layer.name, len(paths), time.perf_counter() - started
        )
    return ordered


def _meta(source: str, style: Style, stages: Stages, page: Page, layout: Layout, line, faces, pens) -> dict:
    """The plan's provenance: where the picture came from, the sketch's parameters and every
    stage's, as resolved."""
    edges, hatching = stages.edges, stages.hatching
    meta = {
        "source": source,
        "style": style.name,
        "page": f"{page.name} {page.width:g}x{page.height:g} mm, margin {page.margin:g} mm",
        "image_px": f"{line.edges.shape[1]}x{line.edges.shape[0]}",  # as planned
        "mm_per_px": f"{layout.mm_per_px:.6g}",
        "pen_width_mm": f"{edges.pen_width:g}",
        "line_length_px": str(line.length),
        "stroke_gamma": f"{style.stroke_gamma:g}",
        "stroke_width_px": f"{style.stroke_width:g}",
        "edge_threshold": f"{edges.threshold:.4g}",
        "hatch_angles_deg": " ".join(f"{a:g}" for a in hatching.angles) if hatching else "",
        "hatch_coverage": f"{style.hatch_coverage:g}",
        "texture": style.texture or "synthesised",
        "texture_seed": str(style.seed),
        "edge_lines": str(edges.max_lines),
        "edge_budget_mm_per_cm2": f"{style.edge_budget:g}",
        "time_budget": f"{style.time_budget:g}",
        # Faces treated with care, "x,y,size" in px of the image as planned (image_px).
        "faces": "; ".join(face.describe() for face in faces)
        if faces
        else ("none" if stages.faces else "off"),
    }
    if pens is not None:
        meta["pens"] = f"{pens.name}: " + ", ".join(
            f"{p.name} {p.color} {p.width:g} mm" for p in pens.load_order
        )
    return meta
