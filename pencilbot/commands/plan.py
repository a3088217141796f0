"""``pencilbot plan``: photo → stroke plan as an SVG in millimetres (and a preview PNG)."""

from __future__ import annotations

import argparse
from pathlib import Path

from pencilbot.commands.common import add_verbosity
from pencilbot.errors import PencilbotError
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS, load_image
from pencilbot.planning.build import make_plan
from pencilbot.planning.layout import ORIENTATIONS
from pencilbot.planning.style import list_styles, load_style, with_overrides
from pencilbot.planning.svg import write_svg
from sim.canvas import Canvas

PREVIEW_DPI = 100


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "plan",
        help="plan the pen strokes of a photo (SVG in mm)",
        description=(
            "Turn a photo into the strokes a pen plotter will draw: hatch layers for the tone, "
            "then the GMED line drawing as short straight strokes, ordered for little pen-up "
            "travel. Writes an SVG sized in millimetres, one group per layer."
        ),
    )
    parser.add_argument("input", metavar="INPUT", help="image file (PNG, JPEG, TIFF, ...)")
    parser.add_argument("-o", "--output", required=True, metavar="PLAN.svg", help="SVG to write")
    parser.add_argument("--page", metavar="SIZE", help="A5, A4, A3, Letter or WxH in mm (default A4)")
    parser.add_argument("--orientation", choices=ORIENTATIONS, help="default portrait")
    parser.add_argument("--margin", type=float, metavar="MM", help="blank border (default 15 mm)")
    parser.add_argument("--pen-width", type=float, metavar="MM", help="pen line width (default 0.5 mm)")
    parser.add_argument(
        "--style",
        default="default",
        metavar="NAME|FILE",
        help=f"drawing style: {', '.join(list_styles())} or a .toml file (default: default)",
    )
    parser.add_argument("--preview", metavar="PREVIEW.png", help="also render the plan as a PNG")
    parser.add_argument(
        "--max-pixels", type=int, default=DEFAULT_MAX_PIXELS, metavar="N", help="refuse larger images"
    )
    parser.add_argument("--downscale", action="store_true", help="shrink a too-large image instead")
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    output = Path(args.output)
    if output.suffix.lower() != ".svg":
        raise PencilbotError(f"the plan is written as SVG: name the output *.svg, not {output.name}")
    if args.preview and Path(args.preview).suffix.lower() != ".png":
        raise PencilbotError(f"the preview is a PNG: name it *.png, not {Path(args.preview).name}")
    options = {
        "page": args.page,
        "orientation": args.orientation,
        "margin": args.margin,
        "pen_width": args.pen_width,
    }
    style = with_overrides(
        load_style(args.style),
        {key: value for key, value in options.items() if value is not None},
        where="command line",
    )
    image = load_image(args.input, max_pixels=args.max_pixels, downscale=args.downscale)
    plan = make_plan(image, style=style)
    write_svg(plan, output)
    if args.preview:
        canvas = Canvas(plan.page.width, plan.page.height, dpi=PREVIEW_DPI, pen_width=style.pen_width)
        for layer in plan.layers:
            canvas.draw_paths(layer.paths, pen_width=layer.pen_width)
        canvas.save_png(args.preview)
    if not args.quiet:
        counts = ", ".join(f"{layer.name} {len(layer.paths)}" for layer in plan.layers)
        print(
            f"wrote {output} ({plan.page.width:g}×{plan.page.height:g} mm): "
            f"{sum(len(layer.paths) for layer in plan.layers)} paths ({counts})"
            + (f"; preview {args.preview}" if args.preview else "")
        )
    return 0
