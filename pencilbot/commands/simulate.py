"""``pencilbot simulate``: draw G-code, a plan SVG or a photo on the virtual plotter, save a PNG.

The G-code goes the way it would to hardware: through the driver, over pyserial, to the
``sim://`` port of an in-process virtual GRBL 1.1 plotter. What the pen drew is rendered at the
chosen dpi over the whole bed, and the simulated drawing time is reported.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import re
import urllib.parse
from pathlib import Path

from pencilbot.commands.common import (
    add_photo_options, add_profile_option, add_svg_options, add_verbosity, check_render, plan_for_input,
    reorder_drawing,
)
from pencilbot.driver import draw
from pencilbot.errors import PencilbotError
from pencilbot.export.gcode import GCODE_SUFFIXES, gcode_program
from pencilbot.paths import DEFAULT_PEN_WIDTH
from pencilbot.planning.stats import duration_text
_RUNS = itertools.count(1)


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "simulate",
        help="draw on the virtual plotter and save what it drew as a PNG",
        description=(
            "Stream INPUT (G-code, an SVG drawing, reordered for the plotter unless it is "
            "pencilbot's own or --keep-order is given, or a photo, which is planned first) through the "
            "serial driver into the virtual GRBL plotter, save the drawing as a PNG of the whole "
            "bed and print the simulated drawing time. --pen-width also sets the line width a "
            f"G-code input is rendered with (default: the plan's, else {DEFAULT_PEN_WIDTH:g} mm)."
        ),
    )
    parser.add_argument("input", metavar="INPUT", help="G-code file, .svg drawing, or photo")
    parser.add_argument("-o", "--output", required=True, metavar="PLOT.png", help="PNG to write")
    add_profile_option(parser, "GRBL or grblHAL plotter profile")
    parser.add_argument("--dpi", type=float, default=150.0, help="PNG resolution in dots per inch (default %(default)g)")
    parser.add_argument("--travel", action="store_true", help="overlay pen-up travel in red")
    parser.add_argument("--realtime", type=float, default=0.0, metavar="R",
                        help="move R times faster than real time (default %(default)g: instant)")
    add_photo_options(parser)
    add_svg_options(parser, reorder=True)
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    source, output = Path(args.input), Path(args.output)
    if output.suffix.lower() != ".png":
        raise PencilbotError(f"name the output {output} with .png")
    if not (math.isfinite(args.realtime) and args.realtime >= 0):
        raise PencilbotError(f"--realtime must be 0 (instant) or a positive speed-up, not {args.realtime:g}")
    import sim
    from pencilbot.driver.keys import AutoOperator
    from sim import protocol_sim

    sim.register()
    profile = protocol_sim.simulated_profile(args.profile)  # fails before any slow planning
    # The render is checked first too: a --dpi the machine cannot hold fails now, not after the plot.
    check_render(profile.bed.width, profile.bed.height, args.dpi, args.pen_width or DEFAULT_PEN_WIDTH,
                 travel=args.travel)
    program, pen_width = _gcode(source, profile, args)
    check_render(profile.bed.width, profile.bed.height, args.dpi, pen_width, travel=args.travel)

    name = f"simulate-{os.getpid()}-{next(_RUNS)}"
    # A preview's plotter has soft limits at the bed's edges (sim:// limits=bed), so a move off
    # the bed fails with GRBL's alarm instead of being drawn off the picture.
    query = urllib.parse.urlencode({"profile": args.profile, "realtime": args.realtime, "limits": "bed"})
    try:
        # Nobody needs to change a pen in a simulation: an M0 prints its prompt and goes on.
        draw(program, f"sim://{name}?{query}", profile=args.profile, source=str(source),
             progress="quiet" if args.quiet else "bar", operator=AutoOperator())
        plotter = protocol_sim.plotter(name)
        canvas = plotter.canvas(dpi=args.dpi, pen_width=pen_width, travel=args.travel)
        canvas.save_png(output)
    finally:
        protocol_sim.forget(name)
    if not args.quiet:
        strokes = len(plotter.machine.strokes)
        print(f"wrote {output}: {strokes} pen-down strokes, simulated drawing time "
              f"{duration_text(plotter.seconds)} ({plotter.seconds:.1f} s) on {profile.name}")
    return 0


def _gcode(source: Path, profile, args: argparse.Namespace) -> tuple[bytes, float]:
    """The G-code program for ``source`` and the pen width (mm) to render it with."""
    if not source.is_file():
        raise PencilbotError(f"{source} does not exist; give a G-code file, a plan .svg or a photo")
    if source.suffix.lower() in GCODE_SUFFIXES:
        try:
            # Read as draw reads it (any text in comments; a command that is not ASCII is refused
            # by line), but as a program: a simulation keeps no job journal beside the file.
            program = source.read_bytes()
        except OSError as exc:
            raise PencilbotError(f"cannot read G-code file {source} ({exc})") from None
        return _without_program_markers(program), args.pen_width or DEFAULT_PEN_WIDTH
    plan, reordered = reorder_drawing(plan_for_input(source, args), source, args, profile)
    if reordered and not args.quiet:
        print(f"{source}: {reordered}")
    return gcode_program(plan, profile, source=str(source)), args.pen_width or plan.pen_width


_BOM = b"\xef\xbb\xbf"
_PROGRAM_MARKER = re.compile(rb"(?m)^[ \t]*%[ \t]*(?:;[^\r\n]*)?(?=\r?$)")


def _without_program_markers(program: bytes) -> bytes:
    """The program without a UTF-8 byte-order mark (not text: GRBL drops its bytes too), and its
    ``%`` lines (the tape start/end marker CAM and Inkscape programs carry) left empty.

    GRBL answers a ``%`` with error:1 (its protocol loop has the feature commented out); a
    preview of a program written for controllers that read it leaves the marker out. The lines
    stay, empty, so messages keep the file's line numbers.
    """
    return _PROGRAM_MARKER.sub(b"", program.removeprefix(_BOM))
