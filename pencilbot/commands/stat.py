"""``pencilbot stat``: what a drawing costs at the plotter — lengths, lifts and estimated time.

An SVG (a plan of ours or any other drawing) is read as ``export`` reads it, but in its own
order; a G-code file (ours or another tool's) is read back into the pen-down paths it draws, on
a page the size of the bed. Either way the figures are the one estimate of
:func:`pencilbot.planning.stats.estimate`, the program's from the plotter's home and back.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pencilbot.commands.common import read_drawing
from pencilbot.commands.options import (
    add_profile_option,
    add_svg_options,
    add_system_commands_option,
    add_verbosity,
)
from pencilbot.errors import PencilbotError
from pencilbot.export.gcode import GCODE_SUFFIXES
from pencilbot.export.hpgl import HPGL_SUFFIXES, hpgl_plan
from pencilbot.machine.bed import Placement
from pencilbot.machine.profile import Profile, load_profile
from pencilbot.planning.plan import Layer, Page, Plan
from pencilbot.planning.stats import PlanStats, Stats, duration_text, estimate


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "stat",
        help="pen-down/up length, lifts and estimated plot time of a drawing or G-code",
        description=(
            "Print pen-down length, pen-up length, lifts, paths, segments and the estimated "
            "plot time of an SVG drawing (a plan, or any other tool's, in its own order) per "
            "layer and in total: the program `pencilbot export` writes for the plotter profile, "
            "with its acceleration, junction deviation, pen delays and Z moves, from and back to "
            "its home (the G-code header says the same). A G-code file, ours or another tool's, "
            "is read back into the paths its pen draws (the profile's pen model says what puts "
            "the pen down; arcs count as straight moves) and costed the same way."
        ),
    )
    parser.add_argument("plan", metavar="DRAWING.svg|FILE.gcode", help="SVG drawing or G-code file")
    add_profile_option(parser, "plotter profile for speeds, delays and where home is")
    parser.add_argument("--json", action="store_true", help="print JSON (lengths in mm, time in s)")
    add_svg_options(parser, sheet=True)
    add_system_commands_option(parser)
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    source = Path(args.plan)
    if source.suffix.lower() in GCODE_SUFFIXES:  # as draw: the profile the file was exported for
        from pencilbot.driver.gcode.header import profile_for

        args.profile = profile_for(
            source, args.profile if getattr(args, "profile_given", False) else None, args.profile
        )
    profile = load_profile(args.profile)
    if source.suffix.lower() in HPGL_SUFFIXES:  # HP-GL, ours or another tool's (vpype's)
        if profile.firmware.program_language != "hpgl":
            raise PencilbotError(
                f"{source} is HP-GL and profile {profile.name} is not an HP-GL plotter's; "
                "give its profile (e.g. --profile hp7475a)"
            )
        plan = hpgl_plan(source, profile)
    else:
        plan = (
            gcode_plan(source, profile, args.allow_system_commands)
            if source.suffix.lower() in GCODE_SUFFIXES
            else read_drawing(source, args)
        )
    stats = estimate(plan, profile)
    if args.json:
        print(json.dumps({"plan": args.plan, "profile": args.profile, **stats.as_dict()}, indent=2))
    elif not args.quiet:
        print(format_table(stats))
    return 0


def gcode_plan(path: Path, profile: Profile, allow: frozenset[str] = frozenset()) -> Plan:
    """What the G-code file ``path`` draws, as a one-layer plan on a page the size of the bed.

    Raises
    ------
    PencilbotError
        The file cannot be read or streamed to the profile's firmware, or its pen never goes
        down as the profile's pen model says.
    """
    from pencilbot.driver.gcode.bed_check import check_on_bed
    from pencilbot.driver.gcode.drawn import drawn_paths
    from pencilbot.driver.gcode.job import load_job

    job = load_job(path, profile, allow=allow)
    drawn = drawn_paths(job)
    if not len(drawn) and job.system.check_from is not None:
        raise PencilbotError(f"{path} draws nothing: {job.system.notes[-1]}")
    if not len(drawn):
        pen = profile.pen_model
        raise PencilbotError(
            f"{path}: the pen never goes down the way profile {profile.name} puts it down ({pen.kind} pen, "
            f"down = {pen.down:g}, up = {pen.up:g}); give the profile of the plotter it was written for (--profile)"
        )
    check_on_bed(job)  # as draw: a move off the bed is no drawing of this plotter
    bed = Page(profile.bed.width, profile.bed.height, margin=0.0, name="bed")
    placement = Placement.on_bed(bed, profile.bed)
    return Plan(bed, (Layer(path.stem, drawn.with_points(placement.to_page(drawn.points))),))


def format_table(stats: PlanStats) -> str:
    """Per-layer rows and a total row: lengths in metres, time as h:mm:ss."""
    header = ("layer", "pen-down", "pen-up", "lifts", "paths", "segments", "time")
    rows = [_row(name, s) for name, s in stats.layers.items()] + [_row("total", stats.total)]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]

    def line(r):
        return "  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths)))

    return "\n".join(
        [line(header), *(line(r) for r in rows[:-1]), line(["-" * w for w in widths]), line(rows[-1])]
    )


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
