"""Hatching: families of lines that follow the form, whose rendered ink matches the tone."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy import ndimage as ndi

from pencilbot.paths import Paths
from pencilbot.planning.flow import Grid, direction_field
from pencilbot.planning.hatching import HATCH_COVERAGE, hatch_layers, trace_families
from pencilbot.planning.layout import Layout
from pencilbot.planning.onset import Onset
from pencilbot.planning.plan import Page
from pencilbot.planning.shading import shade
from pencilbot.render import render_paths


def _layout(shape=(100, 100), mm_per_px=0.5):
    h, w = shape
    return Layout.fit(shape, Page(width=w * mm_per_px + 20, height=h * mm_per_px + 20, margin=10))


def _coverage(layers, layout, pen, inset=6.0):
    """Mean ink of the layers drawn by the real rasteriser, away from the drawing's border."""
    x0, y0, x1, y1 = layout.drawing_box
    paths = [p for layer in layers for p in layer.paths]
    dark = render_paths(paths, x1 - x0, y1 - y0, dpi=254, pen_width=pen, origin=(x0, y0))
    cut = int(inset / 0.1)
    return float(dark[cut:-cut, cut:-cut].mean())


@pytest.mark.parametrize("pen", [0.3, 0.5, 0.8])
def test_a_uniform_patch_is_covered_as_dark_as_asked(pen):
    layout = _layout((120, 120))
    measured = []
    for darkness in (0.1, 0.3, 0.5, 0.7, 0.9):
        layers = shade(np.full((120, 120), darkness), layout, Paths.empty(), pen_width=pen)
        measured.append(_coverage(layers, layout, pen))
        assert measured[-1] == pytest.approx(darkness, abs=0.03)
    assert np.all(np.diff(measured) > 0)


def test_white_paper_gets_no_hatching():
    layout = _layout((60, 80))
    assert not any(layer.paths for layer in shade(np.zeros((60, 80)), layout, Paths.empty()))
    faint = np.full((60, 80), 0.015)
    assert not any(layer.paths for layer in shade(faint, layout, Paths.empty(), blank_below=0.02))


def test_hatching_runs_along_the_isophotes_of_a_radial_gradient():
    # Darkness grows with the distance from the centre: its isophotes are circles, so the first
    # family must run around the centre, at right angles to the radius, wherever it is drawn.
    n = 160
    rows, cols = np.mgrid[0:n, 0:n]
    radius = np.hypot(rows - n / 2, cols - n / 2)
    darkness = np.clip(0.15 + 0.6 * radius / (n / 2), 0, 0.9)
    layout = _layout((n, n))
    layers = shade(darkness, layout, Paths.empty(), pen_width=0.5)
    centre = np.array(
        [
            (layout.drawing_box[0] + layout.drawing_box[2]) / 2,
            (layout.drawing_box[1] + layout.drawing_box[3]) / 2,
        ]
    )
    pts = np.concatenate([p for p in layers[0].paths if len(p) > 1])
    segments = [np.diff(p, axis=0) for p in layers[0].paths if len(p) > 1]
    mids = np.concatenate([(p[1:] + p[:-1]) / 2 for p in layers[0].paths if len(p) > 1])
    steps = np.concatenate(segments)
    radial = mids - centre
    far = np.linalg.norm(radial, axis=1) > 8.0  # the centre is a singularity of any field
    cos = np.abs(np.einsum("ij,ij->i", steps[far], radial[far])) / (
        np.linalg.norm(steps[far], axis=1) * np.linalg.norm(radial[far], axis=1)
    )
    assert pts.size and far.sum() > 200
    assert np.median(cos) < 0.15  # tangential, not ruled at one angle
    # Radial cross-hatching has no single-valued phase (see stripe_phase): the other families
    # bend, but together they still deliver the dark outer ring.
    x0, y0, x1, y1 = layout.drawing_box
    ink = render_paths(
        [p for layer in layers for p in layer.paths],
        x1 - x0,
        y1 - y0,
        dpi=127,
        pen_width=0.5,
        origin=(x0, y0),
    )
    rr, cc = np.mgrid[0 : ink.shape[0], 0 : ink.shape[1]]
    ring = (
        np.abs(np.hypot(rr - ink.shape[0] / 2, cc - ink.shape[1] / 2) - 0.85 * ink.shape[0] / 2)
        < 0.05 * ink.shape[0]
    )
    assert ink[ring].mean() == pytest.approx(0.15 + 0.6 * 0.85, abs=0.06)


