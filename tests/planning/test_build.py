"""make_plan: photo → ordered layers on a page, and the drawing styles that parametrise it."""

import dataclasses

import cv2
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from PIL import Image
from scipy import ndimage as ndi
from skimage import data
from skimage.draw import disk
from skimage.transform import resize

from pencilbot.errors import ProfileError
from pencilbot.imaging.io import image_from_array, load_image
from pencilbot.imaging.pencil import sketch
from pencilbot.paths import Paths
from pencilbot.planning import plot_budget, spread
from pencilbot.planning.build import make_plan, plan_from_sketch, sketch_and_plan
from pencilbot.planning.fidelity import plotted_darkness
from pencilbot.planning.hatching import POINT_SPACING
from pencilbot.planning.layout import Layout, ink_on_image_grid, page_size
from pencilbot.planning.resolution import at_plot_resolution, plot_resolution, plot_shape
from pencilbot.planning.style import Style, list_styles, load_style, with_overrides
from pencilbot.planning.vectorize import edge_strokes

FAST = Style(order_rounds=4)


def _length(paths):
    return sum(float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) for p in paths)


@pytest.fixture(scope="module")
def camera():
    gray = resize(data.camera(), (160, 160), anti_aliasing=True)
    return image_from_array((gray * 255).astype(np.uint8), source="camera-160")


@pytest.fixture(scope="module")
def camera_plan(camera):
    return make_plan(camera, style=FAST)


def test_layers_go_light_hatching_first_edges_last(camera_plan):
    names = [layer.name for layer in camera_plan.layers]
    assert names[-1] == "edges"
    # The cameraman's face (MTCNN finds it, even at 160 px) is drawn in runs, after the hatching.
    assert camera_plan.meta["faces"] != "none" and names[-2] == "face-tone"
    names = names[:-2] + names[-1:]
    assert names[:-1] and all(name.startswith("hatch") for name in names[:-1])
    assert names[:-1] == sorted(names[:-1])  # hatch1 (lightest tones) before hatch2 ...
    assert all(layer.paths for layer in camera_plan.layers)
    assert [layer.role for layer in camera_plan.layers] == ["hatch"] * len(names) + ["edges"]


def test_everything_lies_inside_the_page_margins(camera_plan):
    page = camera_plan.page
    assert (page.width, page.height, page.margin) == (210, 297, 15)
    pts = np.concatenate(camera_plan.paths())
    assert pts[:, 0].min() >= page.margin - 1e-9 and pts[:, 0].max() <= page.width - page.margin + 1e-9
    assert pts[:, 1].min() >= page.margin - 1e-9 and pts[:, 1].max() <= page.height - page.margin + 1e-9


def test_meta_records_the_source_and_parameters(camera_plan):
    meta = camera_plan.meta
    assert meta["source"] == "camera-160"
    assert meta["style"] == "default"
    assert meta["pen_width_mm"] == "0.5"
    assert meta["line_length_px"] == str(sketch(image_from_array(np.zeros((160, 160)))).line.length)
    assert float(meta["edge_threshold"]) > 0
    assert all(isinstance(v, str) for v in meta.values())


def test_ordering_keeps_every_edge_stroke(camera):
    drawing = sketch(camera)
    page = page_size("A4", "portrait")
    # Without faces: the cameraman's face would change the edges there (finer, and left to the runs).
    plan = plan_from_sketch(drawing, page, Style(order_rounds=4, faces=False))
    layout = Layout.fit(camera.shape, page)
    assert plan.meta["faces"] == "off"
    raw = edge_strokes(
        drawing.line,
        layout,
        threshold=float(plan.meta["edge_threshold"]),
        clutter=FAST.edge_clutter,
        max_lines=FAST.edge_lines,
        budget=FAST.edge_budget / 100,
    )
    ordered = plan.layer("edges").paths
    # Ordering only reverses and joins: ink length is kept up to the joins' short bridges
    # (each at most a pen width).
    assert len(ordered) <= len(raw)
    bridge = FAST.pen_width  # edges are chained already; ordering joins only touching ends
    bridges = (len(raw) - len(ordered)) * bridge
    assert _length(raw) - 1e-6 <= _length(ordered) <= _length(raw) + bridges + 1e-6
    assert _segments(raw) <= _segments(ordered)  # every stroke is still drawn, maybe reversed


