"""A plan of several pens on its way out: one SVG layer per pen with its colour (as Inkscape and
vpype read it), G-code that stops for each pen by name, in load order, with the pen up."""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import vpype
from gcodeparser import parse_gcode_lines
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pencilbot.errors import OutOfBedError, ProfileError
from pencilbot.export.gcode import gcode_lines, gcode_program, pens_at_pauses
from pencilbot.export.svg import INKSCAPE_NS, PENCILBOT_NS, SVG_NS, write_svg
from pencilbot.export.svg_read import read_svg
from pencilbot.machine.pens import load_pens
from pencilbot.machine.profile import PenChange, load_profile, profile_from_mapping
from pencilbot.planning.plan import Layer, Page, Plan

A4 = Page(210.0, 297.0, margin=15.0, name="A4")
PROFILES = ["grbl-servo-a4", "grbl-z-a3", "grblhal-servo-a3", "marlin-servo-a4"]


def colour_plan(set_name: str = "cmyk") -> Plan:
    """Two hatch layers per pen (load order) and edges in the darkest, each a few lines somewhere."""
    rng = np.random.default_rng(0)
    layers = []
    for pen in load_pens(set_name).load_order:
        for family in range(2):
            paths = [
                np.cumsum(rng.uniform(-3, 3, (5, 2)), axis=0) + rng.uniform(40, 160, 2) for _ in range(3)
            ]
            layers.append(
                Layer(
                    f"{pen.name}-hatch{family + 1}",
                    paths,
                    pen_width=pen.width,
                    role="hatch",
                    pen=pen.name,
                    color=pen.color,
                )
            )
    dark = load_pens(set_name).darkest
    layers.append(
        Layer(
            f"{dark.name}-edges",
            [np.array([[30.0, 30.0], [60.0, 70.0]])],
            pen_width=dark.width,
            role="edges",
            pen=dark.name,
            color=dark.color,
        )
    )
    return Plan(A4, layers, meta={"source": "test"})


@pytest.mark.parametrize("set_name", ["cmyk", "fineliner6"])
def test_each_pens_layers_sit_in_their_own_svg_layer_with_the_pens_colour(tmp_path, set_name):
    plan = colour_plan(set_name)
    path = tmp_path / "colour.svg"
    write_svg(plan, path)
    root = ET.parse(path).getroot()
    groups = [g for g in root if g.tag == f"{{{SVG_NS}}}g"]
    order = load_pens(set_name).load_order
    assert [g.get(f"{{{PENCILBOT_NS}}}pen") for g in groups] == [pen.name for pen in order]
    for number, (group, pen) in enumerate(zip(groups, order), start=1):
        assert group.get(f"{{{INKSCAPE_NS}}}groupmode") == "layer"
        assert group.get(f"{{{INKSCAPE_NS}}}label") == f"{number} {pen.name}"
        assert group.get("stroke") == pen.color and float(group.get("stroke-width")) == pen.width
        inner = [child.get(f"{{{INKSCAPE_NS}}}label") for child in group]
        assert inner == [layer.name for layer in plan.layers if layer.pen == pen.name]
    # Read back by pencilbot: every layer keeps its pen, colour, width and role.
    back = read_svg(path)
    assert [(l.name, l.pen, l.color, l.pen_width, l.role) for l in back.layers] == [
        (l.name, l.pen, l.color, l.pen_width, l.role) for l in plan.layers
    ]
    assert back.pens == plan.pens
    for a, b in zip(plan.layers, back.layers):
        assert np.allclose(a.paths.points, b.paths.points, atol=1e-3)


def test_vpype_reads_one_layer_per_pen_with_its_colour_and_pen_width(tmp_path):
    plan = colour_plan("cmyk")
    path = tmp_path / "colour.svg"
    write_svg(plan, path)
    document = vpype.read_multilayer_svg(str(path), quantization=0.1)
    order = load_pens("cmyk").load_order
    assert sorted(document.layers) == list(range(1, len(order) + 1))
    for lid, pen in enumerate(order, start=1):
        layer = document.layers[lid]
        assert layer.property("vp_name") == f"{lid} {pen.name}"
        assert layer.property("vp_color").as_hex()[:7] == pen.color
        assert layer.property("vp_pen_width") * 25.4 / 96 == pytest.approx(pen.width, rel=1e-4)
        assert len(layer) == sum(len(l.paths) for l in plan.layers if l.pen == pen.name)


def test_a_plan_of_one_pen_is_written_as_before_without_pen_groups(tmp_path):
    plan = Plan(A4, [Layer("edges", [np.array([[10.0, 10.0], [20.0, 20.0]])], role="edges")])
    path = tmp_path / "black.svg"
    write_svg(plan, path)
    groups = [g for g in ET.parse(path).getroot() if g.tag == f"{{{SVG_NS}}}g"]
    assert [g.get(f"{{{INKSCAPE_NS}}}label") for g in groups] == ["edges"] and groups[0].get(
        "stroke"
    ) == "black"
    assert read_svg(path).pens == ()


def commands(lines: list[str]) -> list[str]:
    """Each command line as gcodeparser reads it, e.g. 'M0', 'G0', 'M3'."""
    out = []
    for line in lines:
        for parsed in parse_gcode_lines(line):
            out.append(f"{parsed.command[0]}{parsed.command[1]}")
    return out


