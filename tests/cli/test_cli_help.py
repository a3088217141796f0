"""Every command's ``--help`` prints and exits 0: a help text is formatted by argparse with
``%``, so a stray percent sign in one option's help turns the whole page into a TypeError."""

from __future__ import annotations

import argparse

import pytest

from pencilbot.cli import build_parser, main


def _commands() -> list[str]:
    parser = build_parser()
    (sub,) = [action for action in parser._actions if isinstance(action, argparse._SubParsersAction)]
    return sorted(sub.choices)


@pytest.mark.parametrize("command", _commands())
def test_every_commands_help_prints(command, capsys):
    with pytest.raises(SystemExit) as stop:
        main([command, "--help"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: pencilbot " + command) and "options:" in out


def _help(command: str, capsys) -> str:
    with pytest.raises(SystemExit):
        main([command, "--help"])
    return capsys.readouterr().out


def _options_shown(command: str) -> dict[str, str]:
    """Each option ``command``'s help shows, with its help text."""
    parser = build_parser()
    (sub,) = [action for action in parser._actions if isinstance(action, argparse._SubParsersAction)]
    return {
        flag: action.help or ""
        for action in sub.choices[command]._actions
        if action.help != argparse.SUPPRESS
        for flag in action.option_strings
    }


def test_baud_and_port_mean_one_thing_in_every_help():
    """``--baud`` is the serial line's speed and ``--port`` the plotter's port wherever they are
    shown; the simulator's emulated line and the studio's extra port have names of their own."""
    for command in _commands():
        shown = _options_shown(command)
        if "--baud" in shown:
            assert "emulat" not in shown["--baud"], command
        if "--port" in shown:
            assert "besides" not in shown["--port"] and "offer" not in shown["--port"], command
    assert "--emulate-baud" in _options_shown("sim-serve") and "--baud" not in _options_shown("sim-serve")
    assert "--offer-port" in _options_shown("studio") and "--port" not in _options_shown("studio")


@pytest.mark.parametrize(
    ("argv", "dest", "value", "note"),
    [
        (["sim-serve", "--baud", "9600"], "emulate_baud", 9600, "--baud is deprecated"),
        (["studio", "--port", "/dev/ttyUSB0"], "offer_port", "/dev/ttyUSB0", "--port is deprecated"),
    ],
)
def test_the_old_spellings_still_work_for_a_release_with_a_note(argv, dest, value, note, capsys):
    assert getattr(build_parser().parse_args(argv), dest) == value
    err = capsys.readouterr().err
    assert note in err and "use --" in err
