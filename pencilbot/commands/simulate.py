"""``pencilbot simulate``: draw G-code, a plan SVG or a photo on the virtual plotter, save a PNG.

The G-code goes the way it would to hardware: through the driver, over pyserial, to the
``sim://`` port of an in-process virtual GRBL 1.1 plotter. A plain job (what pencilbot exports
for a pen on the spindle or on Z) runs on that plotter's machine at once instead (:mod:`sim.bulk`, which
leaves it as the line-by-line way would); whatever the fast path does not take goes the full way. What the pen drew is rendered at the
chosen dpi over the whole bed, a band of rows at a time straight into the PNG (an A0 bed at
600 dpi is half a gigapixel), and the simulated drawing time is reported.
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import urllib.parse
from pathlib import Path

from tqdm import tqdm

from pencilbot.commands.common import PLOT_DPI, check_render, output_beside, plan_for_input, reorder_drawing
from pencilbot.commands.options import (
    MAX_DPI,
    MIN_DPI,
    add_photo_options,
    add_profile_option,
    add_realtime_option,
    add_svg_options,
    add_system_commands_option,
    add_verbosity,
    number,
)
from pencilbot.driver import draw
from pencilbot.driver.gcode.header import profile_for
from pencilbot.driver.gcode.job import gcode_blocks, program_blocks, read_gcode
from pencilbot.errors import PencilbotError, no_such_file
from pencilbot.export.gcode import GCODE_SUFFIXES, PenInFile, gcode_program, header_pen_width, pens_at_pauses
from pencilbot.export.hpgl import HPGL_SUFFIXES, MAX_HPGL_FILE, hpgl_program
from pencilbot.fileio import read_bounded
from pencilbot.firmware.hpgl import looks_like_hpgl
from pencilbot.machine.pens import load_pens
from pencilbot.planning.plan import BLACK, Layer
from pencilbot.planning.stats import duration_text
from pencilbot.render import save_color_png
from pencilbot.units import DEFAULT_PEN_WIDTH

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
    parser.add_argument(
        "-o", "--output", metavar="PLOT.png", help="PNG to write (default: INPUT-plot.png beside it)"
    )
    add_profile_option(parser, "GRBL, grblHAL or HP-GL plotter profile")
    parser.add_argument(
        "--dpi",
        type=number("--dpi", low=MIN_DPI, high=MAX_DPI, unit="dots per inch"),
        default=PLOT_DPI,
        help="PNG resolution in dots per inch (default %(default)g)",
    )
    parser.add_argument("--travel", action="store_true", help="overlay pen-up travel in red")
    add_realtime_option(parser)
    add_photo_options(parser)
    add_svg_options(parser, reorder=True)
    add_system_commands_option(parser)
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    source, output = Path(args.input), output_beside(args, "plot", ".png")
    if output.suffix.lower() != ".png":
        raise PencilbotError(f"name the output {output} with .png")
    import sim
    from pencilbot.driver.keys import AutoOperator
    from sim import protocol_sim

    sim.register()
    if not getattr(args, "profile_given", False) and looks_like_hpgl(source):
        args.profile = _hpgl_profile(args.profile)  # HP-GL is for an HP-GL plotter, whatever the default
    elif source.suffix.lower() in GCODE_SUFFIXES:
        # As draw: the profile the file was exported for, unless another one is asked for.
        args.profile = profile_for(
            source, args.profile if getattr(args, "profile_given", False) else None, args.profile
        )
    profile = protocol_sim.simulated_profile(args.profile)  # fails before any slow planning
    # The render is checked first too: a --dpi the machine cannot hold fails now, not after the plot.
    check_render(
        profile.bed.width, profile.bed.height, args.dpi, _file_pen_width(source, args), travel=args.travel
    )
    plotter = _fast_plot(source, profile, args)
    if plotter is not None:  # a plain job run at once on the virtual machine, no pen changes
        _save_plot(output, plotter, [], args, _file_pen_width(source, args))
        _report(output, plotter, [], profile, args)
        return 0
    program, pen_width, carousel = _gcode(source, profile, args)
    check_render(profile.bed.width, profile.bed.height, args.dpi, pen_width, travel=args.travel)

    pens = carousel or pens_at_pauses(program)  # HP-GL: SP n is the n-th pen
    if not pens and profile.firmware.program_language != "hpgl" and not args.realtime:
        # A drawing's own plain program: at once on the virtual machine too (a million paths in seconds)
        plotter = _fast_plot_blocks(program_blocks(program), len(program), source.name, args)
        if plotter is not None:
            _save_plot(output, plotter, [], args, pen_width)
            _report(output, plotter, [], profile, args)
            return 0
    if getattr(args, "pens", None) and any(pens):
        pens = _recolored(pens, load_pens(args.pens))
    name = f"simulate-{os.getpid()}-{next(_RUNS)}"
    # A preview's plotter has soft limits at the bed's edges (sim:// limits=bed), so a move off
    # the bed fails with GRBL's alarm instead of being drawn off the picture.
    query = urllib.parse.urlencode({"profile": args.profile, "realtime": args.realtime, "limits": "bed"})
    try:
        # Nobody needs to change a pen in a simulation: an M0 prints its prompt and goes on.
        draw(
            program,
            f"sim://{name}?{query}",
            profile=args.profile,
            source=str(source),
            progress="quiet" if args.quiet else "bar",
            operator=AutoOperator(),
            allow_system=args.allow_system_commands,
        )
        plotter = protocol_sim.plotter(name)
        _save_plot(output, plotter, pens, args, pen_width)
    finally:
        protocol_sim.forget(name)
    _report(output, plotter, pens, profile, args)
    return 0


def _hpgl_profile(default: str) -> str:
    """``default`` if it is an HP-GL plotter's profile, else the first HP-GL profile there is."""
    from pencilbot.machine.profile import list_profiles, load_profile

    names = [n for n in [default, *list_profiles()] if load_profile(n).firmware.program_language == "hpgl"]
    if not names:
        raise PencilbotError(
            "the file is HP-GL and no HP-GL plotter profile is known; give one with --profile"
        )
    return names[0]


