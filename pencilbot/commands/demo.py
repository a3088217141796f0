"""``pencilbot demo``: the whole way in one command, from a photo to a (virtual) plotted picture.

With no arguments it takes scikit-image's coffee photo, writes the pencil sketch, the plan SVG
and its preview, the G-code, streams the G-code over the serial path into the built-in virtual
GRBL plotter, writes what the plotter drew, and prints a summary. ``--input`` takes your photo
and ``--port`` a real plotter.
"""

from __future__ import annotations

import argparse
import json
import os
import time
import urllib.parse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pencilbot.commands.common import photo_request, refuse_overwriting
from pencilbot.commands.options import Deprecated, add_photo_options, add_profile_option, add_verbosity
from pencilbot.commands.sketch import write_image
from pencilbot.errors import PencilbotError

DEFAULT_PHOTO = "coffee"
#: The files the demo writes in its folder.
DEMO_FILES = ("sketch.png", "plan.svg", "preview.png", "drawing.gcode", "plot.png")
PREVIEW_DPI = 150.0


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="photo → sketch → plan → G-code → virtual plotter, in one go",
        description=(
            "Run the whole job: pencil sketch, plan SVG and preview, G-code, streaming to a plotter "
            "(the built-in virtual one unless --port is given) and a summary. Without a PHOTO it "
            f"uses scikit-image's {DEFAULT_PHOTO!r} photo."
        ),
    )
    parser.add_argument(
        "input", nargs="?", metavar="PHOTO", help=f"photo to draw (default: skimage.data.{DEFAULT_PHOTO})"
    )
    parser.add_argument(
        "-o",
        "--output",
        default="pencilbot-demo",
        metavar="DIR",
        help="folder for the outputs (default %(default)s)",
    )
    parser.add_argument("--input", dest="old_input", action=Deprecated, new="a positional PHOTO")
    parser.add_argument("--out", dest="output", action=Deprecated, new="-o/--output")
    parser.add_argument(
        "--port", metavar="PORT", help="plotter port or pyserial URL (default: the built-in virtual plotter)"
    )
    add_profile_option(parser)
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    add_photo_options(parser)
    add_verbosity(parser)
    parser.set_defaults(func=run)


@dataclass
class _Step:
    """Prints one line per finished step (unless quiet)."""

    quiet: bool

    def done(self, what: str, started: float) -> None:
        if not self.quiet:
            print(f"  {what} ({time.perf_counter() - started:.1f} s)", flush=True)