def _segments(paths):
    """Each segment as an orientation-free pair of rounded end points."""
    out = set()
    for p in paths:
        for a, b in zip(p[:-1].round(6).tolist(), p[1:].round(6).tolist(), strict=True):
            out.add(tuple(sorted((tuple(a), tuple(b)))))
    return out


def test_a_draft_is_the_plan_unordered_and_unjoined(camera, monkeypatch):
    # A draft (the studio's first preview) is only looked at: the same strokes as the plan of
    # the same sketch, in the order they were made, no path ordered or joined.
    from pencilbot.planning import build

    drawing = sketch(camera)
    page = page_size("A5", "portrait")
    ordered = []
    real = build.order_paths
    monkeypatch.setattr(build, "order_paths", lambda *a, **k: ordered.append(1) or real(*a, **k))
    draft = plan_from_sketch(drawing, page, FAST, draft=True)
    assert ordered == [] and draft.meta["draft"]
    plan = plan_from_sketch(drawing, page, FAST)
    assert ordered and "draft" not in plan.meta  # (the spy sees the plan's ordering)
    assert [layer.name for layer in draft.layers] == [layer.name for layer in plan.layers]
    for rough, done in zip(draft.layers, plan.layers, strict=True):
        assert len(rough.paths) >= len(done.paths)  # none joined
        assert _segments(rough.paths) <= _segments(done.paths)  # every stroke the plan draws
        bridges = (len(rough.paths) - len(done.paths)) * max(FAST.pen_width, FAST.hatch_join)
        assert _length(rough.paths) - 1e-9 <= _length(done.paths) <= _length(rough.paths) + bridges + 1e-6


def test_a_plan_is_reproducible(camera):
    # default style: path ordering improves for a fixed number of rounds, never by the clock
    a, b = make_plan(camera), make_plan(camera)
    assert [layer.name for layer in a.layers] == [layer.name for layer in b.layers]
    for la, lb in zip(a.layers, b.layers, strict=True):
        assert len(la.paths) == len(lb.paths)
        assert all(np.array_equal(p, q) for p, q in zip(la.paths, lb.paths, strict=True))


def test_hatching_follows_the_tone():
    # Dark disc on light paper: the hatch ink sits in the disc.
    gray = np.full((120, 120), 0.92, np.float32)
    gray[disk((60, 60), 35)] = 0.25
    image = image_from_array((gray * 255).astype(np.uint8), source="disc")
    plan = make_plan(image, page=page_size("100x100", margin=5), style=FAST)
    layout = Layout.fit(image.shape, plan.page)
    hatch = Paths.concat(layer.paths for layer in plan.layers if layer.role != "edges")
    ink = ink_on_image_grid(hatch, layout, pen_width=FAST.pen_width)
    inside = np.zeros(gray.shape, bool)
    inside[disk((60, 60), 28)] = True
    outside = np.ones(gray.shape, bool)
    outside[disk((60, 60), 45)] = False
    assert ink[inside].mean() > 0.3
    assert ink[inside].mean() > 4 * ink[outside].mean()


def test_the_tone_is_kept_up_to_the_contours():
    # A dark disc on a light ground: its outline is drawn, and the shading inside must reach the
    # outline instead of leaving a pale halo where edge ink was counted as tone.
    gray = np.full((160, 160), 0.85, np.float32)
    gray[disk((80, 80), 55)] = 0.3
    drawing, plan = sketch_and_plan(image_from_array(gray, source="disc"), style=FAST)
    layout = Layout.fit(drawing.tone.shape, plan.page)
    px_per_mm = 5.0  # finer than the pen: the image grid (1.1 mm) would merge neighbouring lines
    ink = plotted_darkness(plan.paths(), layout.drawing_box, pen_width=FAST.pen_width, px_per_mm=px_per_mm)
    tone = cv2.resize(1.0 - drawing.tone, ink.shape[::-1], interpolation=cv2.INTER_NEAREST)
    ink, tone = (ndi.gaussian_filter(a, px_per_mm) for a in (ink, tone))  # σ = 1 mm
    rows, cols = np.mgrid[0 : ink.shape[0], 0 : ink.shape[1]]
    depth = 55 * layout.mm_per_px - np.hypot(rows - ink.shape[0] / 2, cols - ink.shape[1] / 2) / px_per_mm
    rim, core = (depth > 1) & (depth < 3), depth > 15  # mm inside the outline
    assert plan.paths("edges").points.size
    assert ink[core].mean() == pytest.approx(tone[core].mean(), abs=0.03)
    assert ink[rim].mean() == pytest.approx(tone[rim].mean(), abs=0.05)


