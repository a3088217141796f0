"""Every numeric option of every command is bounded: a bad value is one line naming the option
and what it takes, exit code 2, before anything runs; and no image or page is sized past memory."""

import argparse
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pencilbot.cli import main
from pencilbot.commands import COMMANDS, build_parser


def numeric_options() -> list[tuple[str, str, tuple]]:
    """``(command, option, bounds)`` for every option read through ``options.number``."""
    found = []
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for command, parser in sub.choices.items():
        for action in parser._actions:
            if action.option_strings and hasattr(action.type, "bounds"):
                found.append((command, action.option_strings[-1], action.type.bounds))
    return found


OPTIONS = numeric_options()


def test_no_option_of_any_command_reads_a_bare_number():
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    bare = [
        (command, action.option_strings)
        for command, parser in sub.choices.items()
        for action in parser._actions
        if action.type in (int, float)
    ]
    assert bare == [] and len(sub.choices) == len(COMMANDS)
    named = {(command, option) for command, option, _ in OPTIONS}
    for must in [
        ("simulate", "--dpi"),
        ("simulate", "--realtime"),
        ("simulate", "--pen-width"),
        ("plan", "--margin"),
        ("draw", "--timeout"),
        ("draw", "--baud"),
        ("sim-serve", "--emulate-baud"),
        ("sketch", "--stroke-width"),
        ("export", "--svg-dpi"),
        ("optimize", "--rounds"),
        ("plan", "--jobs"),
    ]:
        assert must in named


def bad_values(bounds) -> st.SearchStrategy[str]:
    low, high, above, whole = bounds
    out = [
        st.sampled_from(["nan", "inf", "-inf", "NaN", "abc", "", "1e999", "0x10"]),
        st.floats(min_value=high, exclude_min=True, allow_infinity=False)
        .map(lambda v: repr(max(v, math.nextafter(high, math.inf))))
        .filter(lambda t: float(t) > high),
    ]
    if low is not None:
        below = st.floats(max_value=low, exclude_max=not above, allow_infinity=False, allow_nan=False)
        out.append(below.map(repr))
    if whole:
        out.append(st.floats(low or 0, min(high, 1e6)).filter(lambda v: not v.is_integer()).map(repr))
    return st.one_of(out)


@settings(
    max_examples=4, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)  # capsys is read each time
@pytest.mark.parametrize("command, option, bounds", OPTIONS, ids=[f"{c} {o}" for c, o, _ in OPTIONS])
@given(data=st.data())
def test_a_bad_value_is_one_line_naming_the_option(capsys, command, option, bounds, data):
    value = data.draw(bad_values(bounds))
    assert main([command, f"{option}={value}"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"pencilbot: error: {option} must be ") and err.count("\n") == 1, err
    assert f"not {value!r}" in err


@pytest.mark.parametrize(
    "argv, words",
    [
        (
            ["simulate", "x.gcode", "-o", "x.png", "--dpi", "30000"],
            "--dpi must be at least 1 and at most 10000",
        ),
        (["simulate", "x.gcode", "-o", "x.png", "--dpi", "inf"], "--dpi must be"),
        (
            ["simulate", "x.gcode", "-o", "x.png", "--pen-width", "1e9"],
            "--pen-width must be at least 0.05 and at most 50 mm",
        ),
        (["simulate", "x.gcode", "-o", "x.png", "--realtime", "nan"], "--realtime must be at least 0"),
        (["draw", "x.gcode", "--port", "sim://", "--timeout", "0"], "--timeout must be more than 0"),
        (
            ["plan", "{photo}", "-o", "{out}", "--page", "100000x100000"],
            "a 100000 x 100000 mm page with a 0.5 mm pen needs about",
        ),
    ],
)
def test_the_reported_cases_are_one_message(tmp_path, capsys, argv, words):
    import numpy as np
    from PIL import Image

    photo = tmp_path / "p.png"
    Image.fromarray(np.full((40, 60), 128, np.uint8)).save(photo)
    code = main([a.format(photo=photo, out=tmp_path / "p.svg") for a in argv])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("pencilbot: error: ") and words in err and err.count("\n") == 1, err
    assert not (tmp_path / "p.svg").exists()


def test_a_render_bigger_than_memory_is_refused_before_it_is_allocated(tmp_path, capsys, monkeypatch):
    from pencilbot.app import photo as app_photo

    monkeypatch.setattr(app_photo, "available_memory", lambda: 2 << 30)  # a small machine: 2 GB free
    src = tmp_path / "a.gcode"
    src.write_text("G21\nG90\nG0 X10 Y10\n")
    assert main(["simulate", str(src), "-o", str(tmp_path / "a.png"), "--dpi", "5000"]) == 2
    err = capsys.readouterr().err
    assert "--dpi 5000 makes the 220 x 310 mm bed 43308 x 61024 pixels" in err and "use --dpi" in err
    assert not (tmp_path / "a.png").exists()


@pytest.mark.parametrize(
    "argv",
    [
        [
            "plan",
            "{photo}",
            "-o",
            "{out}",
            "--page",
            "3000x3000",
            "--pen-width",
            "50",
            "--preview",
            "{tmp}/preview.png",
        ],
        ["demo", "{photo}", "-o", "{tmp}/demo", "--page", "3000x3000", "--pen-width", "50"],
    ],
)
def test_a_page_whose_preview_would_not_fit_is_refused_before_planning(tmp_path, capsys, monkeypatch, argv):
    import numpy as np
    from PIL import Image

    from pencilbot.app import photo as app_photo

    # 2 GB free: planning 3 x 3 m with a 50 mm pen takes 0.2 GB, its 100-150 dpi preview 3.3-7.5 GB.
    monkeypatch.setattr(app_photo, "available_memory", lambda: 2 << 30)
    photo = tmp_path / "p.png"
    Image.fromarray(np.full((40, 60), 128, np.uint8)).save(photo)
    code = main([a.format(photo=photo, out=tmp_path / "p.svg", tmp=tmp_path) for a in argv])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert (
        err.startswith("pencilbot: error: a 3000 x 3000 mm page with a 50 mm pen needs about")
        and "to plan and preview" in err
    )
    assert "wider pen" not in err  # the preview is what does not fit
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png"]  # nothing written, no folder made