def _fast_plot(source: Path, profile, args: argparse.Namespace):
    """The virtual plotter after a plain G-code job ran on it at once (:mod:`sim.bulk`), or None
    when the job must go the full way: through the driver, line by line (another clock than the
    instant one, a pen that is neither on the spindle nor on Z, a line of another form, a refused line or an
    alarm, whose message the full way gives)."""
    if source.suffix.lower() not in GCODE_SUFFIXES or args.realtime or not source.is_file():
        return None
    return _fast_plot_blocks(gcode_blocks(source), source.stat().st_size, source.name, args)


def _fast_plot_blocks(blocks, size: int, name: str, args: argparse.Namespace):
    """The virtual plotter after a plain job's ``blocks`` (whole lines, ``size`` bytes in all) ran
    on it at once, or None when the fast path cannot take them."""
    from sim import bulk, protocol_sim

    # The board the full way would open (see run's URL), made the same way.
    plotter = protocol_sim.plotter_from_options({"profile": args.profile, "realtime": "0", "limits": "bed"})
    if type(plotter) is not protocol_sim.VirtualPlotter or not bulk.fast_path_possible(plotter.machine):
        return None
    with tqdm(
        total=size,
        unit="B",
        unit_scale=True,
        desc=f"simulating {name}",
        file=sys.stderr,
        disable=args.quiet,
        leave=False,
    ) as bar:
        return plotter if bulk.run_blocks(plotter.machine, _counted(blocks, bar)) is None else None


def _counted(blocks, bar):
    """The blocks, each counted on the bar as it is taken."""
    for block in blocks:
        bar.update(len(block))
        yield block


def _save_plot(output: Path, plotter, pens: list, args: argparse.Namespace, pen_width: float) -> None:
    if any(pens):
        _save_color_plot(output, plotter, pens, dpi=args.dpi, pen_width=pen_width, travel=args.travel)
    else:
        plotter.save_png(output, dpi=args.dpi, pen_width=pen_width, travel=args.travel)


def _report(output: Path, plotter, pens: list, profile, args: argparse.Namespace) -> None:
    if not args.quiet:
        strokes = len(plotter.machine.drawn())
        in_pens = f" with {len({p.name for p in pens if p})} pens" if any(pens) else ""
        print(
            f"wrote {output}: {strokes} pen-down strokes{in_pens}, simulated drawing time "
            f"{duration_text(plotter.seconds)} ({plotter.seconds:.1f} s) on {profile.name}"
        )


