"""Reading any SVG: Inkscape's (layers with transforms, shapes, curves), vpype's, hatched's and
linedraw's, through vpype's reader; and pencilbot's own plans through the whole-array path."""

import drawings
import numpy as np
import pytest

from pencilbot.errors import PencilbotError
from pencilbot.export.svg import write_svg
from pencilbot.export.svg_read import _parse, _read_any, _read_own, is_plan_svg, read_svg
from pencilbot.planning.plan import Layer, Page, Plan

PX = 25.4 / 96  # mm per CSS pixel


def _segment_lengths(path):
    return np.hypot(*np.diff(path, axis=0).T)


def test_inkscape_layers_with_transforms_shapes_and_curves(tmp_path):
    (tmp_path / "drawing.svg").write_text(drawings.inkscape_svg())
    plan = read_svg(tmp_path / "drawing.svg")
    assert (plan.page.width, plan.page.height) == drawings.INKSCAPE_PAGE
    # The hidden "Helpers" layer draws nothing, and the text is no pen path.
    assert [layer.name for layer in plan.layers] == ["Shapes", "Curves"]
    assert [layer.pen_width for layer in plan.layers] == pytest.approx([0.3, 0.3])
    rect, circle = plan.layers[0].paths
    # The layer's translate(10,5) is applied, and Y is flipped.
    assert sorted(map(tuple, np.round(rect[:-1], 6))) == sorted(drawings.INKSCAPE_RECT[:-1])
    np.testing.assert_allclose(rect[0], rect[-1])  # closed
    (cx, cy), r = drawings.INKSCAPE_CIRCLE
    radii = np.hypot(circle[:, 0] - cx, circle[:, 1] - cy)
    np.testing.assert_allclose(radii, r, atol=1e-6)  # vertices on the circle
    # Flattened to segments of at most half the default pen: the chords stray < a tenth of it.
    chord = _segment_lengths(circle).max()
    assert 0.1 < chord <= 0.25 + 1e-9
    assert r * (1 - np.cos(np.arcsin(chord / 2 / r))) < 0.05  # how far a chord strays from the arc
    assert abs(np.ptp(circle[:, 0]) - 2 * r) < 0.01 and abs(np.ptp(circle[:, 1]) - 2 * r) < 0.01
    bezier, rotated = plan.layers[1].paths
    np.testing.assert_allclose(bezier[[0, -1]], drawings.INKSCAPE_BEZIER_ENDS, atol=1e-9)
    # y(t) = 30 + 45 t (1 - t) (1 - 2t) (Y up): it strays from its chord by 45 √3 / 18 mm.
    assert bezier[:, 1].max() == pytest.approx(30 + 45 * 3**0.5 / 18, abs=0.01)
    assert bezier[:, 1].min() == pytest.approx(30 - 45 * 3**0.5 / 18, abs=0.01)
    np.testing.assert_allclose(rotated[[0, -1]], drawings.INKSCAPE_ROTATED_LINE, atol=1e-9)


def test_vpype_files_keep_layer_names_pen_widths_and_coordinates(tmp_path):
    truth = drawings.vpype_svg(tmp_path / "v.svg")
    plan = read_svg(tmp_path / "v.svg")
    assert (plan.page.width, plan.page.height) == pytest.approx(truth["page"])
    assert [layer.name for layer in plan.layers] == list(truth["layers"])
    for layer, (pen, lines) in zip(plan.layers, truth["layers"].values()):
        assert layer.pen_width == pytest.approx(pen, abs=1e-4)  # vpype writes 4 decimals of px
        assert len(layer.paths) == len(lines)
        for got, want in zip(layer.paths, lines):
            np.testing.assert_allclose(got, want, atol=1e-3)


def test_hatched_files_need_a_size_and_then_read_whole(tmp_path):
    lines = drawings.hatch_lines()
    (tmp_path / "h.svg").write_text(drawings.hatched_svg(lines))
    with pytest.raises(
        PencilbotError, match=r"width '200' and height '300', no size on paper.*--svg-dpi 96.*--page"
    ):
        read_svg(tmp_path / "h.svg")
    plan = read_svg(tmp_path / "h.svg", dpi=96)
    assert (plan.page.width, plan.page.height) == pytest.approx((200 * PX, 300 * PX))
    (layer,) = plan.layers
    assert layer.name == "default" and layer.pen_width == 0.5  # hatched sets no stroke width
    assert len(layer.paths) == len(lines)
    # Nothing is cropped: hatched's page is its image turned, so half the drawing lies beyond it.
    got = layer.paths.points
    want = np.concatenate(lines) * PX
    np.testing.assert_allclose(got[:, 0], want[:, 0], atol=1e-9)
    np.testing.assert_allclose(plan.page.height - got[:, 1], want[:, 1], atol=1e-9)
    assert got[:, 0].max() > plan.page.width


def test_linedraw_files_without_any_size(tmp_path):
    lines = drawings.contour_lines()
    (tmp_path / "l.svg").write_text(drawings.linedraw_svg(lines))
    with pytest.raises(PencilbotError, match="no width or height, no size on paper"):
        read_svg(tmp_path / "l.svg")
    plan = read_svg(tmp_path / "l.svg", dpi=72)
    (layer,) = plan.layers
    mm = 25.4 / 72
    assert layer.pen_width == pytest.approx(2 * mm)  # its stroke-width, in its own units
    far = np.concatenate(lines).max(axis=0) * mm
    assert (plan.page.width, plan.page.height) == pytest.approx(tuple(far))  # the page reaches the drawing
    for got, want in zip(layer.paths, lines):
        np.testing.assert_allclose(got[:, 0], want[:, 0] * mm, atol=1e-9)
        np.testing.assert_allclose(plan.page.height - got[:, 1], want[:, 1] * mm, atol=1e-9)


