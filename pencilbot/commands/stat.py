"""``pencilbot stat``: what a plan costs at the plotter — lengths, lifts and estimated time."""

from __future__ import annotations

import argparse
import json

from pencilbot.commands.common import add_verbosity
from pencilbot.machine.profile import DEFAULT_PROFILE, load_profile
from pencilbot.planning.stats import PlanStats, Stats, duration_text, estimate
from pencilbot.export.svg import read_svg


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "stat",
        help="pen-down/up length, lifts and estimated plot time of a plan",
        description=(
            "Print pen-down length, pen-up length, lifts, paths, segments and the estimated "
            "plot time of a plan SVG, per layer and in total: the program `pencilbot export` "
            "writes for the plotter profile, with its acceleration, junction deviation, pen "
            "delays and Z moves, from and back to its home (the G-code header says the same)."
        ),
    )
    parser.add_argument("plan", metavar="PLAN.svg", help="plan written by `pencilbot plan`")
    parser.add_argument("--profile", default=DEFAULT_PROFILE, metavar="NAME|FILE.toml",
                        help="plotter profile for speeds, delays and where home is (default %(default)s)")
    parser.add_argument("--json", action="store_true", help="print JSON (lengths in mm, time in s)")
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    profile = load_profile(args.profile)
    stats = estimate(read_svg(args.plan), profile)
    if args.json:
        print(json.dumps({"plan": args.plan, "profile": args.profile, **stats.as_dict()}, indent=2))
    elif not args.quiet:
        print(format_table(stats))
    return 0


def format_table(stats: PlanStats) -> str:
    """Per-layer rows and a total row: lengths in metres, time as h:mm:ss."""
    header = ("layer", "pen-down", "pen-up", "lifts", "paths", "segments", "time")
    rows = [_row(name, s) for name, s in stats.layers.items()] + [_row("total", stats.total)]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    line = lambda r: "  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths)))  # noqa: E731
    return "\n".join([line(header), *(line(r) for r in rows[:-1]), line(["-" * w for w in widths]), line(rows[-1])])


def _row(name: str, s: Stats) -> list[str]:
    return [
        name,
        f"{s.pen_down_mm / 1000:.2f} m",
        f"{s.pen_up_mm / 1000:.2f} m",
        str(s.lifts),
        str(s.paths),
        str(s.segments),
        duration_text(s.seconds),
    ]
