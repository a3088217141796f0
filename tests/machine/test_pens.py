"""Pen sets: the shipped ones load in a light-to-dark order, every mistake is one message naming
the pen and the key, and a user's set is found by name."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.configs_io import user_folder
from pencilbot.errors import ProfileError
from pencilbot.machine.pens import list_pen_sets, load_pens

SHIPPED = ["black", "cmyk", "fineliner6", "primaries"]

GOOD = """\
description = "two pens"

[[pen]]
name = "sepia"
color = "#704214"
width = 0.3

[[pen]]
name = "sky"
color = "#87CEEB"
width = 0.8
"""


def write(tmp_path, text: str):
    path = tmp_path / "mine.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_shipped_sets_load_and_draw_lightest_first_darkest_last():
    assert list(list_pen_sets()) == SHIPPED
    for name in SHIPPED:
        pens = load_pens(name)
        order = pens.load_order
        assert [pen.luminance for pen in order] == sorted((pen.luminance for pen in order), reverse=True)
        assert pens.darkest.name == "black"
    cmyk = load_pens("cmyk")
    assert [pen.name for pen in cmyk.load_order] == ["yellow", "cyan", "magenta", "black"]
    assert len(load_pens("fineliner6").pens) == 6


def test_a_set_from_a_file_keeps_its_values(tmp_path):
    pens = load_pens(write(tmp_path, GOOD))
    assert [(p.name, p.color, p.width) for p in pens.pens] == [
        ("sepia", "#704214", 0.3),
        ("sky", "#87ceeb", 0.8),
    ]
    assert [p.name for p in pens.load_order] == ["sky", "sepia"]
    assert pens.pen("sky").rgb.tolist() == pytest.approx([0x87 / 255, 0xCE / 255, 0xEB / 255])


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (('color = "#704214"', 'color = "brown"'), ["pen 1 ('sepia') color", "#rrggbb"]),
        (('color = "#704214"', 'color = "#70421"'), ["pen 1 ('sepia') color"]),
        (("width = 0.8", "width = 0"), ["pen 2 ('sky') width", "mm"]),
        (("width = 0.8", 'width = "0.8"'), ["pen 2 ('sky') width"]),
        (("width = 0.8", "width = nan"), ["pen 2 ('sky') width"]),
        (("width = 0.8", 'width = 0.8\nink = "gel"'), ["pen 2 ('sky') has unknown key ink"]),
        (('name = "sky"', 'name = "sky (blue)"'), ["pen 2 ('sky (blue)') name", "letters"]),
        (('name = "sky"', 'name = "sepia"'), ["two pens are called 'sepia'"]),
        (("width = 0.3\n", ""), ["pen 1 ('sepia') has no width"]),
        (('description = "two pens"', 'descripton = "two pens"'), ["unknown key descripton"]),
    ],
)
def test_every_mistake_is_one_message_naming_the_pen_and_key(tmp_path, change, words):
    path = write(tmp_path, GOOD.replace(*change, 1))
    with pytest.raises(ProfileError) as err:
        load_pens(path)
    assert str(path) in str(err.value)
    for word in words:
        assert word in str(err.value)


def test_a_file_without_pens_or_not_toml_is_refused(tmp_path):
    with pytest.raises(ProfileError, match=r"one \[\[pen\]\] table per pen"):
        load_pens(write(tmp_path, 'description = "none"\n'))
    with pytest.raises(ProfileError, match="not valid TOML"):
        load_pens(write(tmp_path, "[[pen]\n"))
    with pytest.raises(ProfileError, match="no pen set named 'rainbow'; choose one of black, cmyk"):
        load_pens("rainbow")


def test_a_users_set_is_found_by_name_before_the_shipped_ones():
    folder = user_folder() / "pens"
    folder.mkdir(parents=True)
    (folder / "cmyk.toml").write_text(GOOD, encoding="utf-8")
    assert [p.name for p in load_pens("cmyk").pens] == ["sepia", "sky"]


@settings(max_examples=40, deadline=None)
@given(st.text(st.characters(codec="ascii"), min_size=1, max_size=30))
def test_only_names_that_fit_a_gcode_comment_are_accepted(tmp_path_factory, name):
    path = tmp_path_factory.mktemp("pens") / "p.toml"
    path.write_text(
        f'[[pen]]\nname = "{name.replace(chr(92), "").replace(chr(34), "")}"\ncolor = "#000000"\nwidth = 0.5\n'
    )
    try:
        pens = load_pens(path)
    except ProfileError as err:
        assert "name" in str(err) or "TOML" in str(err)
        return
    accepted = pens.pens[0].name
    assert len(accepted) <= 24 and "(" not in accepted and ")" not in accepted and ";" not in accepted