def test_a_straight_gradient_is_hatched_along_its_isophotes_and_flat_tone_at_the_default():
    n = 120
    ramp = np.tile(np.linspace(0.2, 0.8, n), (n, 1))  # dark to the right: isophotes vertical
    layout = _layout((n, n))
    field_grid = Grid(layout.drawing_box, 2.0)
    from pencilbot.planning.flow import sample_image

    field = direction_field(sample_image(ramp, layout, field_grid), field_grid)
    d = field.direction.reshape(-1, 2)
    assert np.median(np.abs(d[:, 1])) > 0.95  # vertical
    flat = direction_field(np.full(field_grid.shape, 0.4), field_grid)
    angles = np.degrees(np.arctan2(flat.direction[..., 1], flat.direction[..., 0])) % 180
    assert np.allclose(angles, 45.0, atol=1.0)


def test_onset_is_continuous_monotone_and_exactly_inverted():
    onset = Onset.spread(4, 0.6, overlap=0.5)
    u = np.linspace(0, 1, 2001)
    total = onset.darkness(u)
    assert np.all(np.diff(total) >= -1e-12)
    assert np.max(np.abs(np.diff(total))) < 0.01  # no jump: cross-hatching fades in
    wanted = np.linspace(0, onset.darkest, 50)
    assert onset.darkness(onset.amount(wanted)) == pytest.approx(wanted, abs=1e-3)
    shares = onset.coverages(onset.amount(np.array([0.2, 0.5, 0.9])))
    # A light tone uses mostly the first family; the darkest uses every family.
    assert shares[0, 0] > 0 and shares[3, 0] == 0
    assert np.all(shares[:, 2] > 0)
    # Overlapping ramps: the second family starts before the first is full.
    first_full = u[np.argmax(onset.coverages(u)[0] >= 0.6 - 1e-12)]
    second_on = u[np.argmax(onset.coverages(u)[1] > 0)]
    assert second_on < first_full


def test_later_families_are_drawn_only_where_the_tone_needs_them():
    dark = np.full((100, 100), 0.2)
    dark[:, 50:] = 0.85
    layout = _layout()
    layers = shade(dark, layout, Paths.empty())
    x_mid = (layout.drawing_box[0] + layout.drawing_box[2]) / 2
    assert any(p[:, 0].max() < x_mid - 2 for p in layers[0].paths), "the light half gets the first family"
    for layer in layers[2:]:
        pts = np.concatenate(layer.paths)
        assert pts[:, 0].min() >= x_mid - 3.0


def test_a_pale_hatching_leaves_the_palest_tones_paper_and_draws_the_rest_alike():
    layout = _layout((100, 100))
    tone = np.full((100, 100), 0.05, np.float32)
    tone[:, 50:] = 0.3  # a pale half and a mid-grey half
    full = shade(tone, layout, Paths.empty(), pen_width=0.5)
    pale = shade(tone, layout, Paths.empty(), pen_width=0.5, pale=0.08)
    halves = [_half_ink(layers, layout) for layers in (full, pale)]
    assert halves[0][0] > 0.02 and halves[1][0] < 0.005  # the pale half's dashes left out
    assert halves[1][1] == pytest.approx(halves[0][1], abs=0.03)  # the grey half as it was


def _half_ink(layers, layout, inset=6.0) -> tuple[float, float]:
    """Mean ink of the left and right halves, away from the border and from the edge between them."""
    x0, y0, x1, y1 = layout.drawing_box
    paths = [p for layer in layers for p in layer.paths]
    dark = render_paths(paths, x1 - x0, y1 - y0, dpi=254, pen_width=0.5, origin=(x0, y0))
    cut, middle = int(inset / 0.1), dark.shape[1] // 2
    return float(dark[cut:-cut, cut : middle - cut].mean()), float(dark[cut:-cut, middle + cut : -cut].mean())