def test_outline_style_draws_edges_only(camera):
    plan = make_plan(camera, style="outline")
    assert [layer.name for layer in plan.layers] == ["edges"]
    assert plan.meta["style"] == "outline"


def test_auto_orientation_turns_the_page_for_a_wide_photo():
    wide = image_from_array(np.tile(np.linspace(0, 1, 200), (80, 1)).astype(np.float32), source="ramp")
    plan = make_plan(wide, style=Style(orientation="auto", order_rounds=0))
    assert plan.page.width > plan.page.height


def test_shipped_styles_load_and_default_matches_the_dataclass():
    assert {"default", "outline"} <= set(list_styles())
    default = load_style("default")
    assert dataclasses.replace(default, name="x") == dataclasses.replace(Style(), name="x")


def test_a_style_file_overrides_only_what_it_names(tmp_path):
    path = tmp_path / "fine.toml"
    path.write_text('pen_width = 0.3\nhatch_angles = [30, 120]\npage = "A3"\n')
    style = load_style(path)
    assert (style.name, style.pen_width, style.hatch_angles, style.page) == ("fine", 0.3, (30.0, 120.0), "A3")
    assert style.margin == Style().margin


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("pen_widht = 0.3\n", ["bad.toml", "pen_widht"]),
        ("pen_width = -1\n", ["bad.toml", "pen_width"]),
        ("hatch_angles = 45\n", ["bad.toml", "hatch_angles"]),
        ("orientation = 'sideways'\n", ["bad.toml", "orientation"]),
        ("hatch_coverage = 1.0\n", ["bad.toml", "hatch_coverage"]),
        ("pen_width = \n", ["bad.toml", "TOML"]),
        ("pen_width = nan\n", ["bad.toml", "pen_width"]),
        ("pen_width = 0.001\n", ["bad.toml", "pen_width", "≥ 0.05"]),
        ("margin = inf\n", ["bad.toml", "margin"]),
        ("hatch_blur = nan\n", ["bad.toml", "hatch_blur"]),
        ("line_length = 100000\n", ["bad.toml", "line_length"]),
        ("stroke_gamma = 0\n", ["bad.toml", "stroke_gamma", "0.1", "10"]),
        ("stroke_width = 50\n", ["bad.toml", "stroke_width", "0.5", "20"]),
        ("texture = 3\n", ["bad.toml", "texture", "path"]),
        ("texture = ''\n", ["bad.toml", "texture"]),
        ("edge_clutter = 0\n", ["bad.toml", "edge_clutter"]),
        ("edge_clutter = nan\n", ["bad.toml", "edge_clutter"]),
        ("edge_clutter = inf\n", ["bad.toml", "edge_clutter"]),
    ],
)
def test_a_bad_style_file_names_the_file_and_the_key(tmp_path, text, words):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ProfileError) as err:
        load_style(path)
    assert all(word in str(err.value) for word in words)
    assert "\n" not in str(err.value)


def test_style_stroke_and_texture_keys_reach_the_drawing(camera, tmp_path):
    from PIL import Image

    folder = tmp_path / "styles"
    folder.mkdir()
    paper = np.full((64, 64), 230, np.uint8)
    paper[::5] = 90  # a ruled "hatching" scan
    Image.fromarray(paper).save(folder / "ruled.png")
    (folder / "mine.toml").write_text(
        'texture = "ruled.png"\nstroke_gamma = 3.0\nstroke_width = 2.0\norder_rounds = 4\n'
    )
    style = load_style(folder / "mine.toml")
    assert style.texture == str(folder / "ruled.png")  # relative to the style file, not the cwd
    assert (style.stroke_gamma, style.stroke_width) == (3.0, 2.0)
    drawing, plan = sketch_and_plan(camera, style=style)
    plain_drawing, plain = sketch_and_plan(camera, style=FAST)
    assert (drawing.line.gamma, plan.meta["texture"], plan.meta["stroke_gamma"]) == (3.0, style.texture, "3")
    assert np.abs(drawing.texture - plain_drawing.texture).mean() > 0.02
    # Darker, wider raster strokes: the pen draws fainter contours too, with more ink.
    assert float(plan.meta["edge_threshold"]) < float(plain.meta["edge_threshold"])
    assert _length(plan.layer("edges").paths) > 1.1 * _length(plain.layer("edges").paths)


