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
