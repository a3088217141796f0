"""``pencilbot align --port PORT``: motors off, so the carriage moves by hand to place the paper
(``--on``: on again)."""

from __future__ import annotations

import argparse

from pencilbot.commands.at_plotter import add_plotter_options, open_plotter


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "align",
        help="switch the motors off to move the carriage by hand and place the paper",
        description="Switch the plotter's motors off (EBB: EM,0,0; Marlin: M18; GRBL: its step idle delay $1 "
        "releases them after each move) so the carriage moves by hand: place the paper, push the carriage "
        "home. --on switches them on again. An HP-GL plotter has no such command.",
    )
    p.add_argument("--on", action="store_true", help="switch the motors on instead")
    add_plotter_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    with open_plotter(args) as plotter:
        said = plotter.motors(args.on)
    if not args.quiet:
        print(said)
    return 0
