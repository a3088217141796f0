"""SVG out and back: physical size, layers vpype understands, the Y flip, clear errors."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.errors import PencilbotError
from pencilbot.export.svg import INKSCAPE_NS, PENCILBOT_NS, SVG_NS, write_svg
from pencilbot.export.svg_read import read_svg
from pencilbot.planning.plan import Layer, Page, Plan

NS = {"svg": SVG_NS, "inkscape": INKSCAPE_NS}


def sample_plan():
    return Plan(
        Page(210, 297, margin=15, name="A4"),
        [
            Layer("hatch-45", [np.array([[20.0, 20.0], [100.0, 100.0]])], pen_width=0.3, role="hatch"),
            Layer(
                "edges",
                [np.array([[15.0, 290.0], [195.0, 290.0], [195.0, 15.0]]), np.array([[50.0, 60.0]])],
                role="edges",
            ),
        ],
        meta={"source": 'coffee <test> & "more"'},
    )


def test_size_in_mm_matches_the_page_and_the_viewbox(tmp_path):
    write_svg(sample_plan(), tmp_path / "p.svg")
    root = ET.parse(tmp_path / "p.svg").getroot()
    assert (root.get("width"), root.get("height")) == ("210mm", "297mm")
    assert root.get("viewBox") == "0 0 210 297"


def test_one_inkscape_layer_per_plan_layer_with_the_pen_width(tmp_path):
    write_svg(sample_plan(), tmp_path / "p.svg")
    groups = ET.parse(tmp_path / "p.svg").getroot().findall("svg:g", NS)
    assert [g.get(f"{{{INKSCAPE_NS}}}label") for g in groups] == ["hatch-45", "edges"]
    assert all(g.get(f"{{{INKSCAPE_NS}}}groupmode") == "layer" for g in groups)
    assert [g.get("id") for g in groups] == ["layer1", "layer2"]
    assert [g.get("stroke-width") for g in groups] == ["0.3", "0.5"]
    assert len(groups[1].findall("svg:path", NS)) == 2


def test_y_is_flipped_on_the_way_out(tmp_path):
    write_svg(sample_plan(), tmp_path / "p.svg")
    edges = ET.parse(tmp_path / "p.svg").getroot().findall("svg:g", NS)[1]
    # plan y = 290 (near the top of the page) → SVG y = 297 − 290 = 7 (near the top, Y down)
    assert edges.find("svg:path", NS).get("d") == "M 15 7 L 195 7 195 282"


def test_round_trip_keeps_page_layers_paths_and_meta(tmp_path):
    plan = sample_plan()
    write_svg(plan, tmp_path / "p.svg")
    back = read_svg(tmp_path / "p.svg")
    assert back.page == plan.page
    assert back.meta == plan.meta
    assert [(l.name, l.pen_width, l.role) for l in back.layers] == [
        (l.name, l.pen_width, l.role) for l in plan.layers
    ]
    assert [l.role for l in back.layers] == ["hatch", "edges"]
    for a, b in zip(back.paths(), plan.paths()):
        np.testing.assert_allclose(a, b)


def test_a_foreign_or_unknown_role_reads_as_other(tmp_path):
    write_svg(sample_plan(), tmp_path / "p.svg")
    text = (tmp_path / "p.svg").read_text().replace('pencilbot:role="hatch"', 'pencilbot:role="magic"')
    (tmp_path / "q.svg").write_text(text.replace(' pencilbot:role="edges"', ""))
    assert [l.role for l in read_svg(tmp_path / "q.svg").layers] == ["other", "other"]


coord = st.floats(0, 400, allow_nan=False)
paths = st.lists(st.lists(st.tuples(coord, coord), min_size=1, max_size=6).map(np.array), max_size=8)
names = st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), min_size=1, max_size=12)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.tuples(names, paths, st.floats(0.05, 3)), min_size=1, max_size=4),
    st.floats(10, 500),
    st.floats(10, 500),
)
def test_round_trip_any_plan(tmp_path_factory, layers, width, height):
    plan = Plan(
        Page(round(width, 3), round(height, 3), margin=5, name="300x200"),
        [Layer(n, ps, pen_width=round(w, 3)) for n, ps, w in layers],
    )
    path = tmp_path_factory.mktemp("svg") / "plan.svg"
    write_svg(plan, path)
    back = read_svg(path)
    assert back.page == plan.page
    assert [l.name for l in back.layers] == [l.name for l in plan.layers]
    assert [len(l.paths) for l in back.layers] == [len(l.paths) for l in plan.layers]
    for a, b in zip(back.paths(), plan.paths()):
        if len(b) == 2 and np.array_equal(np.round(b[0], 3), np.round(b[1], 3)):
            b = b[:1]  # a zero-length segment is written like a dot, and is one: reads back as a dot
        assert a.shape == b.shape
        np.testing.assert_allclose(a, b, atol=1.5e-3)


def test_vpype_reads_layers_and_physical_size(tmp_path):
    import vpype  # a test dependency: vpype must read our SVG as the plotter community does

    write_svg(sample_plan(), tmp_path / "p.svg")
    doc = vpype.read_multilayer_svg(str(tmp_path / "p.svg"), quantization=0.1)
    px_per_mm = 96 / 25.4  # vpype works in CSS pixels
    assert doc.page_size == pytest.approx((210 * px_per_mm, 297 * px_per_mm))
    assert len(doc.layers) == 2
    names = sorted(doc.layers[i].property("vp_name") for i in doc.layers)
    assert names == ["edges", "hatch-45"]
    edges = next(doc.layers[i] for i in doc.layers if doc.layers[i].property("vp_name") == "edges")
    line = edges[0] / px_per_mm  # complex x + iy, SVG Y down
    np.testing.assert_allclose(
        [line[0].real, line[0].imag, line[-1].real, line[-1].imag], [15, 7, 195, 282], atol=0.01
    )


def test_straight_line_svg_from_elsewhere_loads(tmp_path):
    svg = f"""<svg xmlns="{SVG_NS}" width="4in" height="2in" viewBox="0 0 400 200">
      <g id="a" style="stroke-width:2"><polyline points="0,0 100,0"/><line x1="0" y1="200" x2="400" y2="200"/>
      <path d="m 10 10 h 20 v 20 z"/></g>
      <path d="M 0 100 L 50 100"/></svg>"""
    (tmp_path / "x.svg").write_text(svg)
    plan = read_svg(tmp_path / "x.svg")
    assert plan.page.width == pytest.approx(101.6) and plan.page.height == pytest.approx(50.8)
    scale = 101.6 / 400
    assert [l.name for l in plan.layers] == ["a", "default"]  # loose shapes last, as a layer
    assert plan.layers[0].pen_width == pytest.approx(2 * scale)
    np.testing.assert_allclose(plan.layers[0].paths[1], [[0, 0], [101.6, 0]])  # bottom edge, Y up
    np.testing.assert_allclose(plan.layers[0].paths[2] / scale, [[10, 190], [30, 190], [30, 170], [10, 190]])


@pytest.mark.parametrize(
    "content, message",
    [
        ("not xml at all", "cannot read"),
        (f'<svg xmlns="{SVG_NS}" width="100" height="100%"/>', "no size on paper.*--svg-dpi 96.*--page A4"),
        (f'<svg xmlns="{SVG_NS}" width="1e999mm" height="10mm"/>', "width '1e999mm' is not a size"),
        (f'<svg xmlns="{SVG_NS}" width="0mm" height="10mm"/>', "width '0mm' is not a size"),
        (
            f'<svg xmlns="{SVG_NS}" xmlns:p="{PENCILBOT_NS}" width="10mm" height="10mm" p:margin="wide"/>',
            "margin",
        ),
        ('<html xmlns="http://www.w3.org/1999/xhtml"/>', "not an SVG"),
    ],
)
def test_bad_svgs_are_user_errors(tmp_path, content, message):
    (tmp_path / "bad.svg").write_text(content)
    with pytest.raises(PencilbotError, match=message):
        read_svg(tmp_path / "bad.svg")


def test_missing_file_is_a_user_error(tmp_path):
    with pytest.raises(PencilbotError, match="no such file"):
        read_svg(tmp_path / "none.svg")


def test_failed_write_leaves_nothing_behind(tmp_path):
    with pytest.raises(PencilbotError, match="cannot write"):
        write_svg(sample_plan(), tmp_path / "missing" / "p.svg")
    assert list(tmp_path.iterdir()) == []


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-1e6, 1e6), st.floats(-1e6, 1e6)), min_size=1, max_size=50),
    st.sampled_from([0.0, 1.0, 0.1, 0.001, 1e-4]),
)
def test_numbers_written_in_one_pass_are_the_ones_written_one_by_one(points, grid):
    from pencilbot.export.svg import _fmt, _numbers_text

    xy = np.array(points)
    if grid:  # values on a grid, where trailing zeros and minus zeros come up
        xy = np.round(xy / grid) * grid * np.sign(np.sin(np.arange(xy.size))).reshape(xy.shape)
    assert _numbers_text(xy).split("\n") == [f"{_fmt(x)} {_fmt(y)}" for x, y in xy.tolist()]
