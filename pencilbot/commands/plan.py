"""``pencilbot plan``: photos → stroke plans as SVGs in millimetres (and preview PNGs)."""

from __future__ import annotations

import argparse
from pathlib import Path

from pencilbot.commands.batch import (
    add_jobs_option,
    collect_inputs,
    make_folders,
    output_paths,
    outputs_or_beside,
    run_batch,
)
from pencilbot.commands.common import photo_request, plan_for_input
from pencilbot.commands.options import add_photo_options, add_verbosity
from pencilbot.errors import PencilbotError
from pencilbot.export.svg import write_svg
from pencilbot.export.svg_read import is_plan_svg
from pencilbot.planning.preview import preview_image
from pencilbot.render import write_png

PREVIEW_DPI = 100


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "plan",
        help="plan the pen strokes of photos (SVG in mm)",
        description=(
            "Turn a photo into the strokes a pen plotter will draw: hatch layers for the tone, "
            "then the GMED line drawing as short straight strokes, ordered for little pen-up "
            "travel. Writes an SVG sized in millimetres, one group per layer. With several "
            "inputs or a folder, -o (and --preview) name folders, each input gets NAME.svg "
            "(NAME.png) there, and the files are planned on all cores."
        ),
    )
    parser.add_argument(
        "inputs", nargs="+", metavar="INPUT", help="image file (PNG, JPEG, TIFF, ...) or folder of them"
    )
    parser.add_argument(
        "-o",
        "--output",
        metavar="PLAN.svg|DIR",
        help="SVG to write (a folder for several inputs; default: INPUT's name .svg beside it)",
    )
    parser.add_argument("--preview", metavar="PREVIEW.png|DIR", help="also render each plan as a PNG")
    add_photo_options(parser)
    add_jobs_option(parser)
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    photo_request(args, PREVIEW_DPI if args.preview else None)  # a bad style, pen set or option, or a
    # page too large for memory (with its preview), fails once, before any slow planning
    inputs = collect_inputs(args.inputs)
    outputs = outputs_or_beside(inputs, args.output, what="plan", suffixes=(".svg",))
    previews = (
        output_paths(inputs, args.preview, what="preview", suffixes=(".png",))
        if args.preview
        else [None] * len(outputs)
    )
    if inputs.batch:
        make_folders([*outputs, *previews])
    jobs = list(zip(inputs.paths, outputs, previews, [args] * len(outputs)))
    return run_batch(plan_one, jobs, workers=args.jobs, quiet=args.quiet, verbose=args.verbose)


def plan_one(source: Path, output: Path, preview: Path | None, args: argparse.Namespace) -> str:
    """Plan the photo ``source`` into ``output`` (and ``preview``); return the line reporting it."""
    if source.suffix.lower() == ".svg" and is_plan_svg(source):
        raise PencilbotError(f"{source} is already a plan; give a photo (pencilbot export draws a plan)")
    if source.suffix.lower() == ".svg":
        raise PencilbotError(
            f"{source} is a drawing, not a photo: `pencilbot optimize {source} -o {output}` reorders it "
            f"for the plotter, `pencilbot export {source}` writes its G-code (reordered the same way)"
        )
    plan = plan_for_input(source, args)
    write_svg(plan, output)
    if preview is not None:
        write_png(preview, preview_image(plan, PREVIEW_DPI))
    counts = ", ".join(f"{layer.name} {len(layer.paths)}" for layer in plan.layers)
    if plan.pens:
        counts += f"; pens in load order: {', '.join(plan.pens)}"
    return (
        f"wrote {output} ({plan.page.width:g}×{plan.page.height:g} mm): "
        f"{sum(len(layer.paths) for layer in plan.layers)} paths ({counts})"
        + (f"; preview {preview}" if preview else "")
    )