def test_light_tones_are_dashed_lines_not_scratches_far_apart():
    layout = _layout((100, 100))
    # Just above BLANK_BELOW (0.04 itself sits on the threshold in float32 after the blur).
    layers = shade(np.full((100, 100), 0.05), layout, Paths.empty(), pen_width=0.5)
    paths = [p for layer in layers for p in layer.paths]
    assert paths
    # Neighbouring drawn lines stay within a few mm of each other (MAX_GAP), and each is dashed.
    lengths = np.array([np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in paths])
    assert np.median(lengths) < 15.0
    assert _coverage(layers, layout, 0.5) == pytest.approx(0.05, abs=0.02)


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    pen=st.sampled_from([0.3, 0.5, 0.7]),
    angles=st.lists(st.floats(-90, 90), min_size=1, max_size=4, unique=True),
    min_run=st.floats(1.0, 5.0),
)
# A line through a random field that turns back within one stroke: long enough along the
# line, a 2 mm hook on paper.
@example(seed=269, pen=0.3, angles=[8.0], min_run=3.0)
def test_strokes_stay_in_the_picture_and_are_never_crumbs(seed, pen, angles, min_run):
    rng = np.random.default_rng(seed)
    layout = _layout((70, 90))
    darkness = rng.random((70, 90))
    grid = Grid(layout.drawing_box, 0.5)
    field_grid = Grid(layout.drawing_box, 2.0)
    field = direction_field(rng.random(field_grid.shape), field_grid)
    lines = trace_families(field, pen_width=pen, angles=tuple(angles), coverage=0.6)
    from pencilbot.planning.flow import sample_image

    layers = hatch_layers(
        sample_image(darkness, layout, grid),
        grid,
        field,
        pen_width=pen,
        angles=tuple(angles),
        min_run=min_run,
        lines=lines,
    )
    x0, y0, x1, y1 = layout.drawing_box
    for layer in layers:
        for p in layer.paths:
            assert p.shape[1] == 2 and len(p) >= 2
            assert np.all(p[:, 0] >= x0 - 1e-6) and np.all(p[:, 0] <= x1 + 1e-6)
            assert np.all(p[:, 1] >= y0 - 1e-6) and np.all(p[:, 1] <= y1 + 1e-6)
            assert np.linalg.norm(np.diff(p, axis=0), axis=1).sum() >= min_run - 0.5


def test_what_a_capped_family_cannot_lay_down_the_others_do():
    onset = Onset.spread(4, 0.6, overlap=0.25)
    darkness = np.array([0.2, 0.5, 0.8, 0.0])
    free = onset.allocate(darkness, np.ones((4, 4)))
    np.testing.assert_allclose(free, onset.coverages(onset.amount(darkness)), atol=1e-3)
    capped = np.ones((4, 4))
    capped[0] = 0.3  # the first family's lines spread out: it covers at most 0.3
    shares = onset.allocate(darkness, capped)
    assert np.all(shares[0] <= 0.3 + 1e-12)
    total = 1 - np.prod(1 - shares, axis=0)
    np.testing.assert_allclose(total, darkness, atol=1e-3)
    assert np.all(shares[:, 3] == 0)


