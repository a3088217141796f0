"""make_plan: photo → ordered layers on a page, and the drawing styles that parametrise it."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image
from scipy import ndimage as ndi
from skimage import data
from skimage.draw import disk
from skimage.transform import resize

from pencilbot.errors import ProfileError
from pencilbot.imaging.io import image_from_array, load_image
from pencilbot.imaging.pencil import sketch
from pencilbot.planning.build import (
    at_plot_resolution,
    hatch_darkness,
    ink_on_image_grid,
    make_plan,
    plan_from_sketch,
    plot_resolution,
    plot_shape,
)
from pencilbot.planning.layout import Layout, page_size
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
    assert names[:-1] and all(name.startswith("hatch") for name in names[:-1])
    assert names[:-1] == sorted(names[:-1])  # hatch1 (lightest tones) before hatch2 ...
    assert all(layer.paths for layer in camera_plan.layers)


def test_everything_lies_inside_the_page_margins(camera_plan):
    page = camera_plan.page
    assert (page.width, page.height, page.margin) == (210, 297, 15)
    pts = np.concatenate(camera_plan.all_paths())
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
    plan = plan_from_sketch(drawing, page, FAST)
    layout = Layout.fit(camera.shape, page)
    raw = edge_strokes(drawing.line, layout, threshold=float(plan.meta["edge_threshold"]))
    ordered = plan.layer("edges").paths
    # Ordering only reverses and joins: ink length is kept up to the joins' short bridges
    # (each at most edge_join · ℓ at plot scale).
    assert len(ordered) < len(raw)
    bridge = max(FAST.pen_width, FAST.edge_join * drawing.line.length * layout.mm_per_px)
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
    hatch = [p for layer in plan.layers if layer.name != "edges" for p in layer.paths]
    ink = ink_on_image_grid(hatch, layout, pen_width=FAST.pen_width)
    inside = np.zeros(gray.shape, bool)
    inside[disk((60, 60), 28)] = True
    outside = np.ones(gray.shape, bool)
    outside[disk((60, 60), 45)] = False
    assert ink[inside].mean() > 0.3
    assert ink[inside].mean() > 4 * ink[outside].mean()


def test_hatching_leaves_room_for_the_edges_ink(camera):
    drawing = sketch(camera)
    layout = Layout.fit(camera.shape, page_size("A4", "portrait"))
    strokes = edge_strokes(drawing.line, layout)
    plain = hatch_darkness(drawing, [], layout, pen_width=0.5, blur=1.0)
    compensated = hatch_darkness(drawing, strokes, layout, pen_width=0.5, blur=1.0)
    assert np.all(compensated <= plain + 1e-6)
    near_edges = ink_on_image_grid(strokes, layout, pen_width=0.5) > 0.5
    assert (plain - compensated)[near_edges].mean() > 0.1
    assert 0 <= compensated.min() and compensated.max() <= 1


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
        ("pen_width = 0.001\n", ["bad.toml", "pen_width", "0.05 mm"]),
        ("margin = inf\n", ["bad.toml", "margin"]),
        ("hatch_blur = nan\n", ["bad.toml", "hatch_blur"]),
        ("line_length = 100000\n", ["bad.toml", "line_length"]),
    ],
)
def test_a_bad_style_file_names_the_file_and_the_key(tmp_path, text, words):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ProfileError) as err:
        load_style(path)
    assert all(word in str(err.value) for word in words)
    assert "\n" not in str(err.value)


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


def test_neighbouring_hatch_runs_are_joined_pen_down():
    # A dark disc: hatched line after line, so serpentine hops between neighbours are short.
    gray = np.full((120, 120), 0.92, np.float32)
    gray[disk((60, 60), 40)] = 0.02
    drawing = sketch(image_from_array((gray * 255).astype(np.uint8), source="disc"))
    page = page_size("100x100", margin=5)
    apart = plan_from_sketch(drawing, page, Style(hatch_join=0.0, order_rounds=0))
    joined = plan_from_sketch(drawing, page, Style(hatch_join=2.0, order_rounds=0))
    names = [layer.name for layer in apart.layers if layer.name != "edges"]
    assert names
    for name in names:  # hatch1 covers the disc; the few runs of later layers rarely meet
        before, after = apart.layer(name).paths, joined.layer(name).paths
        assert all(len(p) == 2 for p in before)  # one straight run per path when not joined
        if name == names[0]:
            assert len(after) <= 0.9 * len(before)  # lifts saved
        # Each join adds one connecting move no longer than the tolerance.
        added = _length(after) - _length(before)
        assert -1e-6 <= added <= (len(before) - len(after)) * 2.0 + 1e-6


@settings(max_examples=10, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    shape=st.tuples(st.integers(12, 64), st.integers(12, 64)),
    page=st.sampled_from(["A5", "A4", "Letter", "150x90"]),
    orientation=st.sampled_from(["portrait", "landscape", "auto"]),
    margin=st.floats(0, 30),
    pen=st.floats(0.2, 1.2),
)
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


def test_a_photo_file_is_decoded_at_plot_resolution_not_reduced_after(tmp_path):
    path = tmp_path / "big.png"
    Image.fromarray((resize(data.camera(), (1800, 1200)) * 255).astype(np.uint8)).save(path)
    style = Style(page="A5", orientation="auto", order_rounds=0)
    page = page_size("A5", "auto", (1800, 1200), style.margin)
    lean = load_image(path, shrink_to=plot_resolution(style))
    after = at_plot_resolution(load_image(path), page, style.pen_width)
    assert lean.shape == after.shape == plot_shape((1800, 1200), page, style.pen_width)
    assert Layout.fit(lean.shape, page).mm_per_px >= style.pen_width / 3  # a pixel is at least a third of the pen
    assert at_plot_resolution(lean, page, style.pen_width) is lean
    assert np.abs(lean.gray - after.gray).mean() < 1 / 255  # 8-bit area averaging, then float
    assert make_plan(lean, style=style).meta["image_px"] == f"{lean.shape[1]}x{lean.shape[0]}"
