"""The options a photo is planned with, the same in every front door that takes them from a
command line (pencilbot's commands, ``vpype pencilbot``): :func:`add_photo_options` declares
them, :func:`photo_request` reads them back as a :class:`~pencilbot.app.photo.PhotoRequest`.
Every numeric option of the CLI is read through :func:`number`."""

from __future__ import annotations

import argparse
import math
from functools import partial
from pathlib import Path

from pencilbot.app.photo import PhotoRequest
from pencilbot.configs_io import config_names, user_folder
from pencilbot.errors import PencilbotError, ProfileError
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS
from pencilbot.machine.bed import MAX_BED
from pencilbot.machine.pens import list_pen_sets, load_pens
from pencilbot.planning.layout import ORIENTATIONS
from pencilbot.planning.style import (
    MAX_PEN_WIDTH,
    MIN_PEN_WIDTH,
    TIME_BUDGETS,
    Style,
    default_style,
    list_styles,
    load_style,
)

MAX_IMAGE_PIXELS = 10**10

# Style keys a photo option may override, by option name (in the order --help shows them).
STYLE_OPTIONS = {
    "--page": "page",
    "--orientation": "orientation",
    "--margin": "margin",
    "--pen-width": "pen_width",
    "--hatch": "hatch",
    "--faces": "faces",
    "--face-lines": "face_lines",
    "--time-budget": "time_budget",
}


def number(
    option: str,
    *,
    low: float | None = None,
    high: float,
    above: bool = False,
    whole: bool = False,
    unit: str = "",
):
    """The argparse ``type`` of a numeric option: a finite number in ``[low, high]`` (``(low,
    high]`` with ``above``), a whole one with ``whole``; ``unit`` names what it counts.

    Every numeric option of every command is read through this, so a value out of bounds (``nan``,
    ``inf``, ``0`` where it must be positive, ``1e9`` mm of pen) is one message naming the option,
    before anything runs. It raises :class:`PencilbotError`, not ``ValueError``: argparse lets it
    through to the CLI's one-line report instead of printing its usage text.
    """

    def text(value: float) -> str:
        return f"{value:.0f}" if float(value).is_integer() else f"{value:g}"

    bounds = [f"{'more than' if above else 'at least'} {text(low)}"] if low is not None else []
    rule = (
        " and ".join([*bounds, f"at most {text(high)}"])
        + (f" {unit}" if unit else "")
        + (", a whole number" if whole else "")
    )

    def parse(text: str):
        try:
            value = int(text) if whole else float(text)
        except ValueError:
            value = None
        if (
            value is None
            or not math.isfinite(value)
            or value > high
            or (low is not None and (value <= low if above else value < low))
        ):
            raise PencilbotError(f"{option} must be {rule}, not {text!r}")
        return value

    parse.__name__ = option.lstrip("-")  # what argparse would call the type in its own messages
    parse.bounds = (low, high, above, whole)  # type: ignore[attr-defined]  # for --help generators and tests
    return parse


class Listing(argparse.Action):
    """An option that prints a listing and exits, as ``--version`` does (no other argument needed)."""

    def __init__(self, option_strings, dest, listing, help=None):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)
        self.listing = listing

    def __call__(self, parser, namespace, values, option_string=None):
        print("\n".join(self.listing()))
        parser.exit()


def style_listing() -> list[str]:
    """One line per style: name, its page, pen and whether it hatches, and whether it is the user's."""

    def summary(name):
        style = load_style(name)
        return f"{style.page} {style.orientation}, {style.pen_width:g} mm pen, {'hatching' if style.hatch else 'outline only'}"

    return [listing_line(name, path, partial(summary, name)) for name, path in config_names("styles").items()]


def pens_listing() -> list[str]:
    """One line per pen set: its pens in load order, and whether it is the user's."""

    def summary(name):
        pens = load_pens(name)
        return ", ".join(f"{pen.name} {pen.color} {pen.width:g} mm" for pen in pens.load_order)

    return [listing_line(name, path, partial(summary, name)) for name, path in config_names("pens").items()]


def listing_line(name: str, path: Path, describe) -> str:
    try:
        words = describe()
    except ProfileError as err:
        words = f"cannot be used: {err}"
    yours = f" (yours: {path})" if path.is_relative_to(user_folder()) else ""
    return f"{name:20} {words}{yours}"


