"""``pencilbot export``: photo or plan SVG → G-code for a plotter profile."""

from __future__ import annotations

import argparse
from pathlib import Path

from pencilbot.commands.common import add_verbosity
from pencilbot.errors import PencilbotError
from pencilbot.gcode.profiles import list_profiles, load_profile
from pencilbot.gcode.writer import GcodeSummary, duration_text, write_gcode
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS, load_image
from pencilbot.planning.build import make_plan
from pencilbot.planning.plan import Plan
from pencilbot.planning.style import load_style, with_overrides
from pencilbot.planning.svg import read_svg

DEFAULT_PROFILE = "grbl-servo-a4"


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export",
        help="write G-code for a plotter from a photo or a plan SVG",
        description=(
            "Write G-code for a plotter profile. INPUT is a photo (planned with the style, page "
            "and pen width given) or a plan SVG written by `pencilbot plan`. With several "
            "inputs, -o names a folder and each input gets NAME.gcode there."
        ),
    )
    parser.add_argument("inputs", nargs="*", metavar="INPUT", help="photo or plan .svg")
    parser.add_argument(
        "-o", "--output", metavar="OUT.gcode",
        help="G-code file to write (a folder for several inputs; default: INPUT's name .gcode beside it)",
    )
    parser.add_argument(
        "--profile", default=DEFAULT_PROFILE, metavar="NAME|FILE.toml",
        help=f"shipped plotter profile or a profile file (default {DEFAULT_PROFILE}; see --list-profiles)",
    )
    parser.add_argument("--list-profiles", action="store_true", help="list the shipped profiles and exit")
    photo = parser.add_argument_group("photo inputs")
    photo.add_argument("--style", metavar="NAME|FILE.toml", help="drawing style (default: default)")
    photo.add_argument("--page", metavar="A4|WxH", help="paper size, overrides the style's (e.g. A3, 300x200)")
    photo.add_argument("--pen-width", type=float, metavar="MM", help="pen line width in mm, overrides the style's")
    photo.add_argument(
        "--max-pixels", type=int, default=DEFAULT_MAX_PIXELS, metavar="N", help="refuse larger images"
    )
    photo.add_argument("--downscale", action="store_true", help="shrink a too-large image instead")
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.list_profiles:
        for name in list_profiles():
            print(f"{name:20} {load_profile(name).description}")
        return 0
    if not args.inputs:
        raise PencilbotError("give a photo or plan SVG to export (pencilbot export photo.jpg -o drawing.gcode)")
    profile = load_profile(args.profile)  # a bad profile fails before any slow planning
    targets = _targets([Path(p) for p in args.inputs], args.output)
    for source, target in targets:
        plan = _plan(source, args)
        summary = write_gcode(plan, profile, target, source=str(source))
        if not args.quiet:
            print(_report(summary, profile.name))
    return 0


def _targets(inputs: list[Path], output: str | None) -> list[tuple[Path, Path]]:
    """Each input with the G-code file it becomes."""
    if output is None:
        return [(p, p.with_suffix(".gcode")) for p in inputs]
    out = Path(output)
    if out.is_dir():
        return [(p, out / f"{p.stem}.gcode") for p in inputs]
    if len(inputs) > 1:
        raise PencilbotError(
            f"{len(inputs)} inputs need -o to name an existing folder, not {out}; create it first"
        )
    if out.suffix.lower() not in (".gcode", ".nc", ".gc", ".ngc"):
        raise PencilbotError(f"name the output {out} with .gcode (or .nc, .gc, .ngc)")
    return [(inputs[0], out)]


def _plan(source: Path, args: argparse.Namespace) -> Plan:
    if source.suffix.lower() == ".svg":
        photo_only = {"--style": args.style, "--page": args.page, "--pen-width": args.pen_width,
                      "--downscale": args.downscale or None}
        given = [flag for flag, value in photo_only.items() if value is not None]
        if given:
            raise PencilbotError(
                f"{source} is a plan: its page and pen are already set; {', '.join(given)} "
                "apply to photos only"
            )
        return read_svg(source)
    options = {"page": args.page, "pen_width": args.pen_width}
    style = with_overrides(
        load_style(args.style or "default"),
        {key: value for key, value in options.items() if value is not None},
        where="command line",
    )
    image = load_image(source, max_pixels=args.max_pixels, downscale=args.downscale)
    return make_plan(image, style=style)


def _report(summary: GcodeSummary, profile: str) -> str:
    return (
        f"wrote {summary.path} for {profile}: {summary.paths} paths, {summary.lines} lines, "
        f"{summary.bytes / 1e3:.0f} kB; about {duration_text(summary.stats.total.seconds)} to draw; "
        f"{summary.placement.describe()}"
    )
