"""A small face at the pen's own scale: dithered cells, runs along the rows, joined where they touch."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.paths import Paths
from pencilbot.planning.dither import (
    CAP,
    LEVELS,
    LIGHTEST,
    PITCH,
    REACH,
    RunLevel,
    error_diffuse,
    face_runs,
    ink_on_grid,
    row_runs,
    run_strokes,
    solo_strokes,
)
from pencilbot.planning.flow import Grid
from pencilbot.planning.layout import Layout
from pencilbot.planning.plan import Page
from pencilbot.planning.shading import FACE_TONE, shade

PEN = 0.5
GRID = Grid((10.0, 10.0, 40.0, 40.0), PEN)  # 60 x 60 cells


def _ink(paths: Paths) -> np.ndarray:
    """Ink per cell of GRID, rendered at a tenth of a cell (round pen ends and all) and averaged."""
    fine = ink_on_grid(paths, Grid(GRID.box, GRID.cell / 10), PEN)
    rows, cols = GRID.shape
    return fine.reshape(rows, 10, cols, 10).mean(axis=(1, 3))


def _cells_drawn(paths: Paths, shape) -> np.ndarray:
    """Cells a stroke runs along within a row (its horizontal segments, and every point)."""
    drawn = np.zeros(shape, bool)
    for path in paths:
        rc = np.rint(GRID.to_rc(path)).astype(int)
        drawn[rc[:, 0], rc[:, 1]] = True
        for (r0, c0), (r1, c1) in zip(rc[:-1], rc[1:]):
            if r0 == r1:
                drawn[r0, min(c0, c1) : max(c0, c1) + 1] = True
    return drawn


def _random_cells(seed: int = 1, share: float = 0.45) -> np.ndarray:
    return np.random.default_rng(seed).random(GRID.shape) < share


def test_row_runs_are_the_runs_of_each_row():
    on = np.array([[1, 1, 0, 1], [0, 0, 0, 0], [1, 0, 1, 1]], bool)
    rows, first, last = row_runs(on)
    assert rows.tolist() == [0, 0, 2, 2] and first.tolist() == [0, 3, 0, 2] and last.tolist() == [1, 3, 0, 3]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_strokes_run_along_exactly_the_inked_cells(seed):
    on = _random_cells(seed)
    strokes = run_strokes(on, GRID)
    assert np.array_equal(_cells_drawn(strokes, on.shape), on)
    # Between rows a stroke only steps to the next row, onto an inked cell at most one column over.
    for path in strokes:
        rc = np.rint(GRID.to_rc(path)).astype(int)
        step = np.abs(np.diff(rc, axis=0))
        assert np.all(step[:, 0] <= 1) and np.all(step[step[:, 0] == 1, 1] <= 1)
        assert on[rc[:, 0], rc[:, 1]].all()


def test_touching_runs_are_joined_into_fewer_strokes():
    on = _random_cells(4)
    runs = len(row_runs(on)[0])
    strokes = run_strokes(on, GRID)
    assert len(strokes) < 0.6 * runs
    # Along a row a stroke runs back over at most REACH cells of the run it stepped onto.
    for path in strokes:
        rc = np.rint(GRID.to_rc(path)).astype(int)
        along = (rc[1:, 0] == rc[:-1, 0]) * np.abs(np.diff(rc[:, 1]))
        for row in np.unique(rc[:, 0]):
            there = rc[:, 0] == row
            span = np.ptp(rc[there, 1])
            assert along[there[:-1] & there[1:]].sum() - span <= REACH


@pytest.mark.parametrize("bias", sorted({level.run_bias for level in LEVELS}))
def test_the_ink_follows_the_request_and_darker_asks_for_more(bias):
    region = np.ones(GRID.shape, bool)
    means = []
    for level in (0.15, 0.35, 0.55, 0.75, 0.95):
        on = error_diffuse(np.full(GRID.shape, level), region, run_bias=bias)
        ink = _ink(solo_strokes(on, GRID))[5:-5, 5:-5].mean()  # away from the border
        assert ink == pytest.approx(level, abs=0.03)
        means.append(ink)
    assert np.all(np.diff(means) > 0.1)
    # Every run drawn as its own stroke is what the diffusion counts; joined, the same cells.
    assert np.array_equal(_cells_drawn(solo_strokes(on, GRID), on.shape), on)


def test_the_joins_ink_is_taken_off_the_faces_request():
    # Joining runs across rows steps diagonally past bare cells: at RUN_BIAS a mid grey's runs,
    # joined as they are diffused, came to 0.43 for 0.35. face_runs takes that ink off around them.
    layout = Layout.fit((120, 120), Page(80.0, 80.0, margin=10.0))
    face = np.ones((120, 120), np.float32)
    for level in (0.25, 0.35, 0.45):
        on = error_diffuse(np.full(GRID.shape, level), np.ones(GRID.shape, bool))
        joined = _ink(run_strokes(on, GRID))[5:-5, 5:-5].mean()
        assert joined - level > 0.06  # the defect: the joins' ink on top of the request's
        request = np.full((120, 120), LIGHTEST + (1 - LIGHTEST) * level, np.float32)
        runs = face_runs(
            request,
            face,
            layout,
            Paths.empty(),
            pen_width=PEN,
            blank_below=0.0,
            paper=request,
            level=RunLevel(),
        )
        drawn = ink_on_grid(runs, Grid(layout.drawing_box, PEN / 4), PEN)
        inner = drawn[len(drawn) // 8 : -len(drawn) // 8, len(drawn) // 8 : -len(drawn) // 8].mean()
        assert inner == pytest.approx(level, abs=0.045)


def test_a_run_s_round_end_is_counted():
    # A stroke along k cells, centre to centre, lays k - 1 cells of ink and a disc of CAP ...
    stroke = Paths.of([GRID.to_mm(np.array([[30.0, 20.0], [30.0, 24.0]]))])
    assert _ink(stroke).sum() == pytest.approx(4 + CAP, abs=0.01)
    # ... and the diffusion lays the request's ink in those terms.
    for level in (0.3, 0.5, 0.7):
        on = error_diffuse(np.full(GRID.shape, level), np.ones(GRID.shape, bool))
        _, first, last = row_runs(on)
        assert (last - first + CAP).sum() == pytest.approx(level * on.size, rel=0.02)


@pytest.mark.parametrize("given", [0.0, 0.5])
def test_ink_already_there_stacks_with_the_runs(given):
    # Rows PITCH pen widths apart: a run of k cells lays (k - 1) pen + CAP pen² cells of ink.
    pen = 1 / PITCH
    on = error_diffuse(
        np.full(GRID.shape, 0.8), np.ones(GRID.shape, bool), np.full(GRID.shape, given), pen=pen
    )
    _, first, last = row_runs(on)
    laid = ((last - first) * pen + CAP * pen**2).sum() / on.size
    assert 1.0 - (1.0 - given) * (1.0 - laid) == pytest.approx(0.8, abs=0.02)


def test_nothing_is_inked_where_nothing_is_asked_or_outside_the_region():
    assert not error_diffuse(np.zeros(GRID.shape), np.ones(GRID.shape, bool)).any()
    assert len(run_strokes(np.zeros(GRID.shape, bool), GRID)) == 0
    region = np.zeros(GRID.shape, bool)
    region[20:40, 20:40] = True
    on = error_diffuse(np.full(GRID.shape, 0.6), region)
    assert on[20:40, 20:40].any() and not on[~region].any()


@pytest.mark.parametrize(("inset", "strokes"), [(REACH, 1), (REACH + 2, 2)])
def test_a_join_runs_back_over_at_most_reach_cells(inset, strokes):
    # A short run below a long one, ``inset`` cells in from either end: joining them runs back
    # over ``inset`` cells of one of the two.
    on = np.zeros((2, 40), bool)
    on[0, 0:20] = True
    on[1, inset : 20 - inset] = True
    assert len(run_strokes(on, GRID)) == strokes


def test_ink_already_there_is_taken_from_the_cells_around_it():
    request = np.full(GRID.shape, 0.4)
    region = np.ones(GRID.shape, bool)
    given = np.zeros(GRID.shape)
    given[:, 28:32] = 1.0  # a contour down the middle, four cells wide
    plain, around = error_diffuse(request, region), error_diffuse(request, region, given)
    assert not around[:, 28:32].any()
    # The contour's ink is more than the tone asked there: the cells beside it get less.
    assert around[:, 20:28].sum() + around[:, 32:40].sum() < plain[:, 20:28].sum() + plain[:, 32:40].sum()


def _layout() -> Layout:
    return Layout.fit((120, 120), Page(80.0, 80.0, margin=10.0))


def test_face_runs_draw_a_grey_face_and_leave_a_white_one_blank():
    layout = _layout()
    face = np.zeros((120, 120), np.float32)
    face[30:90, 30:90] = 1.0
    grey = np.full((120, 120), 0.6, np.float32)
    runs = face_runs(grey, face, layout, Paths.empty(), pen_width=PEN, blank_below=0.04, paper=grey)
    assert len(runs)
    px = layout.mm_to_px(runs.points)
    assert np.all((px > 28) & (px < 92))  # inside the face only
    white = np.zeros((120, 120), np.float32)
    assert (
        len(face_runs(white, face, layout, Paths.empty(), pen_width=PEN, blank_below=0.04, paper=white)) == 0
    )


def test_shade_draws_a_dithered_face_as_runs_and_hatches_around_it():
    layout = _layout()
    face = np.zeros((120, 120), np.float32)
    face[30:90, 30:90] = 1.0
    grey = np.full((120, 120), 0.5, np.float32)
    layers = shade(grey, layout, Paths.empty(), pen_width=PEN, dithered=face, rounds=1)
    assert layers[-1].name == FACE_TONE and len(layers[-1].paths)
    hatching = Paths.concat(layer.paths for layer in layers[:-1])
    px = layout.mm_to_px(hatching.points)
    deep_inside = np.all((px > 36) & (px < 84), axis=1)
    assert len(hatching) and not deep_inside.any()  # the hatching leaves the face to the runs
    assert FACE_TONE not in [
        layer.name for layer in shade(grey, layout, Paths.empty(), pen_width=PEN, rounds=1)
    ]


def _row_gaps(runs: Paths) -> np.ndarray:
    """Distances (mm) between neighbouring rows the runs lie on."""
    rows = np.unique(np.round(runs.points[:, 1], 6))
    return np.diff(rows)


def test_a_faces_rows_are_a_pen_apart_and_spread_only_in_a_close_portrait():
    from pencilbot.planning.dither import CLOSER_SHARE, WIDE_PITCH, face_pitch

    layout = _layout()  # a 60 mm drawing of 120 px
    dark = np.full((120, 120), 0.9, np.float32)
    small = np.zeros((120, 120), np.float32)
    small[40:70, 40:70] = 1.0  # a sixteenth of the drawing
    runs = face_runs(dark, small, layout, Paths.empty(), pen_width=PEN, blank_below=0.04, paper=dark)
    # Rows one pen width apart: a light or mid tone's runs are short and close (at 1.2, scattered dashes).
    assert np.allclose(_row_gaps(runs), PEN, atol=1e-6)
    # A face over CLOSER_SHARE of the drawing (a close portrait) is drawn on rows WIDE_PITCH apart.
    close = np.zeros((120, 120), np.float32)
    close[10:110, 10:110] = 1.0
    assert face_pitch(0.05) == 1.0 and face_pitch(CLOSER_SHARE + 0.1) == WIDE_PITCH
    runs = face_runs(dark, close, layout, Paths.empty(), pen_width=PEN, blank_below=0.04, paper=dark)
    assert np.allclose(_row_gaps(runs), WIDE_PITCH * PEN, atol=1e-6)


def test_a_lighter_sheet_draws_the_same_skin_bare_and_the_rest_lighter():
    layout = Layout.fit((120, 120), Page(80.0, 80.0, margin=10.0))
    face = np.ones((120, 120), np.float32)
    ramp = np.repeat(np.linspace(0.0, 1.0, 120, dtype=np.float32)[None, :], 120, axis=0)  # light to dark
    grid = Grid(layout.drawing_box, PEN / 4)
    # (No price on a lift: at one, the search leaves bare what is too light to pay for its runs.)
    free = replace(LEVELS[0], lift=0.0, lightest=0.12)

    def columns(ink_scale: float) -> np.ndarray:
        runs = face_runs(
            ramp,
            face,
            layout,
            Paths.empty(),
            pen_width=PEN,
            blank_below=0.0,
            paper=ramp,
            ink_scale=ink_scale,
            level=free,
        )
        ink = ink_on_grid(runs, grid, PEN)
        return ink.mean(axis=0)  # light to dark

    full, half = columns(1.0), columns(0.5)
    darkness = np.linspace(0.0, 1.0, full.size)
    below, above = darkness < free.lightest - 0.02, (darkness > free.lightest + 0.05) & (darkness < 0.3)
    assert full[below].max() == half[below].max() == 0.0  # the lightest skin bare either way ...
    assert full[above].mean() > 0.04 and half[above].mean() > 0.02  # ... and no more of it
    bands, halves = full.reshape(12, -1).mean(axis=1), half.reshape(12, -1).mean(axis=1)
    assert np.all(np.diff(halves[2:]) > 0)  # the order of tones kept
    assert halves[-4:].mean() == pytest.approx(0.5 * bands[-4:].mean(), rel=0.15)


def _diffused_cell_by_cell(request, region, given, pen, run_bias):
    """error_diffuse as it is defined: one cell after another, row by row (the reference the
    wave-by-wave diffusion must equal bit for bit)."""
    rows, cols = request.shape
    want = np.where(region, np.clip(request, 0.0, 1.0), 0.0)
    given = np.zeros((rows, cols)) if given is None else np.clip(given, 0.0, 1.0)
    on = np.zeros((rows, cols), bool)
    below = np.zeros(cols + 2)
    for r in range(rows):
        values, base, inside = (want[r] + below[1:-1]).tolist(), given[r].tolist(), region[r].tolist()
        errors = [0.0] * cols
        ahead, previous = 0.0, False
        for c in range(cols):
            if not inside[c]:
                ahead, previous = 0.0, False
                continue
            value = values[c] + ahead
            ink = 1.0 - (1.0 - (pen if previous else CAP * pen * pen)) * (1.0 - base[c])
            previous = value > (ink + base[c]) / 2 - (run_bias if previous else -run_bias)
            on[r, c] = previous
            errors[c] = value - (ink if previous else base[c])
            ahead = errors[c] * 7 / 16
        error = np.asarray(errors)
        below = np.zeros(cols + 2)
        below[:-2] += error * 3 / 16
        below[1:-1] += error * 5 / 16
        below[2:] += error * 1 / 16
    return on


@settings(max_examples=150, deadline=None)
@given(
    shape=st.tuples(st.integers(1, 30), st.integers(1, 30)),
    seed=st.integers(0, 2**32 - 1),
    share=st.floats(0.0, 1.0),
    with_given=st.booleans(),
    pen=st.sampled_from([1.0, 1 / 1.2, 0.9]),
    bias=st.sampled_from([0.0, 0.2, 0.3, 0.4]),
    single=st.booleans(),
)
def test_the_waves_diffuse_as_cell_after_cell(shape, seed, share, with_given, pen, bias, single):
    rng = np.random.default_rng(seed)
    request = rng.random(shape).astype(np.float32 if single else np.float64)
    region = rng.random(shape) < share
    given_ink = (rng.random(shape) * rng.random()).astype(np.float32) if with_given else None
    expected = _diffused_cell_by_cell(request, region, given_ink, pen, bias)
    assert np.array_equal(error_diffuse(request, region, given_ink, pen=pen, run_bias=bias), expected)