@pytest.mark.parametrize("min_run", [2.0, 2.2, 3.1, 4.0])
def test_the_shortest_stroke_is_min_run_to_a_fraction_of_the_sample_step(min_run, monkeypatch):
    # Each stroke's length along its line, from the family's own arc lengths: the bound is
    # checked far tighter than one sample step (0.4 mm), the size of an off-by-one in counting
    # a run's samples (a polyline through every fourth sample would cut the traced line's wiggles).
    # The lines are not spread (pencilbot.planning.spread), so a stroke's ends are samples.
    from pencilbot.planning import spread
    from pencilbot.planning.flow import sample_image

    monkeypatch.setattr(spread, "STEP", 0.0)
    from pencilbot.planning.hatching import SAMPLE_STEP, family_lines, hatch_strokes

    layout = _layout((100, 100))
    field_grid = Grid(layout.drawing_box, 2.0)
    field = direction_field(np.full(field_grid.shape, 0.4), field_grid)
    family = family_lines(field, pen_width=0.5, coverage=0.6)
    grid = Grid(layout.drawing_box, 0.5)
    request = sample_image(np.random.default_rng(3).random((100, 100)) * 0.6, layout, grid)
    strokes = hatch_strokes(family, grid.sample(request, family.points), pen_width=0.5, min_run=min_run)
    where = {tuple(p): i for i, p in enumerate(family.points)}
    ends = np.array([(where[tuple(p[0])], where[tuple(p[-1])]) for p in strokes])
    assert np.all(family.line[ends[:, 0]] == family.line[ends[:, 1]])
    lengths = family.along[ends[:, 1]] - family.along[ends[:, 0]]
    assert len(lengths) > 50
    assert lengths.min() >= min_run - 1e-6
    # Runs just long enough are kept: the shortest stroke is the fewest sample steps that reach it.
    assert lengths.min() == pytest.approx(np.ceil(min_run / SAMPLE_STEP - 1e-9) * SAMPLE_STEP, abs=1e-6)


def test_each_round_of_the_tone_loop_brings_the_drawn_tone_closer():
    # A ramp with a pale square and a contour: what the ideal dither cannot know (dropped
    # crumbs, crowding, a contour's own ink) leaves an error the loop must shrink, round by round.
    from pencilbot.planning.dither import ink_on_grid
    from pencilbot.planning.flow import gaussian, sample_image
    from pencilbot.planning.shading import CORRECTION_BLUR

    n = 100
    layout = _layout((n, n))
    dark = np.tile(np.clip(0.1 + 0.8 * np.arange(n) / n, 0, 1), (n, 1))
    dark[30:70, 30:70] = 0.15
    edges = Paths.of([[[25.0, 25.0], [45.0, 25.0], [45.0, 45.0]]])
    # Judged on the loop's own cells, which no two neighbouring lines share (ink of separate
    # lines in one cell stacks as 1 − Π(1 − c) and would be undercounted).
    grid = Grid(layout.drawing_box, min(0.5, 0.5 / HATCH_COVERAGE / 2))
    sigma = 1.0 / grid.cell  # the loop's own judging scale: the default blur, 1 mm
    goal = gaussian(sample_image(dark, layout, grid), sigma)
    edge_ink = ink_on_grid(edges, grid, 0.5)

    def tone_error(rounds):
        layers = shade(dark, layout, edges, rounds=rounds)
        hatch_ink = ink_on_grid(Paths.concat(layer.paths for layer in layers), grid, 0.5)
        seen = gaussian(1.0 - (1.0 - edge_ink) * (1.0 - hatch_ink), sigma)
        # At the scale the loop corrects: finer, what is left is the lines' own pattern (spread
        # lines leave less of it, and a correction then only moves dashes about).
        error = gaussian(seen - goal, CORRECTION_BLUR / grid.cell)
        return float(np.abs(error)[8:-8, 8:-8].mean())

    uncorrected, once, twice = tone_error(1), tone_error(2), tone_error(3)
    # The first correction takes out most of the bias the ideal dither leaves (a correction of
    # the wrong sign or size would add error instead); the second keeps it out.
    assert once < 0.75 * uncorrected and twice < 0.75 * uncorrected


@pytest.mark.parametrize("coverage", [0.0, 1.0, 1.5, -0.2])
def test_a_family_coverage_outside_zero_to_one_is_refused(coverage):
    layout = _layout((40, 40))
    grid = Grid(layout.drawing_box, 0.5)
    field = direction_field(np.full(Grid(layout.drawing_box, 2.0).shape, 0.4), Grid(layout.drawing_box, 2.0))
    with pytest.raises(ValueError, match=r"coverage must be in \(0, 1\)"):
        hatch_layers(np.full(grid.shape, 0.5), grid, field, coverage=coverage)