def _save_color_plot(
    output: Path, plotter, pens: list, *, dpi: float, pen_width: float, travel: bool
) -> None:
    """Save what the plotter drew, each pen's strokes as a transparent layer of its ink (strokes
    before any pen change in black), band by band."""
    plotter.firmware.finish()
    bed = plotter.profile.bed
    inks = [
        ([bed.to_view(stroke) for stroke in strokes], ink.color, ink.width)
        for ink, strokes in strokes_by_pen(plotter.machine, pens, default=PenInFile("", BLACK, pen_width))
    ]
    save_color_png(
        output,
        inks,
        bed.width,
        bed.height,
        dpi=dpi,
        travel_pen=pen_width,
        travel=plotter.machine.bed_travel() if travel else None,
    )


def strokes_by_pen(drawing, pens: list, *, default: PenInFile) -> list[tuple[PenInFile, list]]:
    """A virtual plotter's pen-down strokes (machine mm) grouped by the pen that drew them, in
    the order the pens came: a stroke's pen is the one the last pen change before it asked for
    (``pens``: :func:`~pencilbot.export.gcode.pens_at_pauses` of the program), else ``default``.
    """
    groups: dict[str, tuple[PenInFile, list]] = {}
    for stroke, pauses in zip(drawing.strokes, drawing.stroke_pauses):
        pen = (pens[pauses - 1] if 0 < pauses <= len(pens) else None) or default
        groups.setdefault(pen.name, (pen, []))[1].append(stroke)
    return list(groups.values()) or [(default, [])]


def _recolored(pens: list, pen_set) -> list:
    """The file's pens with the colours and widths ``--pens`` gives for the names it knows."""
    known = {pen.name: pen for pen in pen_set.pens}
    return [
        p if p is None or p.name not in known else PenInFile(p.name, known[p.name].color, known[p.name].width)
        for p in pens
    ]


def _file_pen_width(source: Path, args: argparse.Namespace) -> float:
    """The pen a G-code file is drawn with: ``--pen-width``, else the one its header names (our
    one-pen files), else the usual one."""
    if args.pen_width or source.suffix.lower() not in GCODE_SUFFIXES:
        return args.pen_width or DEFAULT_PEN_WIDTH
    try:
        with open(source, "rb") as handle:
            head = handle.read(8192)
    except OSError:
        return DEFAULT_PEN_WIDTH  # what cannot be read is said where it is read
    return header_pen_width(head) or DEFAULT_PEN_WIDTH


def _gcode(source: Path, profile, args: argparse.Namespace) -> tuple[bytes, float, list]:
    """The program for ``source`` (G-code, or HP-GL for an HP-GL plotter), the pen width (mm) to
    render it with, and for an HP-GL colour plan its pens by carousel slot (else empty)."""
    if not source.is_file():
        raise PencilbotError(no_such_file(source, "a G-code file, a plan .svg or a photo"))
    if source.suffix.lower() in GCODE_SUFFIXES:
        # Read as draw reads it (any text in comments; a command that is not ASCII is refused
        # by line; a line over a megabyte as it is read), but as a program: a simulation keeps
        # no job journal beside the file.
        program = read_gcode(source)  # drawn with the pen its header names, else the usual one
        return program, args.pen_width or header_pen_width(program) or DEFAULT_PEN_WIDTH, []
    if source.suffix.lower() in HPGL_SUFFIXES or looks_like_hpgl(
        source
    ):  # HP-GL: one instruction after another
        try:
            return read_bounded(source, "HP-GL file", MAX_HPGL_FILE), args.pen_width or DEFAULT_PEN_WIDTH, []
        except OSError as exc:
            raise PencilbotError(f"cannot read HP-GL file {source} ({exc})") from None
    plan, reordered = reorder_drawing(plan_for_input(source, args), source, args, profile, say=not args.quiet)
    if reordered and not args.quiet:
        print(f"{source}: {reordered}")
    if profile.firmware.program_language == "hpgl":  # an HP-GL plotter draws HP-GL
        program = hpgl_program(plan, profile)
        if plan.pens:  # each pen of a colour plan in its carousel slot, in load order
            first: dict[str, Layer] = {}
            for layer in plan.layers:
                first.setdefault(layer.pen, layer)
            return (
                program,
                args.pen_width or plan.pen_width,
                [PenInFile(pen, first[pen].color, first[pen].pen_width) for pen in plan.pens],
            )
        return program, args.pen_width or plan.pen_width, []
    return gcode_program(plan, profile, source=str(source)), args.pen_width or plan.pen_width, []
