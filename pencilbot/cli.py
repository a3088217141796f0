"""Command-line entry point: a thin dispatcher over ``pencilbot.commands``.

Each subcommand lives in its own module under :mod:`pencilbot.commands` and exposes
``add_parser(subparsers)`` (which registers the parser and sets ``func``). User errors
(:class:`~pencilbot.errors.PencilbotError`) print one line and exit non-zero, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys

from pencilbot import __version__
from pencilbot.errors import PencilbotError

# Order is the order shown in --help.
COMMANDS = ["sketch", "plan", "stat", "export", "simulate", "sim_serve", "draw", "demo"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pencilbot",
        description="Turn a photo into a pencil drawing and draw it with a pen plotter.",
    )
    parser.add_argument("--version", action="version", version=f"pencilbot {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"pencilbot.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"pencilbot.commands.{name}":
                raise
            continue  # not built yet
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    # -v shows pencilbot's own debug messages, not those of every library (Pillow, ...).
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s: %(message)s")
    if getattr(args, "verbose", 0):
        for name in ("pencilbot", "sim", "firmware_protocol"):
            logging.getLogger(name).setLevel(logging.DEBUG)
    try:
        return int(args.func(args) or 0)
    except PencilbotError as err:
        print(f"pencilbot: error: {err}", file=sys.stderr)
        return err.exit_code
    except KeyboardInterrupt:
        print("pencilbot: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`, which stopped reading
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
