"""Every command speaks the same way: the same option has the same default and spelling
everywhere, old spellings still work for a release with a note, a resumed job's options can be
overridden."""

from __future__ import annotations

import pytest

from pencilbot.cli import build_parser, main
from pencilbot.commands.draw import connection_options


def test_a_given_on_error_overrides_the_resumed_job_s_either_way():
    parser = build_parser()
    journal = {"timeout": 3.0, "send_and_wait": True, "on_error": "continue"}
    given = parser.parse_args(["draw", "--resume", "job", "--on-error", "stop"])
    assert connection_options(given, journal) == (3.0, True, "stop")
    kept = parser.parse_args(["draw", "--resume", "job"])
    assert connection_options(kept, journal) == (3.0, True, "continue")
    assert connection_options(kept, {})[2] == "stop"


def test_the_virtual_plotter_s_speed_has_one_default():
    parser = build_parser()
    simulate = parser.parse_args(["simulate", "x.gcode", "-o", "x.png"])
    serve = parser.parse_args(["sim-serve"])
    assert simulate.realtime == serve.realtime == 0.0 and simulate.dpi == serve.dpi


def test_draw_takes_a_profile_as_the_other_commands_do(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["draw", "--list-profiles"])
    assert stop.value.code == 0
    assert "grbl-servo-a4" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["draw", "--help"])
    assert "--profile NAME|FILE.toml" in capsys.readouterr().out


def test_demo_takes_a_positional_photo_and_o_and_its_old_spellings_with_a_note(capsys):
    parser = build_parser()
    new = parser.parse_args(["demo", "p.png", "-o", "out"])
    old = parser.parse_args(["demo", "--input", "p.png", "--out", "out"])
    assert (new.input, new.output) == (old.old_input, old.output) == ("p.png", "out")
    err = capsys.readouterr().err
    assert "--input is deprecated" in err and "--out is deprecated" in err and "-o/--output" in err