def test_unknown_style_names_the_choices():
    with pytest.raises(ProfileError, match="default"):
        load_style("no-such-style")
    with pytest.raises(ProfileError, match="cannot read"):
        load_style("/no/such/dir/style.toml")


def test_overrides_are_checked_like_file_values():
    assert with_overrides(Style(), {"pen_width": 0.7}).pen_width == 0.7
    with pytest.raises(ProfileError, match="command line.*pen_width"):
        with_overrides(Style(), {"pen_width": 0})
    with pytest.raises(ProfileError, match="unknown key 'colour'"):
        with_overrides(Style(), {"colour": "red"})


def test_neighbouring_hatch_runs_are_joined_pen_down(monkeypatch):
    # Unjoined, the disc's runs are past the plot's budget (their lifts), which would draw that
    # plan's hatching lighter: the two plans compared here hatch the same tone.
    monkeypatch.setattr(plot_budget, "PLOT_BUDGET", float("inf"))
    monkeypatch.setattr(plot_budget, "TRAVEL_BUDGET", float("inf"))
    # Lines not spread across their gaps (pencilbot.planning.spread bends them a little): a run's
    # kept points are then exactly a sample spacing apart, and a longer step is a hop.
    monkeypatch.setattr(spread, "STEP", 0.0)
    # A dark disc: hatched line after line, so serpentine hops between neighbours are short.
    gray = np.full((120, 120), 0.92, np.float32)
    gray[disk((60, 60), 40)] = 0.02
    drawing = sketch(image_from_array((gray * 255).astype(np.uint8), source="disc"))
    page = page_size("100x100", margin=5)
    apart = plan_from_sketch(drawing, page, Style(hatch_join=0.0, order_rounds=0))
    joined = plan_from_sketch(drawing, page, Style(hatch_join=2.0, order_rounds=0))
    names = [layer.name for layer in apart.layers if layer.role != "edges"]
    assert names
    for name in names:  # hatch1 covers the disc; the few runs of later layers rarely meet
        before, after = apart.layer(name).paths, joined.layer(name).paths
        # Not joined, a path is one hatch run: points a sample spacing apart, no hop.
        assert all(np.linalg.norm(np.diff(p, axis=0), axis=1).max() <= POINT_SPACING + 0.05 for p in before)
        if name == names[0]:
            assert len(after) <= 0.95 * len(before)  # lifts saved (long runs only: dashes stay apart)
        # Each join adds one connecting move no longer than the tolerance.
        added = _length(after) - _length(before)
        assert -1e-6 <= added <= (len(before) - len(after)) * 2.0 + 1e-6


# A fine pen on a big sheet is the costly plan (13 s at 0.2 mm on A4, 1 s at 1 mm): the drawn
# examples take pens from 0.5 mm, and the finest pen is checked on every page shape by hand.
@settings(max_examples=6, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    shape=st.tuples(st.integers(12, 64), st.integers(12, 64)),
    page=st.sampled_from(["A5", "A4", "Letter", "150x90"]),
    orientation=st.sampled_from(["portrait", "landscape", "auto"]),
    margin=st.floats(0, 30),
    pen=st.floats(0.5, 1.2),
)
@example(seed=1, shape=(64, 12), page="150x90", orientation="portrait", margin=0.0, pen=0.2)
@example(seed=2, shape=(12, 64), page="150x90", orientation="landscape", margin=30.0, pen=0.2)
@example(seed=3, shape=(40, 40), page="A5", orientation="auto", margin=0.0, pen=1.2)
def test_any_photo_on_any_page_stays_inside_the_margins(seed, shape, page, orientation, margin, pen):
    rng = np.random.default_rng(seed)
    blobs = ndi.gaussian_filter(rng.random(shape), 3)
    gray = (blobs - blobs.min()) / max(np.ptp(blobs), 1e-9)
    image = image_from_array(gray.astype(np.float32), source="blobs")
    style = Style(page=page, orientation=orientation, margin=margin, pen_width=pen, order_rounds=0)
    plan = make_plan(image, style=style)
    page_ = plan.page
    assert page_.margin == margin
    for layer in plan.layers:
        assert layer.pen_width == pen
        for p in layer.paths:
            assert np.all((p[:, 0] >= margin - 1e-6) & (p[:, 0] <= page_.width - margin + 1e-6))
            assert np.all((p[:, 1] >= margin - 1e-6) & (p[:, 1] <= page_.height - margin + 1e-6))


