"""``pencilbot home --port PORT``: pen up, carriage home."""

from __future__ import annotations

import argparse

from pencilbot.commands.at_plotter import add_plotter_options, carriage_words, open_plotter


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "home",
        help="raise the pen and take the carriage home",
        description="Raise the pen and take the carriage home: to its switches on a machine that homes "
        "(GRBL $H, Marlin G28), else to where it started (machine 0,0; an EBB: where its motors were "
        "switched on, HM; HP-GL: PA0,0).",
    )
    add_plotter_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    with open_plotter(args) as plotter:
        where = plotter.home()
    if not args.quiet:
        print("home" + (f": {carriage_words(where)}" if where else ""))
    return 0
