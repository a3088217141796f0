"""Profiles range-checked for every family (issue 33): a value that cannot draw correctly is
refused when the profile loads, naming the key (an EBB ``steps_per_mm = 1e-9`` drew nothing and
``up = 200`` drew 15 of 37 strokes, both exit 0), and ``export`` never writes a line the board
rejects (``M3 S1e+308``, ``M3 S-30``, a ``$RST=*`` pen lift, a ``G91`` or ``G20`` header)."""

import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from profile_tables import shipped_table, toml_text

from pencilbot.cli import main
from pencilbot.errors import ProfileError
from pencilbot.machine.profile import profile_from_mapping


def load_with(name: str, section: str, key: str, value):
    found = shipped_table(name)
    found.setdefault(section, {})[key] = value
    return profile_from_mapping(found, where="test.toml")


REFUSED = [
    ("axidraw-v3", "ebb", "steps_per_mm", 1e-9, "[ebb] steps_per_mm"),
    ("axidraw-a3", "pen", "up", 200, "[pen] up = 200"),
    ("nextdraw-8511", "pen", "down", -5, "[pen] down = -5"),
    ("axidraw-v3", "ebb", "servo_max", 100, "[ebb] servo_max"),
    ("grbl-servo-a4", "pen", "up", 1e308, "[pen] up = 1e+308"),
    ("grbl-servo-a4", "pen", "up", -30, "[pen] up = -30"),
    ("grbl-servo-a4", "pen", "down", 1e-7, "[pen] down_command line 'M3 S1e-07'"),
    ("grbl-servo-a4", "pen", "up_command", "$RST=*", "[pen] up_command line '$RST=*'"),
    ("grbl-servo-a4", "pen", "down_command", "$N0=M3S90", "[pen] down_command line '$N0=M3S90'"),
    ("grbl-servo-a4", "gcode", "header", "G21\nG91", "[gcode] header leaves G91"),
    ("grbl-servo-a4", "gcode", "header", "G90 G20", "[gcode] header leaves G20"),
    ("grblhal-servo-a3", "gcode", "footer", "G91 G0 X1", "[gcode] footer leaves G91"),
    ("marlin-servo-a4", "pen", "up", 400, "[pen] up = 400"),
    ("grbl-z-a3", "pen", "up", 1e6, "[pen] up = 1000000"),
    ("hp7475a", "motion", "draw_feed", 1e6, "[motion] draw_feed"),
]


@pytest.mark.parametrize("name, section, key, value, named", REFUSED)
def test_a_value_that_cannot_draw_is_refused_when_the_profile_loads(name, section, key, value, named):
    with pytest.raises(ProfileError, match="^plotter profile test.toml: " + re.escape(named)):
        load_with(name, section, key, value)


@pytest.mark.parametrize("name, section, key, value, named", REFUSED[:8])
def test_export_with_such_a_profile_writes_nothing(tmp_path, capsys, name, section, key, value, named):
    found = shipped_table(name)
    found.setdefault(section, {})[key] = value
    (tmp_path / "p.toml").write_text(toml_text(found))
    svg = tmp_path / "d.svg"
    svg.write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" width="50mm" height="50mm" viewBox="0 0 50 50">'
        '<path d="M 5 5 L 40 40" stroke="black"/></svg>'
    )
    code = main(
        ["export", str(svg), "-o", str(tmp_path / "d.gcode"), "--profile", str(tmp_path / "p.toml"), "-q"]
    )
    err = capsys.readouterr().err
    assert code == 2 and named.split(" =")[0].split(" line")[0] in err and err.count("\n") == 1, err
    assert not (tmp_path / "d.gcode").exists()


def test_a_template_may_switch_modes_if_it_switches_back():
    profile = load_with("grbl-z-a3", "pen", "up_command", "G91 G0 Z2 G90")
    assert profile.pen_model.up_lines == ("G91 G0 Z2 G90",)


@settings(max_examples=80, deadline=None)
@given(
    up=st.floats(-1e9, 1e9),
    down=st.floats(-1e9, 1e9),
    name=st.sampled_from(["axidraw-v3", "grbl-servo-a4", "grbl-z-a3", "marlin-servo-a4", "hp7475a"]),
)
def test_every_pen_value_loads_in_range_or_is_refused_by_key(up, down, name):
    found = shipped_table(name)
    found["pen"].update(up=up, down=down)
    try:
        profile = profile_from_mapping(found, where="test.toml")
    except ProfileError as exc:
        assert str(exc).startswith("plotter profile test.toml: [pen] ")
        return
    assert -1000 <= profile.pen.up <= 1e5 and -1000 <= profile.pen.down <= 1e5
    if name == "axidraw-v3":
        assert 0 <= profile.pen.up <= 100 and 0 <= profile.pen.down <= 100
    for line in (*profile.pen_model.up_lines, *profile.pen_model.down_lines):
        assert "e" not in line.lower().split(";")[0].replace("m", "")  # no exponent reaches the board
