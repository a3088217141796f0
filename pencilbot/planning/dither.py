"""Tone at the pen's own scale: a face too small on paper for hatching, drawn as dithered runs.

A face of two centimetres is a few dozen pen widths across, and hatch lines and dashes there
are as coarse as its features: an eye is a dash or two. Here the face's darkness is resampled
onto a grid of rows about a pen width apart, error-diffused (Floyd–Steinberg) into inked and
bare cells, those improved by a search that weighs the blurred error against the pen lifts
(:mod:`pencilbot.planning.run_search`), and each row's runs of inked cells are drawn as straight
strokes from the first cell's centre to the last's. The diffusion counts the ink a run really
lays (its round first end covers less than a cell) and the ink the contours already lay there,
and it continues a run more easily than it starts one, so the same ink takes fewer, longer runs.

Each stroke is a pen lift, the costliest move of a servo plotter, so runs that touch across
neighbouring rows are joined into one stroke: from a run's end straight down (or diagonally,
past a corner) onto the next row's run, back along it to its end if need be, and on. Measured on
messi5's 17 mm face (bench/fidelity.py, face rho@1mm / @0.5mm, plot time): hatching 0.916 /
0.741, 29.8 min; runs one pen width apart, each its own stroke, 0.977 / 0.936 but 30.7 min;
rows 1.2 pen widths apart, joined, the lightest fifth of the tone left bare 0.961 / 0.894,
29.8 min.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from pencilbot.paths import Paths
from pencilbot.planning.flow import Grid, sample_image
from pencilbot.planning.run_search import search_runs
from pencilbot.render import render_paths
from pencilbot.units import MM_PER_INCH

#: Distance between rows, in pen widths. One: the runs of a light or mid tone are shorter and
#: closer, so at half a millimetre a face's skin reads as tone, not as dashes (face set, rho@0.5mm:
#: 2008_002506's grimace 0.814 -> 0.852, 2008_007676's laughing woman 0.791 -> 0.854, family
#: 2007_007763 #6 0.784 -> 0.839), for a minute or so more plotting on a photo of large faces.
#: (1.2 left a hairline between rows of a solid black and a sixth fewer rows.)
PITCH = 1.0
#: Rows spread from PITCH to WIDE_PITCH as the faces cover from CLOSE_SHARE to CLOSER_SHARE of
#: the drawing: a close portrait is mostly face, and its runs, a lift each few millimetres, are
#: most of its plotting (Tom_Cruise_avp_2014_4's 123 mm face, a third of the sheet: 28.7 min at
#: 1.2, 35.8 min at 1.0, where its face meets the bars at 1.2 already: 0.951 / 0.915).
WIDE_PITCH = 1.2
CLOSE_SHARE, CLOSER_SHARE = 0.15, 0.25
#: How much more easily a run continues than starts (a shift of the threshold, in cells of ink):
#: longer runs, fewer pen lifts, the same ink.
RUN_BIAS = 0.2
#: Darkness kept bare paper, the rest stretched over the full range: a face's lightest skin
#: would otherwise be a scatter of single dots, a pen lift each, and its features stand out more.
LIGHTEST = 0.2


#: Price of a pen lift in the search that improves the diffused cells
#: (:mod:`pencilbot.planning.run_search`), at the finest level.
LIFT = 0.05


@dataclass(frozen=True)
class RunLevel:
    """How finely the faces' runs are drawn: ``run_bias`` (:func:`error_diffuse`), the price of
    a lift in the search that improves them (``lift``, :func:`~pencilbot.planning.run_search.search_runs`),
    the darkness ``lightest`` up to which a face's skin is left bare and the ``ink`` the rest is
    drawn at (:func:`face_runs`)."""

    run_bias: float = RUN_BIAS
    lightest: float = LIGHTEST
    lift: float = LIFT
    ink: float = 1.0


#: The faces' runs from the finest to the thriftiest. A plan is drawn at the first; past its plot
#: budget (:mod:`pencilbot.planning.plot_budget`) or the faces' (:mod:`~pencilbot.planning.face_budget`)
#: at each next one in turn, before anything is drawn lighter. Measured (bench/fidelity.py
#: --faceset, the joins' ink counted, :func:`face_runs`; faces from 25 mm / 12-25 mm meeting their
#: bars, their medians at 1 mm / 0.5 mm, whole-box rho min): the runs at a bias of 0.4, skin to 0.2
#: bare (stop 37): 15 / 29, 0.956 / 0.918, 0.941; a bias of 0.2, then 0.3 and 0.4: 15 / 30, 0.963 /
#: 0.932, 0.942; skin to 0.12 bare first: 16 / 30, 0.972 / 0.935, 0.941 (the lit faces gain most:
#: biden 0.937 -> 0.959 at 1 mm). The finest for every photo: those past the budget paid with their
#: hatching's tone (whole box down to 0.869). Since every level's cells are searched
#: (:mod:`~pencilbot.planning.run_search`), a thriftier level leaves less skin bare at a lower ink
#: instead: its search spreads the same lifts evenly over the skin, where error diffusion
#: scattered them. The finest as before, then (bias 0.4, skin to 0.05 bare, lift 0.1, ink 0.88)
#: and (0.4, 0.12, 0.2, 0.88): 19 / 33, 0.983 / 0.924, 0.937 (2008_001322, its faces darker in
#: the sheet's order of tones); the levels before, searched: 14 / 30, 0.969 / 0.940, 0.944; at ink
#: 1: 19 / 34, 0.981 / 0.940, 0.929; at ink 0.8: 18 / 31, 0.982 / 0.918, 0.938. The finest with
#: skin to 0.05 bare at ink 0.88 too (these LEVELS): 19 / 32, 0.979 / 0.922, 0.941, every photo's
#: whole box at 0.94 or more. A fourth level, (0.4, 0.2, 0.2, 0.88): 17 / 30 (the photos past the
#: budget took it instead of a lighter hatching; the held-out bald_guys.jpg's whole box 0.948 ->
#: 0.926).
LEVELS = (
    RunLevel(RUN_BIAS, 0.05, LIFT, 0.88),
    RunLevel(0.4, 0.05, 0.1, 0.88),
    RunLevel(0.4, 0.12, 0.2, 0.88),
)
#: The faces' runs of a plan still past its plot budget at the last of LEVELS, its hatching drawn
#: lighter (:mod:`pencilbot.planning.plot_budget`): a photo of many faces, whose runs are most of
#: its plot. A tiling of 96 faces (bench/fidelity.py --photos, a stress photo) was 0.807 whole box
#: and 7.97 m of pen-up without it, 0.854 and 7.67 m with it; the face set is unchanged.
SPARSEST = RunLevel(0.4, LIGHTEST, 0.2, 0.88)
#: The ink the joins of a face's runs add (:func:`face_runs`) is taken off its request over this
#: Gaussian sigma, in cells: the runs nearby, not the join's own cells, lay less.
JOIN_SPREAD = 1.5
#: Most cells a join runs back over the run it steps onto.
REACH = 4
#: Ink of a run's first cell, in cells, for a pen as wide as a cell: a stroke of k cells from
#: centre to centre with round ends covers k − 1 cells and a disc.
CAP = np.pi / 4


def face_pitch(share: float) -> float:
    """Distance between a face's rows (pen widths) when the faces cover ``share`` of the drawing."""
    spread = np.clip((share - CLOSE_SHARE) / (CLOSER_SHARE - CLOSE_SHARE), 0.0, 1.0)
    return float(PITCH + (WIDE_PITCH - PITCH) * spread)