def run(args: argparse.Namespace) -> int:
    # Heavy imports here, so `pencilbot --help` stays quick.
    from pencilbot.app.photo import load_photo, prepare, sketch_and_plan
    from pencilbot.app.program import program_suffixes, speaks_hpgl, write_program
    from pencilbot.export.hpgl import SheetPlacement
    from pencilbot.export.svg import write_svg
    from pencilbot.machine.bed import Placement
    from pencilbot.machine.profile import load_profile
    from pencilbot.planning.fidelity import color_difference, fidelity, photo_likeness
    from pencilbot.planning.preview import preview as plan_preview
    from pencilbot.planning.preview import preview_image
    from pencilbot.planning.stats import duration_text
    from pencilbot.render import write_png

    refuse_overwriting(args, [Path(args.output) / name for name in DEMO_FILES])
    profile = load_profile(args.profile)  # a bad profile, style or pen set fails before any slow work
    prepared = prepare(photo_request(args, PREVIEW_DPI))  # a page too large for memory fails now
    style = prepared.style
    image = load_photo(_photo(args), prepared)
    out = Path(args.output)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise PencilbotError(f"cannot create the output folder {out}: {err.strerror}") from None
    step = _Step(args.quiet or args.json)
    if not step.quiet:
        print(f"pencilbot demo: {image.source} → {out}/")

    started = time.perf_counter()
    drawing, plan = sketch_and_plan(image, prepared)
    page = plan.page
    in_color = len(plan.pens) > 1
    write_image(drawing.result, out / "sketch.png")
    step.done(f"sketch.png: GMED pencil sketch{' in colour' if in_color else ''}", started)

    started = time.perf_counter()
    write_svg(plan, out / "plan.svg")
    preview = plan_preview(plan, PREVIEW_DPI)
    write_png(out / "preview.png", preview_image(plan, PREVIEW_DPI))
    faithful = fidelity(plan, drawing) if style.hatch and not in_color else None
    alike = photo_likeness(plan, drawing)
    delta_e = color_difference(plan, drawing.result) if in_color else None
    step.done("plan.svg, preview.png: pen strokes on the page", started)

    started = time.perf_counter()
    hpgl = speaks_hpgl(profile)  # an HP-GL plotter draws an HP-GL file
    gcode_path = out / f"drawing{program_suffixes(profile)[0]}"
    stats = write_program(plan, profile, gcode_path, source=image.source).stats.total  # what its header says
    step.done(f"{gcode_path.name}: {profile.name}", started)

    started = time.perf_counter()
    simulated = agreement = simulated_up = None
    if args.port is not None:
        from pencilbot.driver import draw

        draw(gcode_path, args.port, profile=args.profile, progress=_progress(args))
        step.done(f"streamed to {args.port}", started)
    elif profile.firmware.capabilities.realtime_protocol or hpgl or profile.firmware.capabilities.host_motion:
        placement = SheetPlacement.of(page, profile) if hpgl else Placement.on_bed(page, profile.bed)
        simulated, simulated_up, agreement = _simulate(args, gcode_path, placement, preview, out)
        step.done("plot.png: what the virtual plotter drew", started)
    elif not step.quiet:
        print(
            f"  plot.png: skipped; the virtual plotter speaks GRBL's protocol, not "
            f"{profile.firmware.title}'s (draw drawing.gcode with --port)"
        )

    summary = _summary(
        image.source, out, stats, (simulated, simulated_up, agreement), faithful, alike, plan, delta_e
    )
    if args.json:
        print(json.dumps(summary, indent=2))
    elif not args.quiet:
        print(_summary_text(summary, duration_text))
    return 0


def _summary(source: str, out: Path, stats, simulated_run, faithful, alike, plan, delta_e) -> dict:
    """The demo's figures (what --json prints): the drawing, the estimate, the simulation's
    seconds, pen-up travel and agreement with the preview (None each without one), the likeness."""
    simulated, simulated_up, agreement = simulated_run
    return {
        "source": source,
        "outputs": sorted(p.name for p in out.iterdir() if p.is_file()),
        "paths": stats.paths,
        "segments": stats.segments,
        "pen_down_m": round(stats.pen_down_mm / 1000, 2),
        "pen_up_m": round(stats.pen_up_mm / 1000, 2),
        "lifts": stats.lifts,
        "estimated_s": round(stats.seconds, 1),
        "simulated_s": None if simulated is None else round(simulated, 1),
        "simulated_pen_up_m": None if simulated_up is None else round(simulated_up / 1000, 2),
        "plot_vs_preview_r": _figure(agreement, 4),
        "line_fidelity_r": _figure(None if faithful is None else faithful.line_r, 3),
        "tone_fidelity_r": _figure(None if faithful is None else faithful.tone_r, 3),
        "tone_fidelity_mae": _figure(None if faithful is None else faithful.tone_mae, 3),
        "photo_rho": _figure(alike.rho, 3),
        "pens": list(plan.pens),
        "colour_delta_e00_3mm": _figure(delta_e, 2),
    }


def _figure(value: float | None, digits: int) -> float | None:
    """A summary figure rounded, or None when there is none (JSON has no NaN: r of a blank page)."""
    return None if value is None or not np.isfinite(value) else round(value, digits)


def _photo(args: argparse.Namespace):
    """The photo file given, else scikit-image's photo."""
    photo = args.input if args.input is not None else args.old_input
    if photo is not None:
        return photo
    from skimage import data

    from pencilbot.imaging.io import image_from_array

    return image_from_array(getattr(data, DEFAULT_PHOTO)(), source=f"skimage.data.{DEFAULT_PHOTO}")


