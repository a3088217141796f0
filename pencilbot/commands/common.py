"""Options and helpers shared by several subcommands."""

from __future__ import annotations

import argparse
from pathlib import Path

from pencilbot.errors import PencilbotError
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS, load_image
from pencilbot.planning.layout import ORIENTATIONS
from pencilbot.planning.plan import Plan
from pencilbot.planning.style import Style, list_styles, load_style, with_overrides

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
        help=f"drawing style: {', '.join(list_styles())} or a .toml file (default: default)",
    )
    photo.add_argument(
        "--page", metavar="A4|WxH", help="paper: A5, A4, A3, Letter or WxH in mm (default: the style's, A4)"
    )
    photo.add_argument(
        "--orientation", choices=ORIENTATIONS,
        help="auto turns the sheet to suit the photo (default: the style's)",
    )
    photo.add_argument("--margin", type=float, metavar="MM", help="blank border in mm (default: the style's, 15)")
    photo.add_argument("--pen-width", type=float, metavar="MM", help="pen line width in mm (default: the style's, 0.5)")
    photo.add_argument(
        "--max-pixels", type=int, default=DEFAULT_MAX_PIXELS, metavar="N", help="refuse larger images"
    )
    photo.add_argument("--downscale", action="store_true", help="shrink a too-large image instead")


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
    from pencilbot.planning.svg import read_svg

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
    return with_overrides(load_style(args.style or "default"), options, where="command line")


def _overrides(args: argparse.Namespace) -> dict[str, object]:
    """Value of each style-overriding option by flag, in the order --help shows them."""
    return {flag: getattr(args, key) for flag, key in _STYLE_OPTIONS.items()}