def error_diffuse(
    request: np.ndarray,
    region: np.ndarray,
    given: np.ndarray | None = None,
    *,
    pen: float = 1.0,
    run_bias: float = RUN_BIAS,
) -> np.ndarray:
    """Inked cells whose ink follows ``request`` inside ``region``, Floyd–Steinberg with runs.

    Each cell's error goes to its neighbours to the right and below; a cell continuing a run
    lays ``pen`` of ink (the pen covers that share of the row), one starting a run its round end,
    ``CAP · pen²``. Error diffusion is sequential, cell after cell; the cells of one
    anti-diagonal wave are independent of each other and are diffused together.

    Parameters
    ----------
    request : (H, W) float array in [0, 1]
        Darkness to lay, per cell.
    region : (H, W) bool array
        Cells that may be inked; the others stay bare and pass no error on.
    given : (H, W) float array in [0, 1], optional
        Ink already in each cell (the contours'), stacking with a run's as 1 − (1 − g)(1 − i):
        what a contour lays is taken from the cells around it.
    pen : float
        Pen width, in cells.
    run_bias : float
        How much more easily a run continues than starts (``RUN_BIAS``).

    Returns
    -------
    (H, W) bool array
    """
    rows, cols = request.shape
    want = np.where(region, np.clip(request, 0.0, 1.0), 0.0).astype(np.float64)
    base = np.zeros((rows, cols)) if given is None else np.clip(given, 0.0, 1.0).astype(np.float64)
    cap = CAP * pen * pen
    # A cell waits for the one on its left and the three above it: the cells of one anti-diagonal
    # 2·row + column are each other's equals, and each such wave is one set of array operations.
    # Errors and inked cells are kept with a bare row above and a bare column either side.
    error = np.zeros((rows + 1, cols + 2))
    on = np.zeros((rows + 1, cols + 2), bool)
    for wave in range(2 * (rows - 1) + cols):
        r = np.arange(max(0, (wave - cols + 2) // 2), min(rows - 1, wave // 2) + 1)
        c = wave - 2 * r
        # What the row above passed down (its error 3/16 down-left, 5/16 down, 1/16 down-right),
        # summed in that order, then this row's error from the left (7/16).
        below = error[r, c + 2] * 3 / 16 + error[r, c + 1] * 5 / 16 + error[r, c] * 1 / 16
        value = (want[r, c] + below) + error[r + 1, c] * 7 / 16
        previous = on[r + 1, c]
        ink = 1.0 - (1.0 - np.where(previous, pen, cap)) * (1.0 - base[r, c])
        inked = value > (ink + base[r, c]) / 2 - np.where(previous, run_bias, -run_bias)
        inside = region[r, c]
        on[r + 1, c + 1] = inked & inside
        error[r + 1, c + 1] = np.where(inside, value - np.where(inked, ink, base[r, c]), 0.0)
    return on[1:, 1:-1]


def row_runs(on: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every row's runs of consecutive inked cells: (row, first column, last column) arrays,
    row by row, left to right."""
    step = np.diff(np.pad(on.astype(np.int8), ((0, 0), (1, 1))), axis=1)
    rows, first = np.nonzero(step == 1)
    _, after = np.nonzero(step == -1)
    return rows, first, after - 1


def run_strokes(on: np.ndarray, grid: Grid, origin: tuple[int, int] = (0, 0)) -> Paths:
    """Strokes along the runs of ``on``, runs that touch across rows joined into one stroke.

    Parameters
    ----------
    on : (H, W) bool array
        Inked cells (:func:`error_diffuse`).
    grid : Grid
        The cells' grid; ``on``'s cell (0, 0) is ``grid``'s cell ``origin`` (row, column).
    origin : (int, int)

    Returns
    -------
    Paths
        Every run drawn once from end to end; between two runs a stroke steps to the
        neighbouring row (straight, or diagonally past a run's corner) and may run back over up to
        ``REACH`` cells of a run. No two strokes share a run.
    """
    rows, first, last = row_runs(on)
    if rows.size == 0:
        return Paths.empty()
    links = _links(on, rows, first, last)
    partner = _partners(rows.size, links)
    # Where each join reaches the run it steps onto.
    row_of = rows.tolist()
    joined = partner[links[:, 0].astype(np.int64)] == links[:, 1].astype(np.int64)
    via = {}
    for end, other, _, _, column in links[joined].tolist():
        end, other = int(end), int(other)
        via[end, other] = via[other, end] = (row_of[other // 2], int(column))
    # Each chain of runs walked from a free end, its cells gathered in one list; the cells become
    # page points in one step (a stroke's points one by one were most of the time here).
    tips = np.stack([np.repeat(rows, 2), np.stack([first, last], 1).ravel()], 1).tolist()
    following = partner.tolist()
    drawn = bytearray(rows.size)
    cells: list = []
    ends = [0]
    for start in np.flatnonzero(partner < 0).tolist():
        if drawn[start // 2]:
            continue
        end = start
        while True:
            drawn[end // 2] = 1
            cells += (tips[end], tips[end ^ 1])
            after = following[end ^ 1]
            if after < 0:
                break
            cells.append(via[end ^ 1, after])
            end = after
        ends.append(len(cells))
    points = grid.to_mm(np.asarray(cells, np.float64) + np.asarray(origin))
    offsets = np.asarray(ends)
    # A point where the one before it in the same stroke is (a run of one cell, a join onto a tip).
    kept = np.ones(len(points), bool)
    kept[1:] = np.any(points[1:] != points[:-1], axis=1)
    kept[offsets[:-1]] = True
    return Paths(points[kept], np.concatenate([[0], np.cumsum(kept)[offsets[1:] - 1]]))


def solo_strokes(on: np.ndarray, grid: Grid, origin: tuple[int, int] = (0, 0)) -> Paths:
    """Every run of ``on`` as its own stroke, unjoined: the ink :func:`error_diffuse` counts."""
    rows, first, last = row_runs(on)
    if rows.size == 0:
        return Paths.empty()
    cells = np.stack([np.stack([rows, first], 1), np.stack([rows, last], 1)], 1).reshape(-1, 2)
    points = grid.to_mm(cells.astype(np.float64) + np.asarray(origin))
    return Paths(points, np.arange(0, len(points) + 1, 2))


def _links(on: np.ndarray, rows: np.ndarray, first: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Candidate joins from a run's end onto a run of a neighbouring row that it touches.

    An end is ``2 · run`` (the run's first cell) or ``2 · run + 1`` (its last). A join steps
    from the end (r, x) to the cell (r ± 1, x') of the other run, straight across or, where that
    cell is bare, diagonally; then runs along the other run to one of its ends, back over at most
    ``REACH`` cells. Rows of (end, other run's end, extra ink in cells, cells run back over, x').
    """
    count = rows.size
    lengths = last - first + 1
    run_of = np.repeat(np.arange(count), lengths)
    columns = (
        np.repeat(first, lengths)
        + np.arange(lengths.sum())
        - np.repeat(np.cumsum(lengths) - lengths, lengths)
    )
    owner = np.full((on.shape[0] + 2, on.shape[1] + 2), -1, np.int64)  # a bare border all round
    owner[np.repeat(rows, lengths) + 1, columns + 1] = run_of
    end_row, end_col = np.repeat(rows, 2) + 1, np.stack([first, last], 1).ravel() + 1
    ends = np.arange(2 * count)
    found = []
    for dr in (1, -1):
        straight = owner[end_row + dr, end_col]
        for dc in (0, -1, 1):
            other = owner[end_row + dr, end_col + dc]
            ok = (other >= 0) & (straight < 0 if dc else True)
            end, other = ends[ok], other[ok]
            # A diagonal step inks a quarter of each of the two cells beside it (if bare).
            extra = 0.0 if dc == 0 else 0.25 + 0.25 * (owner[end_row[ok], end_col[ok] + dc] < 0)
            column = end_col[ok] - 1 + dc
            for side, tip in ((0, first[other]), (1, last[other])):
                back = np.abs(column - tip)
                found.append(np.stack(np.broadcast_arrays(end, 2 * other + side, extra, back, column), 1))
    links = np.concatenate(found).astype(np.float64)
    links = links[links[:, 3] <= REACH]
    return links[np.lexsort((links[:, 3], links[:, 2]))]


def _partners(count: int, links: np.ndarray) -> np.ndarray:
    """The end each run end is joined to (−1: none), taking ``links`` in order: every end is
    joined at most once and no run is joined round into a loop, so the joins make chains."""
    partner = np.full(2 * count, -1, np.int64)
    chain = np.arange(count)

    def root(run: int) -> int:
        while chain[run] != run:
            chain[run] = chain[chain[run]]
            run = chain[run]
        return run

    for end, other in links[:, :2].astype(np.int64).tolist():
        if partner[end] < 0 and partner[other] < 0 and root(end // 2) != root(other // 2):
            chain[root(end // 2)] = root(other // 2)
            partner[end], partner[other] = other, end
    return partner


def face_runs(
    darkness: np.ndarray,
    dithered: np.ndarray,
    layout,
    edges: Paths,
    *,
    pen_width: float,
    blank_below: float,
    paper: np.ndarray,
    level: RunLevel = LEVELS[0],
    ink_scale: float = 1.0,
) -> Paths:
    """The dithered runs (:mod:`pencilbot.planning.dither`) that draw ``darkness`` where
    ``dithered`` is above ½, on rows ``PITCH`` pen widths apart (more for a close portrait:
    :func:`~pencilbot.planning.dither.face_pitch`), the edges' ink counted.

    Darkness up to ``level.lightest`` is left bare and the rest stretched over the full range,
    times ``ink_scale`` (a sheet drawn lighter for its budgets, the same skin bare); where
    the photo (``paper``) is lighter than ``blank_below`` the paper stays blank, as elsewhere.
    """
    grid = Grid(layout.drawing_box, pen_width * PITCH)
    region = sample_image(dithered, layout, grid) > 0.5
    pitch = face_pitch(float(region.mean()))
    if pitch != PITCH:
        grid = Grid(layout.drawing_box, pen_width * pitch)
        region = sample_image(dithered, layout, grid) > 0.5
    if not region.any():
        return Paths.empty()
    rows, cols = np.nonzero(region)
    window = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
    cut = level.lightest
    target = (
        level.ink
        * ink_scale
        * np.clip((sample_image(darkness, layout, grid)[window] - cut) / (1.0 - cut), 0.0, 1.0)
    )
    target[sample_image(paper, layout, grid)[window] < blank_below] = 0.0
    given = ink_on_grid(edges, grid, pen_width)[window]
    origin = (int(rows.min()), int(cols.min()))
    on = _dithered(target, region[window], given, pitch, level)
    runs = run_strokes(on, grid, origin)
    # The joins' steps between rows lay ink the diffusion did not count (a shorter bias joins
    # more of them: a mid grey of 0.35 came to 0.43): taken off the request around them, and the
    # runs drawn again, once (0.38; a second time the joins moved and it came to 0.40).
    solo = ink_on_grid(solo_strokes(on, grid, origin), grid, pen_width)
    extra = np.maximum(ink_on_grid(runs, grid, pen_width) - solo, 0.0)[window]
    if not np.any(extra > 0):
        return runs
    request = np.clip(
        target
        - cv2.GaussianBlur(extra.astype(np.float32), (0, 0), JOIN_SPREAD, borderType=cv2.BORDER_REPLICATE),
        0.0,
        1.0,
    )
    return run_strokes(_dithered(request, region[window], given, pitch, level), grid, origin)


def _dithered(
    request: np.ndarray, region: np.ndarray, given: np.ndarray, pitch: float, level: RunLevel
) -> np.ndarray:
    """The inked cells of ``request``: diffused, then searched (:mod:`pencilbot.planning.run_search`)."""
    on = error_diffuse(request, region, given, pen=1.0 / pitch, run_bias=level.run_bias)
    return search_runs(on, request, region, given, pen=1.0 / pitch, lift=level.lift)


def ink_on_grid(paths: Paths, grid: Grid, pen_width: float) -> np.ndarray:
    """Darkness of pen paths on a grid's cells (exact-area rasteriser)."""
    rows, cols = grid.shape
    x0, _, _, y1 = grid.box
    height = rows * grid.cell
    return render_paths(
        paths,
        cols * grid.cell,
        height,
        dpi=MM_PER_INCH / grid.cell,
        pen_width=pen_width,
        origin=(x0, y1 - height),
    )