def test_a_pen_width_given_sets_every_layer_and_the_flattening(tmp_path):
    (tmp_path / "drawing.svg").write_text(drawings.inkscape_svg())
    plan = read_svg(tmp_path / "drawing.svg", pen_width=0.1)
    assert [layer.pen_width for layer in plan.layers] == [0.1, 0.1]
    circle = plan.layers[0].paths[1]
    assert 0.02 < _segment_lengths(circle).max() <= 0.05 + 1e-9


def test_layers_with_the_same_number_in_their_label_stay_apart(tmp_path):
    # vpype would merge both into its layer 1.
    svg = f"""<svg xmlns="{drawings.SVG_NS}" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
      width="50mm" height="50mm" viewBox="0 0 50 50">
      <g inkscape:label="Layer 1"><path d="M 0 0 L 10 0"/></g>
      <g inkscape:label="Layer 1 copy"><path d="M 0 10 L 10 10"/></g>
      <line x1="0" y1="20" x2="10" y2="20" stroke="black"/></svg>"""
    (tmp_path / "s.svg").write_text(svg)
    plan = read_svg(tmp_path / "s.svg")
    assert [layer.name for layer in plan.layers] == ["Layer 1", "Layer 1 copy", "default"]
    assert [layer.paths.points[0, 1] for layer in plan.layers] == pytest.approx([50, 40, 30])


def sample_plan():
    rng = np.random.default_rng(0)
    strokes = [
        rng.uniform(10, 190, 2) + np.cumsum(rng.normal(0, 2, (k, 2)), axis=0) for k in rng.integers(2, 9, 300)
    ]
    dots = [np.array([[5.0, 5.0]]), np.array([[6.5, 7.25]])]
    return Plan(
        Page(210, 297, margin=12, name="A4"),
        [
            Layer("hatch1-45", strokes[:200], pen_width=0.3, role="hatch"),
            Layer("empty", [], pen_width=0.4, role="hatch"),
            Layer("edges", strokes[200:] + dots, role="edges"),
        ],
        meta={"source": "a & b", "style": "default"},
    )


def test_our_own_plans_take_the_whole_array_path_and_agree_with_vpype(tmp_path):
    plan = sample_plan()
    write_svg(plan, tmp_path / "p.svg")
    data = (tmp_path / "p.svg").read_bytes()
    fast = _read_own(data)
    assert fast is not None and is_plan_svg(tmp_path / "p.svg")
    slow = _read_any(_parse(data, "p.svg"), "p.svg", dpi=None, pen_width=None)
    assert fast.page == plan.page == slow.page and fast.meta == plan.meta == slow.meta
    # vpype drops an empty layer and dots (zero-length paths); everything else is the same.
    assert [(l.name, l.role, l.pen_width) for l in fast.layers] == [
        (l.name, l.role, l.pen_width) for l in plan.layers
    ]
    assert [(l.name, l.role) for l in slow.layers] == [("hatch1-45", "hatch"), ("edges", "edges")]
    assert fast.layer("edges").paths.lengths[-2:].tolist() == [1, 1]
    for ours, _, written in zip(fast.paths(), plan.paths(), plan.paths()):
        np.testing.assert_allclose(ours, np.round(written, 3), atol=1e-9)
    nonempty = [l for l in fast.layers if len(l.paths)]
    for a, b in zip(nonempty, slow.layers):
        lines = [p for p in a.paths if len(p) > 1]
        assert len(lines) == len(b.paths)
        for p, q in zip(lines, b.paths):
            np.testing.assert_allclose(p, q, atol=1e-6)


@pytest.mark.parametrize(
    "edit",
    [
        lambda text: text.replace(
            '<path d="M 5 292 L 5 292"/>', '<path d="m 5,292 0,0"/>'
        ),  # Inkscape's own path data
        lambda text: text.replace("<metadata>", '<g inkscape:label="new"/><metadata>'),
        lambda text: text.replace('id="layer3"', 'id="layer3" transform="translate(1,0)"'),
    ],
)
def test_an_edited_plan_of_ours_is_read_as_any_svg_and_keeps_its_metadata(tmp_path, edit):
    plan = sample_plan()
    write_svg(plan, tmp_path / "p.svg")
    text = edit((tmp_path / "p.svg").read_text())
    (tmp_path / "edited.svg").write_text(text)
    assert _read_own(text.encode()) is None
    back = read_svg(tmp_path / "edited.svg")
    assert back.page == plan.page and back.meta == plan.meta
    assert [(l.name, l.role) for l in back.layers] == [("hatch1-45", "hatch"), ("edges", "edges")]
    assert len(back.paths()) == len(plan.paths()) - 2  # vpype drops the two dots


@pytest.mark.parametrize("garbage", ["1.2.3", "-", "1 2 3", "e5"])
def test_malformed_numbers_in_our_own_layout_fall_back_to_the_general_reader(garbage):
    cut = f'\n<path d="M 1 2 L {garbage}"/>\n'.encode()
    from pencilbot.export.svg_read import _own_paths

    assert _own_paths(cut, 1.0, 10.0) is None