def test_a_tall_picture_on_a_wide_sheet_is_hatched_to_its_bottom_edge():
    # The drawing box starts further in across (x0) than up (y0): hatching must still reach the
    # box's bottom, not stop where y reaches x0.
    layout = Layout.fit((100, 30), Page(width=150, height=80, margin=10))
    x0, y0, x1, y1 = layout.drawing_box
    assert x0 > y0 + 20
    layers = shade(np.full((100, 30), 0.5), layout, Paths.empty(), pen_width=0.5)
    points = np.concatenate([p for layer in layers for p in layer.paths])
    assert points[:, 1].min() < y0 + 3.0 and points[:, 1].max() > y1 - 3.0
    assert points[:, 0].min() >= x0 - 1e-6 and points[:, 0].max() <= x1 + 1e-6


def test_the_first_request_leaves_out_the_ink_a_contour_lays():
    # No correction round: the hatching's request alone must already count a contour in the
    # tone, laying less ink along it than where there is no contour.
    from pencilbot.planning.dither import ink_on_grid

    n = 100
    layout = _layout((n, n))
    x0, y0, _x1, y1 = layout.drawing_box
    ym = (y0 + y1) / 2
    edges = Paths.of([[x0 + 5 + k * 0.5, ym - 10.0], [x0 + 5 + k * 0.5, ym + 10.0]] for k in range(8))
    dark = np.full((n, n), 0.5)
    grid = Grid(layout.drawing_box, 0.5)
    band = ink_on_grid(edges, grid, 0.5) > 0.5  # cells the contours cover
    assert band.sum() > 100

    def hatch_ink(with_edges):
        layers = shade(dark, layout, edges if with_edges else Paths.empty(), rounds=1)
        return ink_on_grid(Paths.concat(layer.paths for layer in layers), grid, 0.5)[band].mean()

    assert hatch_ink(True) < 0.5 * hatch_ink(False)


def test_a_gap_shorter_than_half_the_shortest_stroke_is_bridged():
    # One straight line sampled every SAMPLE_STEP, asking for ink everywhere but a short stretch:
    # along-line smoothing leaves 2 samples off (a 0.8 mm gap), under half of min_run (1 mm), so
    # the line is drawn through; a longer gap splits it.
    from pencilbot.planning.hatching import SAMPLE_STEP, HatchLines, hatch_strokes

    n = 30
    lines = HatchLines(
        np.column_stack([np.arange(n) * SAMPLE_STEP, np.zeros(n)]),
        np.zeros(n, np.int64),
        np.zeros(n, np.int64),
        np.arange(n) * SAMPLE_STEP,
        np.ones(n),
        np.zeros((1, 1)),
        np.tile([0.0, 1.0], (n, 1)),
    )

    def strokes_with_gap(first, last):
        request = np.ones(n)
        request[first : last + 1] = 0.0
        return hatch_strokes(lines, request, pen_width=0.5, min_run=2.0)

    bridged = strokes_with_gap(3, 8)
    assert (
        len(bridged) == 1
        and bridged[0][0, 0] == 0.0
        and bridged[0][-1, 0] == pytest.approx((n - 1) * SAMPLE_STEP)
    )
    split = strokes_with_gap(12, 18)  # 3 samples off: 1.2 mm, not bridged
    assert len(split) == 2


def test_tone_that_changes_over_a_few_millimetres_is_followed_at_that_scale():
    # Bands 4 mm wide, 0.25 and 0.75 dark (a painting's brush strokes): the loop corrects at
    # SHARP_CORRECTION_BLUR there, so the bands stay apart on paper (contrast 0.27 at 1 mm);
    # with the 2 mm correction alone they run into each other (0.19, measured).
    layout = _layout((160, 160))
    tone = np.where((np.arange(160) // 8) % 2 == 0, 0.25, 0.75).astype(np.float32)
    layers = shade(np.tile(tone, (160, 1)), layout, [], pen_width=0.5)
    x0, y0, x1, y1 = layout.drawing_box
    ink = render_paths(
        [p for layer in layers for p in layer.paths],
        x1 - x0,
        y1 - y0,
        dpi=254,
        pen_width=0.5,
        origin=(x0, y0),
    )
    across = ndi.gaussian_filter(ink, 10).mean(axis=0)[60:-60]  # 1 mm blur, away from the sides
    dark = np.repeat(tone, 5)[60:-60] > 0.5
    assert across[dark].mean() - across[~dark].mean() > 0.24
