"""Plotter profiles: the shipped set loads, every kind of mistake is one clear ProfileError."""

from __future__ import annotations

import copy
import string

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from profile_tables import shipped_table, toml_text

from pencilbot.errors import ProfileError
from pencilbot.machine.profile import TEMPLATE_FIELDS, list_profiles, load_profile
from pencilbot.machine.templates import TemplateError, check_template, fill_template

SHIPPED = ["grbl-servo-a4", "grbl-z-a3", "grblhal-servo-a3", "marlin-servo-a4"]


def write_profile(tmp_path, table: dict, name: str = "myplotter.toml"):
    path = tmp_path / name
    path.write_text(toml_text(table), encoding="utf-8")
    return path


def test_shipped_profiles_are_listed_and_load():
    assert set(SHIPPED) <= set(list_profiles())
    for name in list_profiles():
        profile = load_profile(name)
        assert profile.name == name  # the file name is the name users type
        assert profile.firmware.name == profile.dialect
        assert profile.description


def test_shipped_profiles_follow_their_dialects():
    servo = load_profile("grbl-servo-a4")
    assert servo.render(servo.pen.up_command) == ["M3 S30"]  # ints print without ".0"
    assert servo.render(servo.pen.down_command) == ["M3 S90"]
    z = load_profile("grbl-z-a3")
    assert z.pen.kind == "z" and z.pen.up > z.pen.down
    assert z.bed.invert_x and z.bed.invert_y and z.bed.origin == "top-right"
    marlin = load_profile("marlin-servo-a4")
    assert marlin.dialect == "marlin"
    assert marlin.render(marlin.pen.up_command) == ["M400", "M280 P0 S50"]


def test_profile_by_path_round_trips_the_table(tmp_path):
    table = shipped_table("grbl-z-a3")
    path = write_profile(tmp_path, table)
    assert load_profile(path) == load_profile(str(path)) != load_profile("grbl-z-a3")  # source differs
    profile = load_profile(path)
    assert profile.source == str(path)
    assert (profile.bed.width, profile.motion.draw_feed, profile.pen.down) == (310.0, 2400.0, 0.0)


def test_name_defaults_to_the_file_name(tmp_path):
    table = shipped_table()
    del table["name"]
    assert load_profile(write_profile(tmp_path, table, "studio.toml")).name == "studio"


def test_motion_is_in_mm_per_second_and_the_pen_model_has_its_commands():
    profile = load_profile("grbl-servo-a4")
    assert profile.motion.draw_speed == pytest.approx(3000.0 / 60)
    assert profile.motion.travel_speed == pytest.approx(6000.0 / 60)
    assert (profile.motion.acceleration, profile.motion.junction_deviation) == (800.0, 0.01)
    pen = profile.pen_model
    assert (pen.kind, pen.up, pen.down, pen.up_lines, pen.down_lines) == (
        "spindle",
        30,
        90,
        ("M3 S30",),
        ("M3 S90",),
    )
    assert (pen.up_delay, pen.down_delay) == (0.15, 0.2)
    assert not pen.moves_with_the_axes and load_profile("grbl-z-a3").pen_model.moves_with_the_axes
    assert profile.firmware.title == "GRBL" and profile.receive_buffer == 128


def _set(section, key, value):
    def change(t):
        (t[section] if section else t)[key] = value

    return change


def _drop(section, key):
    def change(t):
        del (t[section] if section else t)[key]

    return change


# (change to a valid profile, words the message must contain)
BAD = {
    "unknown key": (_set("bed", "widht", 300), ["[bed] widht", "width, height"]),
    "unknown top-level key": (_set("", "colour", "red"), ["colour", "dialect"]),
    "wrong type (string for number)": (_set("bed", "width", "300"), ["[bed] width", "'300'", "number > 0"]),
    "wrong type (number for flag)": (_set("bed", "invert_y", 1), ["[bed] invert_y", "true or false"]),
    "wrong type (number for template)": (_set("pen", "up_command", 3), ["[pen] up_command", "string"]),
    "missing key": (_drop("motion", "draw_feed"), ["missing key [motion] draw_feed", "mm/min"]),
    "missing dialect": (_drop("", "dialect"), ["missing key dialect", '"grbl" or "grblhal" or "marlin"']),
    "missing table": (_drop("", "pen"), ["missing table [pen]", "kind"]),
    "not a table": (_set("", "bed", 5), ["bed = 5", "table [bed]"]),
    "negative feed": (
        _set("motion", "travel_feed", -100),
        ["[motion] travel_feed = -100", "≥ 1 and ≤ 1000000 mm/min"],
    ),
    "zero feed": (_set("motion", "draw_feed", 0), ["[motion] draw_feed = 0", "≥ 1 and"]),
    "negative delay": (_set("pen", "down_delay", -0.1), ["[pen] down_delay", "≥ 0 and ≤ 60 seconds"]),
    "absurd feed": (_set("motion", "draw_feed", 3e9), ["[motion] draw_feed", "≤ 1000000 mm/min"]),
    "huge bed": (_set("bed", "height", 1e6), ["[bed] height", "≤ 10000 mm"]),
    "bad origin": (_set("bed", "origin", "middle"), ["[bed] origin", '"top-left"']),
    "bad dialect": (_set("", "dialect", "smoothie"), ["dialect = 'smoothie'", '"marlin"']),
    "bad pen kind": (_set("pen", "kind", "laser"), ["[pen] kind", '"servo"']),
    "too many decimals": (_set("gcode", "decimals", 9), ["[gcode] decimals = 9", "0 to 6"]),
    "float decimals": (_set("gcode", "decimals", 2.5), ["[gcode] decimals", "whole number"]),
    "tiny receive buffer": (_set("gcode", "receive_buffer", 64), ["[gcode] receive_buffer", "81"]),
    "line numbers on grbl": (_set("gcode", "line_numbers", True), ["line_numbers", '"grbl"', "false"]),
    "attribute access": (_set("pen", "up_command", "M3 S{up.__class__}"), ["{up.__class__}", "plain field"]),
    "index access": (_set("pen", "down_command", "M3 S{down[0]}"), ["{down[0]}", "plain field"]),
    "positional field": (_set("pen", "up_command", "M3 S{}"), ["[pen] up_command", "plain field"]),
    "numbered field": (_set("pen", "up_command", "M3 S{0}"), ["{0}", "plain field"]),
    "conversion": (_set("pen", "up_command", "M3 S{up!r}"), ["{up!r}", "conversion"]),
    "format spec": (_set("gcode", "header", "G21 {up:>20}"), ["[gcode] header", "'>20'", ".1f"]),
    "nested spec": (_set("pen", "up_command", "M3 S{up:{down}}"), ["[pen] up_command", "format spec"]),
    "unknown field": (_set("gcode", "footer", "M5 {secret}"), ["{secret}", "{travel_feed}"]),
    "unbalanced brace": (_set("pen", "up_command", "M3 S{up"), ["[pen] up_command", "{{"]),
    "empty pen command": (_set("pen", "down_command", " \n "), ["[pen] down_command is empty"]),
    "non-ASCII template": (_set("gcode", "header", "G21 ; millimètres"), ["[gcode] header", "ASCII"]),
    "line too long": (_set("gcode", "header", "G21 " + "G90 " * 25), ["[gcode] header", "at most 80"]),
    "soft limits without homing": (_set("bed", "soft_limits", True), ["[bed] soft_limits", "homing = true"]),
}


