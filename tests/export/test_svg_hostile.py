"""SVGs that broke the reader in issue 33's sweep: an encoding nobody knows, a plan of ours with
numbers no plotter draws, stroke widths no pen has. Each is one plain error through ``stat`` and
``optimize`` (exit 2, one line, no traceback), for our own layout and another tool's alike."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.cli import main
from pencilbot.errors import PencilbotError
from pencilbot.export.svg import write_svg
from pencilbot.export.svg_read import is_plan_svg, read_svg
from pencilbot.planning.plan import Layer, Page, Plan


def _own(tmp_path, name="own.svg") -> tuple:
    plan = Plan(
        Page(210, 297, 10, "A4"),
        [Layer("l", [np.array([[10, 10], [20, 20.0]]), np.array([[30, 30], [40, 40.0]])], pen_width=0.5)],
    )
    path = tmp_path / name
    write_svg(plan, path)
    return path, path.read_text()


def _foreign(text: str) -> str:
    """The same file without what makes it ours: another tool's SVG."""
    for ours in (
        ' pencilbot:page="A4"',
        ' pencilbot:margin="10"',
        ' pencilbot:role="other"',
        ' xmlns:pencilbot="https://pencilbot.invalid/plan"',
    ):
        assert ours in text
        text = text.replace(ours, "")
    return text


def _cli(*argv: str) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(list(argv))
    return code, err.getvalue()


def _refused(path, tmp_path, *words: str) -> None:
    for argv in (["stat", str(path)], ["optimize", str(path), "-o", str(tmp_path / "out.svg")]):
        code, err = _cli(*argv)
        assert code == 2, (argv, err)
        assert err.count("pencilbot: error:") == 1 and "Traceback" not in err
        for word in words:
            assert word in err, (word, err)
    assert not (tmp_path / "out.svg").exists()


@pytest.mark.parametrize("foreign", [False, True])
def test_an_unknown_encoding_is_one_error(tmp_path, foreign):
    path, text = _own(tmp_path)
    text = text.replace('encoding="UTF-8"', 'encoding="klingon"')
    path.write_text(_foreign(text) if foreign else text)
    assert not is_plan_svg(path)
    with pytest.raises(PencilbotError, match="encoding"):
        read_svg(path, dpi=96)
    _refused(path, tmp_path, "klingon", "UTF-8")


@pytest.mark.parametrize("number", ["9" * 400, "1" + "0" * 13])
def test_a_plan_of_ours_with_numbers_past_any_plotter_is_refused(tmp_path, number):
    path, text = _own(tmp_path)
    assert "M 10 287" in text
    path.write_text(text.replace("M 10 287", f"M {number} 287"))
    assert is_plan_svg(path)  # it still looks like ours: the checks run on our own read too
    with pytest.raises(PencilbotError, match="reaches"):
        read_svg(path)
    _refused(path, tmp_path, "reaches")


@settings(max_examples=25, deadline=None)
@given(width=st.one_of(st.floats(-1e6, 0, exclude_max=True), st.floats(50.001, 1e12)), foreign=st.booleans())
def test_stroke_widths_no_pen_draws_are_refused_in_both_readers(tmp_path_factory, width, foreign):
    tmp_path = tmp_path_factory.mktemp("w")
    path, text = _own(tmp_path)
    text = text.replace('stroke-width="0.5"', f'stroke-width="{width!r}"')
    path.write_text(_foreign(text) if foreign else text)
    with pytest.raises(PencilbotError, match="stroke.width"):  # or past any number: svg_checks
        read_svg(path, dpi=96)


@pytest.mark.parametrize("foreign", [False, True])
@pytest.mark.parametrize("width", ["100000", "-3"])
def test_a_stroke_width_no_pen_draws_is_one_error_in_the_cli(tmp_path, foreign, width):
    path, text = _own(tmp_path)
    text = text.replace('stroke-width="0.5"', f'stroke-width="{width}"')
    path.write_text(_foreign(text) if foreign else text)
    _refused(path, tmp_path, "stroke width", width.lstrip("0") if width != "-3" else "-3")
    if foreign:  # a pen given overrides the file's stroke: then it draws
        code, err = _cli("stat", str(path), "--pen-width", "0.5")
        assert code == 0, err


def test_sane_stroke_widths_still_set_the_pen(tmp_path):
    path, text = _own(tmp_path)
    path.write_text(_foreign(text.replace('stroke-width="0.5"', 'stroke-width="1.25"')))
    assert [layer.pen_width for layer in read_svg(path).layers] == [1.25]
    path.write_text(text.replace('stroke-width="0.5"', 'stroke-width="50"'))
    assert [layer.pen_width for layer in read_svg(path).layers] == [50.0]
