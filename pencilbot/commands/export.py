"""``pencilbot export``: photos or plan SVGs → G-code for a plotter profile."""

from __future__ import annotations

import argparse
import re
from dataclasses import replace
from pathlib import Path

from pencilbot.app.program import program_suffixes
from pencilbot.commands.batch import (
    Inputs,
    add_jobs_option,
    collect_inputs,
    make_folders,
    outputs_or_beside,
    run_batch,
)
from pencilbot.commands.common import photo_request, plan_for_input, reorder_drawing
from pencilbot.commands.options import add_photo_options, add_profile_option, add_svg_options, add_verbosity
from pencilbot.errors import PencilbotError
from pencilbot.export.gcode import GCODE_SUFFIXES, write_gcode
from pencilbot.export.hpgl import HPGL_SUFFIXES, write_hpgl
from pencilbot.machine.profile import Profile, load_profile
from pencilbot.planning.plan import Plan
from pencilbot.planning.stats import duration_text


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export",
        help="write G-code for a plotter from photos or SVG drawings",
        description=(
            "Write G-code for a plotter profile. INPUT is a photo (planned with the style, page "
            "and pen width given), a plan SVG written by `pencilbot plan`, an SVG drawing from "
            "another tool (reordered for the plotter unless --keep-order), or a folder of photos. "
            "With several inputs or a folder, -o names a folder, each input gets NAME.gcode "
            "there, and the files are planned on all cores."
        ),
    )
    parser.add_argument("inputs", nargs="*", metavar="INPUT", help="photo, .svg drawing, or folder of photos")
    parser.add_argument(
        "-o",
        "--output",
        metavar="OUT.gcode|DIR",
        help="G-code file to write (a folder for several inputs; default: INPUT's name .gcode beside it)",
    )
    add_profile_option(parser)
    parser.add_argument(
        "--split-pens",
        action="store_true",
        help="write one G-code file per pen of a colour plan (OUT-1-yellow.gcode, OUT-2-cyan.gcode, ...), "
        "in load order, with no pen-change pauses",
    )
    add_photo_options(parser)
    add_svg_options(parser, reorder=True)
    add_jobs_option(parser)
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not args.inputs:
        raise PencilbotError(
            "give a photo or plan SVG to export (pencilbot export photo.jpg -o drawing.gcode)"
        )
    profile = load_profile(args.profile)  # a bad profile or style fails before any slow planning
    inputs = collect_inputs(args.inputs)
    if any(p.suffix.lower() != ".svg" for p in inputs.paths):
        photo_request(args)
    outputs = _outputs(inputs, args.output, suffixes=file_suffixes(profile))
    jobs = [(source, target, profile, args) for source, target in zip(inputs.paths, outputs)]
    return run_batch(export_one, jobs, workers=args.jobs, quiet=args.quiet, verbose=args.verbose)


def file_suffixes(profile: Profile) -> tuple[str, ...]:
    """The names the plotter's files go by: HP-GL for an HP-GL plotter, else G-code."""
    return program_suffixes(profile)


def _outputs(inputs: Inputs, output: str | None, suffixes: tuple[str, ...] = GCODE_SUFFIXES) -> list[Path]:
    """The G-code (or HP-GL) file each input becomes (beside it when no -o is given)."""
    outputs = outputs_or_beside(inputs, output, what="output", suffixes=suffixes)
    if output is not None and inputs.batch:
        make_folders(outputs)
    return outputs


def export_one(source: Path, target: Path, profile: Profile, args: argparse.Namespace) -> str:
    """Write the G-code of ``source`` (photo or SVG) to ``target``; return the line reporting it."""
    plan, reordered = reorder_drawing(
        plan_for_input(source, args), source, args, profile, say=not args.quiet or bool(args.verbose)
    )
    if target.suffix.lower() in HPGL_SUFFIXES:
        hpgl = write_hpgl(plan, profile, target)
        return (
            f"wrote {hpgl.path} for {profile.name}: {hpgl.paths} paths, {hpgl.instructions} HP-GL "
            f"instructions, {hpgl.bytes / 1e3:.0f} kB; about {duration_text(hpgl.stats.total.seconds)} to draw; "
            f"{hpgl.placement.describe()}" + (f"; {reordered}" if reordered else "")
        )
    if args.split_pens and len(plan.pens) > 1:
        return _export_split(plan, source, target, profile) + (f"; {reordered}" if reordered else "")
    summary = write_gcode(plan, profile, target, source=str(source))
    return (
        f"wrote {summary.path} for {profile.name}: {summary.paths} paths, {summary.lines} lines, "
        f"{summary.bytes / 1e3:.0f} kB; about {duration_text(summary.stats.total.seconds)} to draw; "
        f"{summary.placement.describe()}" + (f"; {reordered}" if reordered else "")
    )


def pen_file(target: Path, number: int, pen: str) -> Path:
    """The file of the ``number``-th pen beside ``target``: ``OUT-1-yellow.gcode``."""
    safe = re.sub(r"[^A-Za-z0-9_.+-]+", "_", pen)
    return target.with_name(f"{target.stem}-{number}-{safe}{target.suffix}")


def _export_split(plan: Plan, source: Path, target: Path, profile: Profile) -> str:
    """One G-code file per pen run of ``plan`` (each a plan of one pen: no pen-change pause)."""
    written, seconds = [], 0.0
    for number, (pen, layers) in enumerate(plan.pen_runs(), start=1):
        one = replace(plan, layers=layers)
        summary = write_gcode(
            one, profile, pen_file(target, number, pen), source=f"{source} (pen {number}: {pen})"
        )
        written.append(f"{Path(summary.path).name} ({pen}, {summary.paths} paths)")
        seconds += summary.stats.total.seconds
    return (
        f"wrote {len(written)} files for {profile.name}, one per pen in load order: {', '.join(written)}; "
        f"about {duration_text(seconds)} to draw in all"
    )
