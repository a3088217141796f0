"""Shading that closes the loop: hatch, render what the pen lays down, correct, hatch again.

The goal is the picture a viewer sees at arm's length: the tone darkness d blurred by ``blur``
mm (the 1–3 mm scale at which shading is judged), with the contours counted *in* it: where an
edge stroke lays ink, the hatching beside it lays less, so a contour is part of the tone instead
of a dark rim on top of it (measured: drawing the tone under the contours, 1 − (1 − e)(1 − d),
followed the photo worse, Spearman rho coffee 0.809 against 0.826, rocket 0.744 against 0.764,
at the same fidelity to the raster sketch). The hatching's request starts at d. Each round
hatches the request, renders edges and hatching with the exact-area rasteriser the previews and
the simulator use, blurs that the same way and adds the difference to the request. What the ideal
dither model cannot know — strokes dropped as too short, gaps bridged, lines that crowd or spread
where they bend, ink already laid by a contour — is measured instead of modelled, so dark tones
reach full coverage, mid-tones get their share and the tone around contours is kept.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, fields

import numpy as np

from pencilbot.paths import Paths
from pencilbot.planning.dither import LEVELS, RunLevel, face_runs, ink_on_grid
from pencilbot.planning.face_budget import thriftier, within_budget
from pencilbot.planning.flow import Grid, direction_field, gaussian, sample_image
from pencilbot.planning.hatching import (
    HATCH_ANGLES,
    HATCH_COVERAGE,
    HATCH_OVERLAP,
    MIN_HATCH_RUN,
    family_capacity,
    family_lines,
    hatch_layers,
)
from pencilbot.planning.layout import budget_area
from pencilbot.planning.plan import Layer
from pencilbot.units import DEFAULT_PEN_WIDTH

#: Default scale (mm) of the forms the hatching follows, photo darkness under which the paper
#: stays blank, and the blur (mm) at which the plot's tone is matched: the style starts here.
FORM_SCALE = 8.0
BLANK_BELOW = 0.04
TONE_BLUR = 1.0
#: A family is traced when more than SHORT_SHARE of the tone asks for more than the families
#: before it reach, less SHORTFALL.
SHORTFALL = 0.02
SHORT_SHARE = 1e-3
#: Largest cell (mm) on which the loop compares tone: fine enough for a 1 mm blur, coarse enough to be quick.
TONE_CELL = 0.5
#: Share of the measured error corrected per round: below 1, as switching lines is not smooth.
GAIN = 0.8
#: Gaussian sigma (mm) over which the measured error is spread before it corrects the request.
CORRECTION_BLUR = 2.0
#: Where the tone itself changes over a millimetre or two (its blur at SHARP_CORRECTION_BLUR mm
#: differs from its blur at CORRECTION_BLUR by SHARP_ERROR or more: a painting's brush strokes,
#: a star's rim, the edge of a sleeve), the error is spread only over SHARP_CORRECTION_BLUR;
#: blended in between. A flat tone keeps the coarse correction (a finer one only moves the dashes
#: of a light tone about), and so does the whole sheet: a finer correction everywhere fragments
#: the dashes into more pen lifts (messi5 1359 -> 1464 paths, 30.9 min). bench/fidelity.py,
#: whole-box rho with the contour budget's overflow rule: starry_night 0.924 -> 0.942.
SHARP_CORRECTION_BLUR = 0.5
SHARP_ERROR = 0.05
#: A sheet drawn lighter for its budgets (:meth:`Hatching.shade_within`) draws its faces' runs
#: lighter by the factor to this power, past the lightest skin's cut (the same skin stays bare).
#: Held at their tone (0), a dark photo's faces were dark discs on a sheet of light hatching: a
#: darkened copy of 2008_007676 (bench/fidelity.py --photos, gamma 1/0.6) whole box 0.798, the bar
#: photo itself 0.941; at 0.5 0.868 and 0.954, at 1 0.889 and 0.959, the face set's faces meeting
#: their bars 16 / 30 (held), 16 / 29 (0.5), 15 / 29 (1) of 21 / 38 (with the faces' level
#: foretold by the plot budget since: 16 / 30 at 0.5).
FACE_FOLLOWS = 0.5
#: Cell (mm) of the direction field: forms vary over millimetres, not pen widths.
FIELD_CELL = 2.0
#: In a face, tone is matched at this blur (Gaussian sigma, mm; elsewhere the style's
#: ``hatch_blur``) and corrected over FACE_CORRECTION_BLUR: an eye, a nostril, the corner of a
#: mouth are a few millimetres on paper. Measured on the bench's three faces (astronaut,
#: grace_hopper, messi5): face rho@1mm 0.904 / 0.871 / 0.815 without, 0.934 / 0.883 / 0.914
#: with (and the hatching's FINE).
FACE_BLUR = 0.5
FACE_CORRECTION_BLUR = 0.7
#: Name of the layer of a small face's dithered runs (:mod:`pencilbot.planning.dither`).
FACE_TONE = "face-tone"
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Hatching:
    """How tone becomes hatching: every parameter of the tone loop, in one object that travels
    down from the style (:func:`~pencilbot.planning.stages.stages_of`) to the loop (:meth:`shade`, :class:`ToneLoop`).

    Attributes
    ----------
    pen_width : float
        Pen width, mm.
    angles : tuple of float
        Angle of each hatch family to the form, degrees (see :func:`hatch_layers`).
    coverage : float
        Densest coverage of one family, in (0, 1).
    overlap : float
        Overlap of the families' onset ramps, in [0, 1).
    form_scale : float
        Size (mm) of the forms the hatching follows; 0 hatches in straight lines at ``angles``
        to the page's 45°.
    min_run : float
        Shortest hatch stroke, mm.
    blank_below : float
        Photo darkness (see ``paper`` of :meth:`shade`) below which the paper stays blank.
    pale : float
        Tone (at the ``blur``) under which the paper stays blank (:data:`~pencilbot.planning.plot_budget.PALE`).
    wobble : float
        Smooth random bend of the lines, fraction of the spacing.
    blur : float
        Gaussian sigma (mm) of the scale at which tone is matched.
    rounds : int
        Hatch–render–correct rounds (1 = no correction).
    seed : int
    time_budget : float
        The style's: the plotting budgets' scale (:func:`~pencilbot.planning.layout.budget_area`).
    """

    pen_width: float = DEFAULT_PEN_WIDTH
    angles: tuple[float, ...] = HATCH_ANGLES
    coverage: float = HATCH_COVERAGE
    overlap: float = HATCH_OVERLAP
    form_scale: float = FORM_SCALE
    min_run: float = MIN_HATCH_RUN
    blank_below: float = BLANK_BELOW
    pale: float = 0.0
    wobble: float = 0.0
    blur: float = TONE_BLUR
    rounds: int = 2
    seed: int = 0
    time_budget: float = 1.0

    def shade(
        self,
        darkness: np.ndarray,
        layout,
        edges: Paths,
        *,
        paper: np.ndarray | None = None,
        form: np.ndarray | None = None,
        important: np.ndarray | None = None,
        dithered: np.ndarray | None = None,
        face_darkness: np.ndarray | None = None,
        level: RunLevel = LEVELS[0],
        face_scale: float = 1.0,
        runs_for: Callable[[RunLevel, float], Paths] | None = None,
    ) -> list[Layer]:
        """Hatch layers whose rendered ink, with the edges, matches ``darkness`` at the ``blur`` scale.

        Parameters
        ----------
        darkness : (H, W) float array in [0, 1]
            Tone to reproduce on the layout's image grid (e.g. 1 − J).
        layout : Layout
            Placement of the image on the page.
        edges : Paths
            The edge strokes (page mm) that will be drawn over the hatching.
        paper : (H, W) float array in [0, 1], optional
            How dark the *photo* is on the image grid (1 − luma). Where it is below ``blank_below``
            (after the blur) the paper stays blank whatever the tone asks. Judging paper by the
            photo, not the tone, keeps a white sheet white and still shades a light face that the
            pencil tone model maps close to paper. Default: ``darkness``.
        form : (H, W) float array, optional
            Tone whose forms the lines follow (the direction field's picture); default
            ``darkness``. A colour plan gives every pen the picture's tone, so all pens follow one form.
        important : (H, W) float array in [0, 1], optional
            Where the picture matters most (faces, on the layout's image grid; e.g.
            :func:`pencilbot.imaging.faces.face_mask`). There the tone is matched at the finer
            ``FACE_BLUR`` and the hatching is finer (``fine`` of
            :func:`~pencilbot.planning.hatching.hatch_strokes`); blended by the mask's value.
        dithered : (H, W) float array in [0, 1], optional
            Faces drawn at the pen's own scale instead (on the layout's image grid; where above ½):
            ``darkness`` there is dithered into runs (:mod:`pencilbot.planning.dither`) and the
            hatching leaves it bare, counting the runs' ink as it counts the edges'.
        face_darkness : (H, W) float array in [0, 1], optional
            The tone the dithered faces are drawn to; default ``darkness``.
        level : RunLevel
            How finely the faces' runs are drawn (:data:`~pencilbot.planning.dither.LEVELS`).
        face_scale : float
            The faces' runs' ink scaled by this past their cut (a sheet drawn lighter).
        runs_for : callable, optional
            The faces' runs at a level and ``face_scale`` instead of :meth:`faces`: kept by a plan
            that draws them again (they are most of a portrait's planning).

        Returns
        -------
        list of Layer
            One per family, lightest first, from the last round; then ``FACE_TONE``, the dithered
            faces' runs, if any.
        """
        runs = (
            runs_for(level, face_scale)
            if runs_for is not None
            else self.faces(
                darkness if face_darkness is None else face_darkness,
                layout,
                edges,
                paper=darkness if paper is None else paper,  # (the loop's photo_darkness)
                dithered=dithered,
                level=level,
                face_scale=face_scale,
            )
        )
        loop = ToneLoop(self, darkness, layout, paper=paper, form=form, important=important)
        layers = loop.run(edges, runs, dithered)
        if len(runs):
            layers = [*layers, Layer(FACE_TONE, runs, pen_width=self.pen_width, role="hatch")]
        return layers

    def faces(
        self,
        darkness: np.ndarray,
        layout,
        edges: Paths,
        *,
        paper: np.ndarray,
        dithered: np.ndarray | None,
        level: RunLevel = LEVELS[0],
        face_scale: float = 1.0,
        drawn: dict | None = None,
    ) -> Paths:
        """The dithered faces' runs of :meth:`shade` (its ``face_darkness``, ``level`` and
        ``face_scale``), within the faces' own budget (:mod:`pencilbot.planning.face_budget`);
        ``drawn`` keeps each drawing of them for the next call with the same pictures."""
        if dithered is None or not np.any(dithered > 0.5):
            return Paths.empty()
        drawn = {} if drawn is None else drawn

        def draw(scale: float, at: RunLevel) -> Paths:
            if (scale, at, face_scale) not in drawn:
                drawn[scale, at, face_scale] = face_runs(
                    scale * darkness,
                    dithered,
                    layout,
                    edges,
                    pen_width=self.pen_width,
                    blank_below=self.blank_below,
                    paper=paper,
                    level=at,
                    ink_scale=face_scale,
                )
            return drawn[scale, at, face_scale]

        return within_budget(draw, budget_area(layout, self.time_budget), thriftier(level))

    def shade_within(
        self,
        budget: float,
        darkness: np.ndarray,
        layout,
        edges: Paths,
        *,
        paper: np.ndarray | None = None,
        important: np.ndarray | None = None,
        dithered: np.ndarray | None = None,
        face_darkness: np.ndarray | None = None,
        scale: float = 1.0,
        level: RunLevel = LEVELS[0],
        runs_for: Callable[[RunLevel, float], Paths] | None = None,
    ) -> tuple[list[Layer], float]:
        """:meth:`shade`, its pen-down length (mm) within ``budget`` (the faces' runs in it), and
        the factor its tone was scaled by.

        Past the budget the tone is shaded once more, scaled by (what the budget leaves it /
        what it drew)^¾: every tone lighter by one factor, so the drawing keeps its order of
        tones (and its ρ and r). The faces' runs follow by ``scale ** FACE_FOLLOWS``, past their
        lightest skin's cut (:func:`~pencilbot.planning.dither.face_runs`' ``ink_scale``). A
        ``scale`` under 1 draws the tone that much lighter, once, whatever its pen-down (the plot's
        budget, :mod:`pencilbot.planning.plot_budget`). The other keywords are :meth:`shade`'s.
        """
        start = scale
        for _ in range(2):
            layers = self.shade(
                scale * darkness,
                layout,
                edges,
                paper=paper,
                important=important,
                dithered=dithered,
                face_darkness=face_darkness,
                level=level,
                face_scale=scale**FACE_FOLLOWS,
                runs_for=runs_for,
            )
            drawn = sum(float(layer.paths.drawn_lengths().sum()) for layer in layers)
            if drawn <= budget or scale < start or start < 1.0:
                return layers, scale
            runs = sum(
                float(layer.paths.drawn_lengths().sum()) for layer in layers if layer.name == FACE_TONE
            )
            # ¾: the hatching's ink falls faster than its tone (fewer families reach a lighter one);
            # linear, the dark bar photo came to 24.8 min but its whole-box rho 0.944 -> 0.929.
            scale *= (max(budget - runs, 0.0) / max(drawn - runs, 1e-9)) ** 0.75
            log.debug(
                "pen-down %.1f m over the budget %.1f m: tone scaled by %.2f",
                drawn / 1e3,
                budget / 1e3,
                scale,
            )
        return layers, scale


def shade(darkness: np.ndarray, layout, edges: Paths, **options) -> list[Layer]:
    """:meth:`Hatching.shade` with the :class:`Hatching` of ``options`` (its fields; the rest,
    ``paper``, ``form``, ``important``, ``dithered``, ``face_darkness``, go to the loop)."""
    names = {f.name for f in fields(Hatching)}
    hatching = Hatching(**{key: value for key, value in options.items() if key in names})
    return hatching.shade(darkness, layout, edges, **{k: v for k, v in options.items() if k not in names})


class ToneLoop:
    """The hatching engine of one picture: its :class:`Hatching`, the grid the tone is compared
    on, the direction field the lines follow and the families traced so far. :meth:`run` hatches,
    renders, corrects and hatches again.

    Tracing a family is the costly part of hatching; the darkest families serve only the
    darkest tones (with the default onset the third starts near 0.86), which many pictures
    never reach. A family is traced once some of the request exceeds what the ones before it
    can lay down together.
    """

    def __init__(
        self, hatching: Hatching, darkness, layout, *, paper=None, form=None, important=None
    ) -> None:
        self.hatching = h = hatching
        box = layout.drawing_box
        # Neighbouring lines must not share a cell: ink of separate paths in one cell stacks as
        # 1 − Π(1 − c), which undercounts lines that lie side by side, and the loop would overshoot.
        self.cell = cell = min(TONE_CELL, h.pen_width / h.coverage / 2)
        self.grid = grid = Grid(box, cell)
        self.layout = layout
        self.sigma = h.blur / cell
        raw = np.clip(sample_image(darkness, layout, grid), 0.0, 1.0)
        tone = gaussian(raw, self.sigma)
        photo = tone if paper is None else gaussian(sample_image(paper, layout, grid), self.sigma)
        self.photo_darkness = darkness if paper is None else paper
        tone[(photo < h.blank_below) | (tone < h.pale)] = 0.0
        self.tone = tone
        self.fine = self.fine_goal = None
        if important is not None and np.any(important > 0):
            self.fine = np.clip(sample_image(important, layout, grid), 0.0, 1.0)
            self.fine_goal = gaussian(raw, FACE_BLUR / cell)
            self.fine_goal[photo < h.blank_below] = 0.0
        field_grid = Grid(box, FIELD_CELL)
        self.field = direction_field(
            sample_image(darkness if form is None else form, layout, field_grid),
            field_grid,
            scale=h.form_scale,
            calm=0.008 if h.form_scale > 0 else np.inf,
        )
        self.angles = tuple(h.angles)
        self.lines: list = []
        self.capacity = np.zeros((len(self.angles), *grid.shape))

    def run(self, edges: Paths, runs: Paths, dithered) -> list[Layer]:
        """The hatch layers of the last round (the faces' ``runs`` counted as the edges' ink,
        the ``dithered`` faces left bare)."""
        h, grid, cell, tone = self.hatching, self.grid, self.cell, self.tone
        edge_ink = self.ink(edges)
        # Where the tone itself changes over a millimetre or two, the loop corrects at that scale.
        detail = np.abs(gaussian(tone, SHARP_CORRECTION_BLUR / cell) - gaussian(tone, CORRECTION_BLUR / cell))
        detail = np.clip(detail / SHARP_ERROR, 0.0, 1.0)
        paper = tone == 0.0
        if len(runs):
            edge_ink = 1.0 - (1.0 - edge_ink) * (1.0 - self.ink(runs))
            paper |= sample_image(dithered, self.layout, grid) > 0.5
        # Start from the tone with the contours' own ink taken out where it lies (ink stacks as
        # 1 − (1 − e)(1 − h)), judged at half a millimetre: the loop's correction is coarser and
        # would spread a contour's share into a pale band beside it.
        local_edges = gaussian(edge_ink, 0.5 / cell)
        request = np.clip(1.0 - (1.0 - tone) / np.maximum(1.0 - local_edges, 0.05), 0.0, 1.0)
        request[paper] = 0.0
        for round_ in range(max(1, h.rounds)):
            layers = self.hatch(request)
            if round_ == h.rounds - 1:
                break
            hatch_ink = self.ink(Paths.concat(layer.paths for layer in layers))
            request = np.clip(
                request + GAIN * self.error(1.0 - (1.0 - edge_ink) * (1.0 - hatch_ink), detail), 0.0, 1.0
            )
            request[paper] = 0.0
        return layers

    def hatch(self, request: np.ndarray) -> list[Layer]:
        """One round's hatch layers for ``request``, tracing the families it needs first."""
        h = self.hatching
        self._trace_for(request)
        return hatch_layers(
            request,
            self.grid,
            self.field,
            pen_width=h.pen_width,
            angles=h.angles,
            coverage=h.coverage,
            overlap=h.overlap,
            min_run=h.min_run,
            lines=self.lines,
            capacity=self.capacity,
            fine=self.fine,
        )

    def error(self, ink: np.ndarray, detail: np.ndarray) -> np.ndarray:
        """The tone ``ink`` misses, spread for correcting the request."""
        cell = self.cell
        # Correct at the scale of the hatch pattern itself (light tones are dashes millimetres
        # apart): a correction finer than that only moves dashes about, unless the tone has
        # detail at that scale (SHARP_ERROR).
        difference = self.tone - gaussian(ink, self.sigma)
        error = gaussian(difference, CORRECTION_BLUR / cell)
        error = (1.0 - detail) * error + detail * gaussian(difference, SHARP_CORRECTION_BLUR / cell)
        if self.fine is not None:  # in faces the hatching is finer, and so is the correction
            fine_error = gaussian(
                self.fine_goal - gaussian(ink, FACE_BLUR / cell), FACE_CORRECTION_BLUR / cell
            )
            error = (1.0 - self.fine) * error + self.fine * fine_error
        return error

    def ink(self, paths: Paths) -> np.ndarray:
        """Darkness of ``paths`` on the loop's grid."""
        return ink_on_grid(paths, self.grid, self.hatching.pen_width)

    def _trace_for(self, request: np.ndarray) -> None:
        h = self.hatching
        while len(self.lines) < len(self.angles) and self._short(request):
            j = len(self.lines)
            family = family_lines(
                self.field.rotated(self.angles[j]),
                seed=h.seed + j,
                pen_width=h.pen_width,
                coverage=h.coverage,
                wobble=h.wobble,
            )
            self.lines.append(family)
            self.capacity[j] = family_capacity([family], self.field, self.grid)[0]

    def _short(self, request: np.ndarray) -> bool:
        if not self.lines:
            return bool(np.any(request > 0))
        reach = 1.0 - np.prod(1.0 - self.capacity[: len(self.lines)], axis=0)
        wanting = request > 0
        short = wanting & (request > reach - SHORTFALL)
        return short.sum() > SHORT_SHARE * max(wanting.sum(), 1)