def add_photo_options(parser: argparse.ArgumentParser) -> None:
    """The options saying how a photo becomes a plan: style, paper, pen, image size limit.

    Read back with :func:`~pencilbot.commands.common.plan_for_input` (:func:`photo_request` for a photo). A plan SVG of ours refuses
    them (its page and pen are set); another tool's SVG takes the sheet options (it is fitted onto
    the sheet) and the pen.
    """
    photo = parser.add_argument_group("photo inputs")
    style = default_style()
    photo.add_argument(
        "--style",
        metavar="NAME|FILE.toml",
        help=f"drawing style: {', '.join(list_styles())} or a .toml file (default {style}; yours: "
        f'style = "NAME" in {user_folder() / "config.toml"})',
    )
    photo.add_argument(
        "--list-styles",
        action=Listing,
        listing=style_listing,
        help="list the drawing styles, shipped and yours, and exit",
    )
    photo.add_argument(
        "--pens",
        metavar="NAME|FILE.toml",
        help=f"draw in colour with a pen set: {', '.join(list_pen_sets())} or a .toml file (default: one "
        "black pen; the pens' widths replace --pen-width)",
    )
    photo.add_argument(
        "--list-pens",
        action=Listing,
        listing=pens_listing,
        help="list the pen sets, shipped and yours, and exit",
    )
    add_sheet_options(
        photo,
        f"({style_default('page')}; another tool's SVG is fitted onto it)",
        f"({style_default('margin')})",
        f"({style_default('pen_width')}; another tool's SVG: its stroke width)",
    )
    photo.add_argument(
        "--faces",
        action=argparse.BooleanOptionalAction,
        help="draw the faces found with finer features and hatching, listed in the plan's metadata; "
        f"--no-faces: do not look for them ({style_default('faces')})",
    )
    photo.add_argument(
        "--face-lines",
        action=argparse.BooleanOptionalAction,
        help="also draw a face's eyes, brows and mouth as pen lines over its tone: reads more as "
        f"a drawn portrait, follows the photo's tone less closely ({style_default('face_lines')})",
    )
    photo.add_argument(
        "--time-budget",
        type=number("--time-budget", low=TIME_BUDGETS[0], high=TIME_BUDGETS[1], unit="times the default"),
        metavar="X",
        help="how long the plot may take, 1 to 4 times the default (about 28 min for A4 on a servo "
        "plotter at 50 mm/s): 2 draws faces finer and tones darker in up to twice the time "
        f"({style_default('time_budget')})",
    )
    photo.add_argument(
        "--max-pixels",
        type=number("--max-pixels", low=1, high=MAX_IMAGE_PIXELS, whole=True),
        default=DEFAULT_MAX_PIXELS,
        metavar="N",
        help="refuse larger images",
    )
    photo.add_argument("--downscale", action="store_true", help="shrink a too-large image instead")
    photo.add_argument(
        "--hatch",
        action=argparse.BooleanOptionalAction,
        help=f"draw the tone as hatching, or only the lines with --no-hatch ({style_default('hatch')})",
    )


def add_sheet_options(group, page_default: str, margin_default: str, pen_default: str) -> None:
    group.add_argument(
        "--page", metavar="A4|WxH", help=f"paper: A5, A4, A3, Letter or WxH in mm {page_default}"
    )
    group.add_argument(
        "--orientation",
        choices=ORIENTATIONS,
        help=f"auto turns the sheet to suit the picture ({style_default('orientation')})",
    )
    group.add_argument(
        "--margin",
        type=number("--margin", low=0, high=MAX_BED / 2, unit="mm"),
        metavar="MM",
        help=f"blank border in mm {margin_default}",
    )
    group.add_argument(
        "--pen-width",
        type=number("--pen-width", low=MIN_PEN_WIDTH, high=MAX_PEN_WIDTH, unit="mm"),
        metavar="MM",
        help=f"pen line width in mm {pen_default}",
    )


def style_default(key: str) -> str:
    """Help words for an option that overrides a style key, with the built-in default."""
    return f"default: the style's, {getattr(Style, key)} in the {Style.name} style"


def photo_request(
    args: argparse.Namespace, *, where: str = "command line", preview_dpi: float | None = None
) -> PhotoRequest:
    """The request the photo options in ``args`` (parsed from :func:`add_photo_options`) make:
    the style ``--style`` names (else the user's default) with the sheet, pen, hatch and faces
    options over it, ``--pens``, ``--max-pixels`` and ``--downscale``."""
    return PhotoRequest(
        style=getattr(args, "style", None) or default_style(),
        overrides={
            key: getattr(args, flag.lstrip("-").replace("-", "_"), None)
            for flag, key in STYLE_OPTIONS.items()
        },
        where=where,
        pens=getattr(args, "pens", None),
        max_pixels=getattr(args, "max_pixels", DEFAULT_MAX_PIXELS),
        downscale=getattr(args, "downscale", False),
        preview_dpi=preview_dpi,
    )
