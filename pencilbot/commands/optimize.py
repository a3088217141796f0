"""``pencilbot optimize``: reorder an SVG drawing (any tool's) for the plotter, and say what it saves."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

from pencilbot.commands.common import change_summary, output_beside, read_drawing, reorder_on
from pencilbot.commands.options import add_profile_option, add_svg_options, add_verbosity, number
from pencilbot.errors import PencilbotError
from pencilbot.export.svg import write_svg
from pencilbot.machine.profile import load_profile
from pencilbot.planning.optimize import REORDER_ROUNDS

MAX_ROUNDS = 1000  # improvement passes per layer: each one finds less, and costs as much as the first
MAX_TIME_BUDGET = 86_400.0  # a day of CPU


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "optimize",
        help="reorder an SVG drawing for less pen-up travel",
        description=(
            "Reorder the paths of an SVG drawing (from Inkscape, vpype, a hatching or contour "
            "tool, or pencilbot) for a pen plotter, layer by layer in the layers' order: paths are "
            "reversed where that helps, ends within a pen width are joined pen-down, specks shorter "
            "than the pen width lying on other lines are dropped, and pen-up travel never gets "
            "longer. Writes the drawing as a pencilbot plan SVG and prints pen-up travel, lifts "
            "and plot time on the plotter profile's machine before and after."
        ),
    )
    parser.add_argument("input", metavar="IN.svg", help="SVG drawing")
    parser.add_argument(
        "-o", "--output", metavar="OUT.svg", help="SVG to write (default: IN-optimized.svg beside it)"
    )
    add_profile_option(parser, "plotter profile for home, speeds and delays")
    parser.add_argument(
        "--rounds",
        type=number("--rounds", low=0, high=MAX_ROUNDS, whole=True),
        default=REORDER_ROUNDS,
        metavar="N",
        help="improvement passes per layer: more shortens pen-up a little more, slower "
        "(default %(default)s, as a photo's plan; huge layers get fewer, at least 2)",
    )
    parser.add_argument(
        "--time-budget",
        type=number("--time-budget", low=0, above=True, high=MAX_TIME_BUDGET, unit="s"),
        metavar="SECONDS",
        help="CPU seconds the reordering may take in all: huge layers then get as "
        "many rounds as fit (the order then depends on the machine's speed)",
    )
    parser.add_argument(
        "--json", action="store_true", help="print the figures as JSON (lengths in mm, time in s)"
    )
    add_svg_options(parser, sheet=True)
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    source, output = Path(args.input), output_beside(args, "optimized", ".svg")
    for path, what in ((source, "input"), (output, "output")):
        if path.suffix.lower() != ".svg":
            raise PencilbotError(
                f"the {what} {path} is not an .svg file; optimize reorders SVG drawings "
                "(a photo becomes one with pencilbot plan)"
            )
    profile = load_profile(args.profile)  # a bad profile fails before the file is read
    plan = read_drawing(source, args)
    said = args.json or not args.quiet  # the estimates cost a second each at a million paths
    reordered, before, after = reorder_on(
        plan, profile, rounds=args.rounds, time_budget=args.time_budget, estimates=said
    )
    result = reordered.plan
    if "source" not in result.meta:
        result = dataclasses.replace(result, meta={**result.meta, "source": str(source)})
    write_svg(result, output)
    if args.json:
        print(
            json.dumps(
                {
                    "input": str(source),
                    "output": str(output),
                    "profile": profile.name,
                    "specks_dropped": reordered.specks,
                    "before": before.as_dict()["total"],
                    "after": after.as_dict()["total"],
                },
                indent=2,
            )
        )
    elif not args.quiet:
        print(
            f"wrote {output}: {before.total.paths} → {after.total.paths} paths on {profile.name}; "
            + change_summary(before.total, after.total, reordered.specks)
        )
    return 0