def test_homing_and_soft_limits_are_off_unless_the_profile_says(tmp_path):
    assert all(
        not (p.bed.homing or p.bed.soft_limits) for p in map(load_profile, SHIPPED)
    )  # GRBL's factory state
    table = shipped_table()
    table["bed"].update(homing=True, soft_limits=True)
    bed = load_profile(write_profile(tmp_path, table)).bed
    assert bed.homing and bed.soft_limits


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_bad_profile_is_one_clear_error_naming_file_and_key(tmp_path, case):
    change, words = BAD[case]
    table = copy.deepcopy(shipped_table())
    change(table)
    path = write_profile(tmp_path, table)
    with pytest.raises(ProfileError) as err:
        load_profile(path)
    message = str(err.value)
    assert message.startswith(f"plotter profile {path}:")
    for word in words:
        assert word in message
    assert "\n" not in message


def test_z_pen_must_lift_upwards(tmp_path):
    table = shipped_table("grbl-z-a3")
    table["pen"]["up"] = -1.0
    with pytest.raises(ProfileError, match=r"\[pen\] up = -1 .*above down = 0 mm"):
        load_profile(write_profile(tmp_path, table))


def test_numbered_marlin_lines_leave_room_for_the_frame(tmp_path):
    table = shipped_table("marlin-servo-a4")
    table["gcode"]["line_numbers"] = True
    table["gcode"]["footer"] = "M117 " + "x" * 70  # fits 80, not 80 - "N… *cs"
    with pytest.raises(ProfileError, match="at most 67 per line"):
        load_profile(write_profile(tmp_path, table))


def test_unreadable_and_unknown_profiles(tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text("name = 'x\n", encoding="utf-8")
    with pytest.raises(ProfileError, match=r"broken.toml is not valid TOML .*fix the syntax"):
        load_profile(broken)
    with pytest.raises(ProfileError, match=r"cannot read plotter profile .*missing.toml"):
        load_profile(tmp_path / "missing.toml")
    with pytest.raises(ProfileError, match=r"no plotter profile named 'axidraw'.*grbl-servo-a4"):
        load_profile("axidraw")


# --- the substitution itself ---------------------------------------------------------------------

_ALPHABET = "{}[].!:0123456789 updownxfG_r>"


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet=_ALPHABET, max_size=20))
def test_templates_fill_only_plain_allowed_fields(template):
    values = dict.fromkeys(TEMPLATE_FIELDS, 12.5)
    try:
        check_template(template, TEMPLATE_FIELDS)
    except TemplateError:
        with pytest.raises(TemplateError):
            fill_template(template, values)
        return
    fields = [f for _, f, _, _ in string.Formatter().parse(template) if f is not None]
    assert all(f in TEMPLATE_FIELDS for f in fields)  # bare names only: no '.', '[', positions
    assert all(conv is None for _, f, _, conv in string.Formatter().parse(template) if f is not None)
    assert fill_template(template, values) == template.format(**values)


def test_precision_is_the_one_format_spec_allowed():
    assert fill_template("G0 Z{up:.1f}", {"up": 4}) == "G0 Z4.0"
    assert fill_template("M3 S{up}", {"up": 30}) == "M3 S30"
    assert fill_template("{{literal}}", {}) == "{literal}"
    for bad in ("{up:x}", "{up:10}", "{up:.1e}", "{up:.12f}", "{up:,}"):
        with pytest.raises(TemplateError):
            fill_template(bad, {"up": 4})