def _progress(args: argparse.Namespace) -> str:
    return "quiet" if args.quiet or args.json else "bar"


def _simulate(args, gcode_path: Path, placement, preview, out: Path) -> tuple[float, float, float]:
    """Stream the G-code to the virtual plotter, save plot.png and compare it with the preview.

    Returns the simulated seconds, the pen-up travel it made (mm) and the correlation of the
    plot with the preview.
    """
    import sim
    from pencilbot.commands.simulate import strokes_by_pen
    from pencilbot.driver import draw
    from pencilbot.export.gcode import PenInFile, pens_at_pauses
    from pencilbot.planning.fidelity import pearson
    from pencilbot.planning.plan import BLACK
    from pencilbot.render import Canvas, color_image, write_png
    from sim import protocol_sim

    sim.register()
    name = f"demo-{os.getpid()}"
    pens = pens_at_pauses(gcode_path.read_bytes())
    # A colour job stops at each pen change; the virtual plotter's operator puts the pen in at once.
    query = urllib.parse.urlencode({"profile": args.profile, **({"operator": "auto"} if pens else {})})
    try:
        draw(gcode_path, f"sim://{name}?{query}", profile=args.profile, progress=_progress(args))
        plotter = protocol_sim.plotter(name)
        plotter.firmware.finish()
        by_pen = strokes_by_pen(plotter.machine, pens, default=PenInFile("", BLACK, preview.pen_width))
        seconds = plotter.seconds
        pen_up = sum(float(np.hypot(*np.diff(move, axis=0).T).sum()) for move in plotter.machine.travel)
    finally:
        protocol_sim.forget(name)
    plots = []
    for ink, strokes in by_pen:
        plot = Canvas(preview.width_mm, preview.height_mm, dpi=PREVIEW_DPI, pen_width=ink.width)
        # What the pen drew, carried back from machine to page coordinates: same frame as the preview.
        plot.draw_paths([placement.to_page(stroke[:, :2]) for stroke in strokes])
        plots.append(plot)
    write_png(
        out / "plot.png",
        color_image(plots, [ink.color for ink, _ in by_pen]) if pens else plots[0].to_image(),
    )
    darkness = 1.0 - np.prod([1.0 - plot.darkness for plot in plots], axis=0)
    return seconds, pen_up, pearson(darkness, preview.darkness)


def _summary_text(s: dict, duration_text) -> str:
    lines = [
        f"strokes: {s['paths']} pen paths, {s['segments']} segments, {s['lifts']} pen lifts",
        f"pen down {s['pen_down_m']} m, pen up {s['pen_up_m']} m",
        f"plot time: estimated {duration_text(s['estimated_s'])}"
        + ("" if s["simulated_s"] is None else f", simulated {duration_text(s['simulated_s'])}"),
    ]
    lines.append(f"likeness to the photo (Spearman, 1 mm blur): rho = {_or_none(s['photo_rho'])}")
    if s["pens"]:
        lines.append(
            f"pens, in load order: {', '.join(s['pens'])}; colour against the colour sketch "
            f"(mean CIEDE2000, 3 mm blur): {_or_none(s['colour_delta_e00_3mm'])}"
        )
    if s["tone_fidelity_mae"] is not None:
        lines.append(
            f"fidelity to the sketch: lines r = {_or_none(s['line_fidelity_r'])}, "
            f"tone r = {_or_none(s['tone_fidelity_r'])} (mean difference {s['tone_fidelity_mae']})"
        )
    if s["simulated_s"] is not None:
        lines.append(f"simulated plot vs plan preview: r = {_or_none(s['plot_vs_preview_r'])}")
    return "\n".join(lines)


def _or_none(figure: float | None) -> str:
    return "none (nothing to compare on a blank page)" if figure is None else str(figure)
