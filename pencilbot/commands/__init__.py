"""One module per CLI subcommand; each defines ``add_parser(subparsers)``.

Shared options are built in :mod:`pencilbot.commands.options`, shared helpers (a photo's plan, the
memory checks) live in :mod:`pencilbot.commands.common`. :func:`build_parser` is here, not
in :mod:`pencilbot.cli`, because a command (``completion``) describes all the others.
"""

from __future__ import annotations

import argparse
import importlib

from pencilbot import __version__
from pencilbot.errors import PencilbotError

# Order is the order shown in --help.
COMMANDS = [
    "sketch",
    "plan",
    "optimize",
    "stat",
    "export",
    "simulate",
    "sim_serve",
    "draw",
    "pen",
    "align",
    "walk",
    "home",
    "ports",
    "studio",
    "demo",
    "completion",
]


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose usage mistakes (a missing argument, ``--page -1x-1`` read as an
    option) are one ``pencilbot: error:`` line like every other, not a usage dump."""

    def error(self, message: str):
        hint = f"; see {self.prog} --help"
        if "expected one argument" in message:
            hint += " (a value that starts with '-' is given as --option=VALUE)"
        raise PencilbotError(message + hint)


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The parser of every command, or of command ``only`` alone (a module name from COMMANDS).

    Raises
    ------
    ProfileError
        The user's settings file (which gives the default profile and style) is not valid.
    """
    parser = _Parser(
        prog="pencilbot", description="Turn a photo into a pencil drawing and draw it with a pen plotter."
    )
    parser.add_argument("--version", action="version", version=f"pencilbot {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS if only is None else [only]:
        importlib.import_module(f"pencilbot.commands.{name}").add_parser(sub)
    return parser