@pytest.mark.parametrize("name", PROFILES)
def test_gcode_stops_for_each_pen_by_name_in_load_order_with_the_pen_up(name):
    profile = load_profile(name)
    plan = colour_plan("cmyk")
    lines = gcode_lines(plan, profile)
    pauses = [i for i, line in enumerate(lines) if "M0" in line.split(";")[0].split("(")[0]]
    names = [
        line.split("insert ", 1)[1].rstrip(")").split(")")[0]
        for line in lines
        if "pen change: insert" in line
    ]
    assert names == [pen.name for pen in load_pens("cmyk").load_order]
    assert len(pauses) == len(names)
    up, down = set(profile.pen_model.up_lines), set(profile.pen_model.down_lines)
    for at in pauses:
        # The last pen command before the pause lifts the pen; no pen-down and no drawing between.
        before = [line for line in lines[:at] if line in up | down]
        assert before[-1] in up
        assert commands(lines[at : at + 1]) == ["M0"]
    # The pause is GRBL's program pause: every line still parses, and is at most 80 characters.
    assert all(len(line) <= 80 for line in lines)
    assert "M0" in commands(lines)
    # Each pen draws after its pause, before the next one.
    for at, following in zip(pauses, pauses[1:] + [len(lines)]):
        assert "G1" in commands(lines[at + 1 : following])
    assert [p.name for p in pens_at_pauses(gcode_program(plan, profile))] == names


def test_a_plan_of_one_pen_has_no_pause():
    plan = colour_plan("cmyk")
    one = dataclasses.replace(plan, layers=[l for l in plan.layers if l.pen == "cyan"])
    lines = gcode_lines(one, load_profile("grbl-servo-a4"))
    assert "M0" not in commands(lines)
    assert "; pen 1 of 1: cyan #009fe3 0.5 mm" in lines


def test_the_profiles_pen_change_template_and_park_position_replace_the_plain_pause():
    profile = load_profile("grbl-servo-a4")
    profile = dataclasses.replace(
        profile, pen_change=PenChange(command="M5\nM0 (load {pen}, pen {number})", park=(5.0, 200.0))
    )
    lines = gcode_lines(colour_plan("cmyk"), profile)
    at = [i for i, line in enumerate(lines) if line.startswith("M0")]
    assert [lines[i] for i in at] == [
        f"M0 (load {pen.name}, pen {n})" for n, pen in enumerate(load_pens("cmyk").load_order, 1)
    ]
    for i in at:
        assert lines[i - 2 : i] == ["G0 X5 Y200", "M5"]
    far = dataclasses.replace(profile, pen_change=PenChange(park=(5.0, 900.0)))
    with pytest.raises(OutOfBedError, match="park position 5, 900 does not fit the bed"):
        gcode_lines(colour_plan("cmyk"), far)


@pytest.mark.parametrize(
    ("pen_change", "words"),
    [
        ({"command": "M0 ({pen.__class__})"}, "[pen_change] command"),
        ({"command": "M0 ({colour})"}, "{colour} is not a known field"),
        ({"park": [1.0]}, "[pen_change] park"),
        ({"park": "home"}, "[pen_change] park"),
        ({"parking": [1.0, 2.0]}, "unknown key [pen_change] parking"),
        ({"command": "M0 (" + "x" * 70 + " {pen})"}, "characters; expected at most 80"),
    ],
)
def test_a_bad_pen_change_table_is_one_message(pen_change, words):
    import tomllib

    from pencilbot.configs_io import config_folder

    table = tomllib.loads((config_folder("plotters") / "grbl-servo-a4.toml").read_text())
    table["pen_change"] = pen_change
    with pytest.raises(ProfileError) as err:
        profile_from_mapping(table, where="test.toml")
    assert words in str(err.value) and "test.toml" in str(err.value)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["cyan", "sky blue", "red-2", "ink.7", "black"]),
            st.integers(1, 3),
            st.sampled_from(["#009fe3", "#d7262b", "#1a1a1a"]),
            st.sampled_from([0.3, 0.5]),
        ),
        min_size=1,
        max_size=6,
    )
)
def test_any_plan_of_pens_reads_back_as_it_was_written(tmp_path, runs):
    rng = np.random.default_rng(len(runs))
    layers = []
    for pen, count, color, width in runs:
        for k in range(count):
            paths = [
                rng.uniform(20, 180, (int(rng.integers(1, 5)), 2)) for _ in range(int(rng.integers(1, 4)))
            ]
            layers.append(Layer(f"{pen}-{k}", paths, pen_width=width, role="hatch", pen=pen, color=color))
    plan = Plan(A4, layers)
    path = tmp_path / "round.svg"
    write_svg(plan, path)
    back = read_svg(path)
    assert [(l.name, l.pen, l.color, l.pen_width, l.role) for l in back.layers] == [
        (l.name, l.pen, l.color, l.pen_width, l.role) for l in plan.layers
    ]
    for a, b in zip(plan.layers, back.layers):
        assert np.array_equal(a.paths.offsets, b.paths.offsets)
        assert np.allclose(a.paths.points, b.paths.points, atol=1e-3)
    # One pen-change pause per run of a pen, in drawing order (when there are several pens).
    names = [p.name for p in pens_at_pauses(gcode_program(plan, load_profile("grbl-servo-a4")))]
    assert names == (list(plan.pens) if len(plan.pens) > 1 else [])
