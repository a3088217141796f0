"""Every guard of the application layer holds through every front door: the CLI, the library
API, the vpype plugin and the studio refuse the same request with the same words, before the
photo is read (issue 34: the memory check was the CLI's alone, the sheet and pen caps the
studio's alone, the API had none)."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from pencilbot import api
from pencilbot.app import photo as app_photo
from pencilbot.app.photo import INTERACTIVE, Limits, PhotoRequest, prepare
from pencilbot.cli import main
from pencilbot.errors import PencilbotError
from pencilbot.studio.options import DrawingOptions, parse_options

SMALL_MACHINE = 2 << 30  # 2 GB free: a 3 x 3 m sheet with a 0.5 mm pen needs about 20 GB to plan


@pytest.fixture
def photo(tmp_path):
    path = tmp_path / "p.png"
    Image.fromarray(np.full((40, 60), 128, np.uint8)).save(path)
    return path


def cli_refusal(capsys, *argv) -> str:
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error: ") and err.count("\n") == 1, err
    return err.removeprefix("pencilbot: error: ").strip()


def api_refusal(**kwargs) -> str:
    with pytest.raises(PencilbotError) as refused:
        api.plan(kwargs.pop("photo"), **kwargs)
    return str(refused.value)


def vpype_refusal(photo, *options) -> str:
    vpype = pytest.importorskip("vpype")
    vpype_cli = pytest.importorskip("vpype_cli")
    import click

    from pencilbot.vpype_plugin import pencilbot

    run = pencilbot.main(args=[*options, str(photo)], standalone_mode=False)
    with pytest.raises(click.ClickException) as refused:
        run(vpype_cli.State(vpype.Document()))
    return refused.value.message


def studio_refusal(**controls) -> str:
    with pytest.raises(PencilbotError) as refused:
        parse_options(controls)
    return str(refused.value)


def test_a_page_too_large_for_memory_is_refused_alike_by_every_door(photo, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(app_photo, "available_memory", lambda: SMALL_MACHINE)
    said = cli_refusal(
        capsys, "plan", photo, "-o", tmp_path / "p.svg", "--page", "1100x1100", "--pen-width", "0.1"
    )
    assert said.startswith("a 1100 x 1100 mm page with a 0.1 mm pen needs about 13 GB to plan, more than")
    assert api_refusal(photo=photo, page="1100x1100", pen_width=0.1) == said
    assert api_refusal(photo=np.zeros((40, 60)), page="1100x1100", pen_width=0.1) == said  # an array too
    assert vpype_refusal(photo, "--page", "1100x1100", "--pen-width", "0.1") == said
    # The studio plans with a preview, whose memory counts as well; its caps let 1100 mm through.
    assert studio_refusal(page="1100x1100", pen_width=0.1).startswith(
        "a 1100 x 1100 mm page with a 0.1 mm pen needs about 14 GB to plan and preview"
    )
    assert not (tmp_path / "p.svg").exists()


def test_a_page_that_fits_in_memory_is_planned_by_the_api(photo, monkeypatch):
    monkeypatch.setattr(app_photo, "available_memory", lambda: SMALL_MACHINE)
    page = api.plan(photo, page="A5").page  # the guard refuses no ordinary sheet
    assert sorted((page.width, page.height)) == pytest.approx([148, 210])


def test_a_value_the_style_refuses_is_refused_alike_by_every_door(photo, tmp_path, capsys):
    said = cli_refusal(capsys, "plan", photo, "-o", tmp_path / "p.svg", "--page", "A99")
    for door_said in (
        api_refusal(photo=photo, page="A99"),
        vpype_refusal(photo, "--page", "A99"),
        studio_refusal(page="A99"),
    ):
        # The same rule of the style's schema; only who gave the value differs.
        assert door_said.split(": ", 1)[-1] == said.split(": ", 1)[-1]
        assert "A99" in door_said


def test_an_unknown_pen_set_is_refused_alike_by_the_cli_the_api_and_vpype(photo, tmp_path, capsys):
    said = cli_refusal(capsys, "plan", photo, "-o", tmp_path / "p.svg", "--pens", "no-such-pens")
    assert api_refusal(photo=photo, pens="no-such-pens") == said
    assert vpype_refusal(photo, "--pens", "no-such-pens") == said


@pytest.mark.parametrize(
    ("controls", "words"),
    [
        ({"page": "3000x3000"}, "page 3000x3000 is larger than the studio plans (1200 mm a side)"),
        ({"pen_width": 0.06}, "pen width 0.06 mm is below the studio's 0.1 mm"),
    ],
)
def test_the_studio_s_caps_are_the_layer_s_interactive_limits(controls, words, monkeypatch):
    monkeypatch.setattr(app_photo, "available_memory", lambda: 1 << 40)  # memory is not what refuses here
    assert studio_refusal(**controls) == words
    # The same guard in the layer for any door that asks for it; without it the page plans.
    request = PhotoRequest(overrides=controls, limits=INTERACTIVE)
    with pytest.raises(PencilbotError, match=words.replace("(", r"\(").replace(")", r"\)")):
        prepare(request)
    assert prepare(PhotoRequest(overrides=controls, limits=Limits())).style


def test_the_pens_width_is_the_one_the_guards_check():
    """With a pen set the darkest pen's width is drawn: that is the width the caps see."""
    narrow = DrawingOptions(pens="cmyk", pen_width=5.0)
    prepared = narrow.prepared()
    assert prepared.style.pen_width == 5.0 and prepared.drawn.pen_width < 5.0
