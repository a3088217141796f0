"""Options and helpers shared by several subcommands."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from pencilbot.errors import PencilbotError
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS, load_image
from pencilbot.planning.layout import ORIENTATIONS
from pencilbot.planning.plan import Plan
from pencilbot.planning.style import DEFAULT_STYLE, Style, list_styles, load_style, with_overrides
from pencilbot.export.svg import read_svg
from pencilbot.units import MM_PER_INCH

#: Image files the commands read as photos and write as pictures (the first is the default).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")

#: The widest pen a preview renders (mm): a broad marker, not a roller.
MAX_RENDER_PEN_WIDTH = 50.0
# Peak bytes per pixel of a bed render, measured with /usr/bin/time (A4 bed at 600 dpi): the
# float64 ink sums, the per-path maxima and the PNG conversion; about three times more with travel.
_RENDER_BYTES_PER_PIXEL = 24
_RENDER_BYTES_PER_PIXEL_TRAVEL = 80
_MEMORY_SHARE = 0.75  # of the memory the system says is available

# Style keys a command-line option may override, by option name.
_STYLE_OPTIONS = {"--page": "page", "--orientation": "orientation", "--margin": "margin", "--pen-width": "pen_width"}


def add_verbosity(parser: argparse.ArgumentParser) -> None:
    """``-q/--quiet`` and ``-v/--verbose`` for every subcommand."""
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more detail")


def add_photo_options(parser: argparse.ArgumentParser) -> None:
    """The options saying how a photo becomes a plan: style, paper, pen, image size limit.

    Read back with :func:`plan_for_input`; a plan SVG input refuses them (its page and pen are set).
    """
    photo = parser.add_argument_group("photo inputs")
    photo.add_argument(
        "--style", metavar="NAME|FILE.toml",
        help=f"drawing style: {', '.join(list_styles())} or a .toml file (default: {DEFAULT_STYLE})",
    )
    photo.add_argument(
        "--page", metavar="A4|WxH", help=f"paper: A5, A4, A3, Letter or WxH in mm ({_style_default('page')})"
    )
    photo.add_argument(
        "--orientation", choices=ORIENTATIONS,
        help=f"auto turns the sheet to suit the photo ({_style_default('orientation')})",
    )
    photo.add_argument("--margin", type=float, metavar="MM", help=f"blank border in mm ({_style_default('margin')})")
    photo.add_argument("--pen-width", type=float, metavar="MM", help=f"pen line width in mm ({_style_default('pen_width')})")
    photo.add_argument(
        "--max-pixels", type=int, default=DEFAULT_MAX_PIXELS, metavar="N", help="refuse larger images"
    )
    photo.add_argument("--downscale", action="store_true", help="shrink a too-large image instead")


def _style_default(key: str) -> str:
    """Help words for an option that overrides a style key, with the built-in default."""
    return f"default: the style's, {getattr(Style, key)} in the {DEFAULT_STYLE} style"


def plan_for_input(path: Path, args: argparse.Namespace) -> Plan:
    """The plan of ``path``: a photo planned with the photo options, or a plan SVG read as is.

    Parameters
    ----------
    path : Path
        A photo, or a ``.svg`` written by ``pencilbot plan``.
    args : argparse.Namespace
        Parsed options of a parser given :func:`add_photo_options`.

    Returns
    -------
    Plan
        Coordinates in mm on the page, Y up.

    Raises
    ------
    PencilbotError
        A photo option was given with a plan SVG, the style or an option is invalid, or the file
        cannot be read.
    """
    # Imported here, not at the top: every command imports this module, and `pencilbot sketch`
    # has no use for the planning stack (0.1 s of start-up).
    from pencilbot.planning.build import make_plan, plot_resolution

    path = Path(path)
    if path.suffix.lower() == ".svg":
        given = {"--style": args.style, **_overrides(args), "--downscale": args.downscale or None}
        flags = [flag for flag, value in given.items() if value is not None]
        if flags:
            raise PencilbotError(
                f"{path} is a plan: its page and pen are already set; {', '.join(flags)} apply to photos only"
            )
        return read_svg(path)
    style = photo_style(args)
    image = load_image(path, max_pixels=args.max_pixels, downscale=args.downscale, shrink_to=plot_resolution(style))
    return make_plan(image, style=style)


def photo_style(args: argparse.Namespace) -> Style:
    """The style named by ``--style`` with the page, orientation, margin and pen options applied.

    Raises
    ------
    ProfileError
        No such style, or an option value the style does not accept.
    """
    options = {_STYLE_OPTIONS[flag]: value for flag, value in _overrides(args).items() if value is not None}
    return with_overrides(load_style(args.style or DEFAULT_STYLE), options, where="command line")


def _overrides(args: argparse.Namespace) -> dict[str, object]:
    """Value of each style-overriding option by flag, in the order --help shows them."""
    return {flag: getattr(args, key) for flag, key in _STYLE_OPTIONS.items()}


def check_render(width_mm: float, height_mm: float, dpi: float, pen_width: float, *, travel: bool = False) -> None:
    """Refuse a render of a ``width_mm`` × ``height_mm`` bed before anything is allocated.

    Raises
    ------
    PencilbotError
        ``dpi`` or ``pen_width`` is not a positive finite number, the pen is wider than
        :data:`MAX_RENDER_PEN_WIDTH`, or the image would need more memory than is available
        (the message names the largest ``--dpi`` that fits).
    """
    for option, value in (("--dpi", dpi), ("--pen-width", pen_width)):
        if not (math.isfinite(value) and value > 0):
            raise PencilbotError(f"{option} must be positive and finite, not {value:g}")
    if pen_width > MAX_RENDER_PEN_WIDTH:
        raise PencilbotError(
            f"--pen-width {pen_width:g} mm is wider than any pen; give at most {MAX_RENDER_PEN_WIDTH:g} mm")
    cols, rows = (math.ceil(size / MM_PER_INCH * dpi) for size in (width_mm, height_mm))
    need = cols * rows * (_RENDER_BYTES_PER_PIXEL_TRAVEL if travel else _RENDER_BYTES_PER_PIXEL)
    budget = _MEMORY_SHARE * available_memory()
    if need > budget:
        fits = max(1, math.floor(dpi * math.sqrt(budget / need)))
        raise PencilbotError(
            f"--dpi {dpi:g} makes the {width_mm:g} x {height_mm:g} mm bed {cols} x {rows} pixels, about "
            f"{need / 1e9:.1f} GB to render, more than this machine has free ({budget / _MEMORY_SHARE / 1e9:.1f} GB); "
            f"use --dpi {fits} or less"
        )


def available_memory() -> int:
    """Bytes of memory the system can give a new allocation now (MemAvailable on Linux)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 4 << 30  # unknown: assume a small machine
