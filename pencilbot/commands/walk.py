"""``pencilbot walk --x MM --y MM --port PORT``: move the carriage by a distance."""

from __future__ import annotations

import argparse

from pencilbot.commands.at_plotter import add_plotter_options, carriage_words, open_plotter
from pencilbot.commands.options import number
from pencilbot.machine.bed import MAX_BED


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "walk",
        help="move the carriage by a distance (mm)",
        description="Move the carriage by --x and --y mm at the profile's travel speed, the pen as it is "
        "(GRBL: a $J= jog; Marlin: G91 G0; EBB: XM/SM; HP-GL: PR), and print where it then stands.",
    )
    for axis in ("x", "y"):
        p.add_argument(
            f"--{axis}",
            type=number(f"--{axis}", low=-MAX_BED, high=MAX_BED, unit="mm"),
            default=0.0,
            metavar="MM",
            help=f"mm along {axis.upper()} (default %(default)g)",
        )
    add_plotter_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    with open_plotter(args) as plotter:
        where = plotter.walk(args.x, args.y)
    if not args.quiet:
        print(f"walked X{args.x:g} Y{args.y:g} mm" + (f"; {carriage_words(where)}" if where else ""))
    return 0