def test_a_huge_photo_is_planned_at_what_the_pen_can_draw():
    page = page_size("A5", "portrait")  # drawing box 118 × 180 mm
    big = image_from_array(resize(data.camera(), (1800, 1800), anti_aliasing=False), source="big")
    small = at_plot_resolution(big, page, pen_width=0.5)
    mm_per_px = Layout.fit(small.shape, page).mm_per_px
    assert mm_per_px == pytest.approx(0.5 / 3, rel=0.01)
    assert small.source == "big" and abs(small.gray.mean() - big.gray.mean()) < 0.01
    assert at_plot_resolution(small, page, pen_width=0.5) is small
    plan = make_plan(big, page=page, style=Style(order_rounds=0))
    assert plan.meta["image_px"] == f"{small.shape[1]}x{small.shape[0]}"


def test_every_style_key_has_one_rule_and_the_defaults_obey_it():
    from pencilbot.planning.style import STYLE_SCHEMA

    fields = [f.name for f in dataclasses.fields(Style) if f.name != "name"]
    assert list(STYLE_SCHEMA) == fields
    for key, rule in STYLE_SCHEMA.items():
        default = getattr(Style(), key)
        if default is not None:  # None: chosen automatically, by leaving the key out
            value = list(default) if isinstance(default, tuple) else default
            assert rule.accepts(value), (key, default, rule.expected)
            assert with_overrides(Style(), {key: value}) == Style()


def test_a_white_photo_plans_no_strokes():
    white = image_from_array(np.ones((120, 160), np.float32), source="white")
    plan = make_plan(white, style=FAST)
    assert plan.paths().points.size == 0


@pytest.mark.parametrize(
    "gray",
    [
        np.tile(np.linspace(0.55, 0.75, 600), (400, 1)),
        np.round(np.tile(np.linspace(0.2, 0.9, 600), (400, 1)) * 255) / 255,
        np.clip(0.97 + np.random.default_rng(0).integers(-2, 3, (400, 600)) / 255, 0, 1),
        np.ones((400, 600)),
    ],
    ids=["smooth-ramp", "8-bit-ramp", "noisy-blank-page", "white"],
)
def test_paper_that_should_stay_paper_plans_no_edge_strokes(gray):
    # The edge map used to be divided by its own maximum: banding and ±2 grey levels of
    # noise became full-strength strokes, metres of them on A4.
    image = image_from_array(gray.astype(np.float32), source="blank")
    drawing, plan = sketch_and_plan(image, style=FAST)
    assert len(plan.layer("edges").paths) == 0
    assert np.all(drawing.line.drawing == 1.0)  # and the raster line drawing is paper too


def test_a_photo_file_is_decoded_at_plot_resolution_not_reduced_after(tmp_path):
    path = tmp_path / "big.png"
    Image.fromarray((resize(data.camera(), (1800, 1200)) * 255).astype(np.uint8)).save(path)
    style = Style(page="A5", orientation="auto", order_rounds=0)
    page = page_size("A5", "auto", (1800, 1200), style.margin)
    lean = load_image(path, shrink_to=plot_resolution(style))
    after = at_plot_resolution(load_image(path), page, style.pen_width)
    assert lean.shape == after.shape == plot_shape((1800, 1200), page, style.pen_width)
    assert (
        Layout.fit(lean.shape, page).mm_per_px >= style.pen_width / 3
    )  # a pixel is at least a third of the pen
    assert at_plot_resolution(lean, page, style.pen_width) is lean
    assert np.abs(lean.gray - after.gray).mean() < 1 / 255  # 8-bit area averaging, then float
    assert make_plan(lean, style=style).meta["image_px"] == f"{lean.shape[1]}x{lean.shape[0]}"
