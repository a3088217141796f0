"""``pencilbot stat``: what a plan costs at the plotter — lengths, lifts and estimated time."""

from __future__ import annotations

import argparse
import json

from pencilbot.commands.common import add_verbosity
from pencilbot.planning.motion import MotionSettings, PlanStats, Stats, duration_text, estimate
from pencilbot.planning.svg import read_svg


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "stat",
        help="pen-down/up length, lifts and estimated plot time of a plan",
        description=(
            "Print pen-down length, pen-up length, lifts, paths, segments and the estimated "
            "plot time of a plan SVG, per layer and in total. The time follows GRBL's motion "
            "model (acceleration, junction deviation, pen delays) with the given plotter "
            "profile's settings, or defaults."
        ),
    )
    parser.add_argument("plan", metavar="PLAN.svg", help="plan written by `pencilbot plan`")
    parser.add_argument("--profile", metavar="NAME|FILE", help="plotter profile for speeds and delays")
    parser.add_argument("--json", action="store_true", help="print JSON (lengths in mm, time in s)")
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    plan = read_svg(args.plan)
    settings = _settings(args.profile)
    stats = estimate(plan, settings)
    if args.json:
        print(json.dumps({"plan": args.plan, "profile": args.profile, **stats.as_dict()}, indent=2))
    elif not args.quiet:
        print(format_table(stats))
    return 0


def _settings(profile: str | None) -> MotionSettings:
    if profile is None:
        return MotionSettings()
    # Imported here: profiles are the G-code side's, and stat works without them.
    from pencilbot.gcode.profiles import load_profile

    return load_profile(profile).motion_settings()


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
