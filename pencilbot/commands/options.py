"""The command-line options several subcommands share: their builders (``add_*``), the bounded
numbers every numeric option is read through (:func:`number`), and the listings
(``--list-profiles``, ``--list-styles``, ``--list-pens``)."""

from __future__ import annotations

import argparse
import math
import sys
from functools import partial
from pathlib import Path

from pencilbot.commands.common import MAX_RENDER_PEN_WIDTH
from pencilbot.configs_io import config_names, user_folder
from pencilbot.errors import PencilbotError, ProfileError
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS
from pencilbot.machine.bed import MAX_BED
from pencilbot.machine.pens import list_pen_sets, load_pens
from pencilbot.planning.layout import ORIENTATIONS
from pencilbot.planning.plan import DEFAULT_MARGIN
from pencilbot.planning.style import MIN_PEN_WIDTH, Style, default_style, list_styles, load_style
from pencilbot.units import DEFAULT_PEN_WIDTH


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


#: Bounds shared by several commands' options.
MAX_DPI = 10_000.0  # dots per inch of a rendered PNG (memory is checked on top: check_render)
MAX_SVG_DPI = 100_000.0
MAX_IMAGE_PIXELS = 10**10
MAX_BAUD = 20_000_000  # bit/s: above any USB serial adapter
MAX_REALTIME = 1e6  # speed-up over real time
MIN_REALTIME = 0.1  # slower than this a simulation only looks hung (1e-9 took 30 years a second)
MIN_DPI = 1.0  # dots per inch of a rendered PNG: a bed at 1e-300 dpi is no pixel at all


def realtime_option(option: str = "--realtime"):
    """The argparse ``type`` of a speed-up over real time: 0 (instant) or from
    :data:`MIN_REALTIME` to :data:`MAX_REALTIME`."""
    parse_number = number(option, low=0, high=MAX_REALTIME, unit="times real time (0: instant)")

    def parse(text: str) -> float:
        value = parse_number(text)
        if 0 < value < MIN_REALTIME:
            raise PencilbotError(
                f"{option} must be 0 (instant) or from {MIN_REALTIME:g} to {MAX_REALTIME:g} times "
                f"real time, not {text!r}"
            )
        return value

    parse.__name__ = option.lstrip("-")
    parse.bounds = parse_number.bounds  # type: ignore[attr-defined]
    return parse


def add_system_commands_option(parser: argparse.ArgumentParser) -> None:
    """``--allow-system-commands '$H,$C'``: the GRBL system commands (``$`` lines other than a
    ``$J=`` jog) a G-code file may send; without it any is refused by line."""
    from pencilbot.driver.gcode.system_lines import allowed_names

    def parse(text: str) -> frozenset:
        names = allowed_names(text)
        if not names:
            raise PencilbotError(f"--allow-system-commands takes names such as '$H,$C', not {text!r}")
        return names

    parse.__name__ = "allow-system-commands"
    parser.add_argument(
        "--allow-system-commands",
        type=parse,
        default=frozenset(),
        metavar="'$H,$C'",
        help="let a G-code file send these GRBL system commands ($ lines: $H homing, $C check mode, $X unlock, "
        "$SLP, $RST, $N startup blocks, $100 settings...); any other is refused by line",
    )


def add_verbosity(parser: argparse.ArgumentParser) -> None:
    """``-q/--quiet`` and ``-v/--verbose`` for every subcommand."""
    parser.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more detail")


def add_profile_option(parser: argparse.ArgumentParser, what: str = "plotter profile") -> None:
    """``--profile`` (its default: :func:`~pencilbot.machine.profile.default_profile`, read now)
    and ``--list-profiles``."""
    from pencilbot.machine.profile import default_profile  # not at the top: `sketch` has no profile

    name = default_profile()
    parser.add_argument(
        "--profile",
        default=name,
        metavar="NAME|FILE.toml",
        action=_Given,
        help=f"{what}: a name (see --list-profiles) or a .toml file (default {name}; yours: $PENCILBOT_PROFILE "
        f'or profile = "NAME" in {user_folder() / "config.toml"})',
    )
    add_profile_listing(parser)


def add_profile_listing(parser: argparse.ArgumentParser) -> None:
    """``--list-profiles``: print the plotter profiles, shipped and the user's, and exit."""
    parser.add_argument(
        "--list-profiles",
        action=_Listing,
        listing=profile_listing,
        help="list the plotter profiles, shipped and yours, and exit",
    )


def add_realtime_option(parser: argparse.ArgumentParser) -> None:
    """``--realtime R``, the virtual plotter's speed, with one default wherever it is taken."""
    parser.add_argument(
        "--realtime",
        type=realtime_option(),
        default=0.0,
        metavar="R",
        help="move R times faster than real time (default %(default)g: instant; 1: as fast as the real machine)",
    )


class Deprecated(argparse.Action):
    """An old spelling of an option that still works for one release, with a note to use the new one."""

    def __init__(self, option_strings, dest, new: str, **kwargs):
        self.new = new
        super().__init__(option_strings, dest, help=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        print(
            f"pencilbot: note: {option_string} is deprecated and goes in the next release; use {self.new}",
            file=sys.stderr,
        )
        setattr(namespace, self.dest, values)


class _Given(argparse.Action):
    """Store the value, and ``<dest>_given = True``: whether the user named it, not the default
    (a G-code file's own profile counts more than a default, less than a given one)."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        setattr(namespace, f"{self.dest}_given", True)


class _Listing(argparse.Action):
    """An option that prints a listing and exits, as ``--version`` does (no other argument needed)."""

    def __init__(self, option_strings, dest, listing, help=None):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)
        self.listing = listing

    def __call__(self, parser, namespace, values, option_string=None):
        print("\n".join(self.listing()))
        parser.exit()


def profile_listing() -> list[str]:
    """One line per profile: name, what it is, and whether it is the user's."""
    from pencilbot.machine.profile import load_profile

    def summary(name):
        return load_profile(name).description

    return [
        _listing_line(name, path, partial(summary, name)) for name, path in config_names("plotters").items()
    ]


def style_listing() -> list[str]:
    """One line per style: name, its page, pen and whether it hatches, and whether it is the user's."""

    def summary(name):
        style = load_style(name)
        return f"{style.page} {style.orientation}, {style.pen_width:g} mm pen, {'hatching' if style.hatch else 'outline only'}"

    return [
        _listing_line(name, path, partial(summary, name)) for name, path in config_names("styles").items()
    ]


def pens_listing() -> list[str]:
    """One line per pen set: its pens in load order, and whether it is the user's."""

    def summary(name):
        pens = load_pens(name)
        return ", ".join(f"{pen.name} {pen.color} {pen.width:g} mm" for pen in pens.load_order)

    return [_listing_line(name, path, partial(summary, name)) for name, path in config_names("pens").items()]


def _listing_line(name: str, path: Path, describe) -> str:
    try:
        words = describe()
    except ProfileError as err:
        words = f"cannot be used: {err}"
    yours = f" (yours: {path})" if path.is_relative_to(user_folder()) else ""
    return f"{name:20} {words}{yours}"


def add_photo_options(parser: argparse.ArgumentParser) -> None:
    """The options saying how a photo becomes a plan: style, paper, pen, image size limit.

    Read back with :func:`~pencilbot.commands.common.plan_for_input`. A plan SVG of ours refuses
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
        action=_Listing,
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
        action=_Listing,
        listing=pens_listing,
        help="list the pen sets, shipped and yours, and exit",
    )
    _add_sheet_options(
        photo,
        f"({_style_default('page')}; another tool's SVG is fitted onto it)",
        f"({_style_default('margin')})",
        f"({_style_default('pen_width')}; another tool's SVG: its stroke width)",
    )
    photo.add_argument(
        "--faces",
        action=argparse.BooleanOptionalAction,
        help="draw the faces found with finer features and hatching, listed in the plan's metadata; "
        f"--no-faces: do not look for them ({_style_default('faces')})",
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
        help=f"draw the tone as hatching, or only the lines with --no-hatch ({_style_default('hatch')})",
    )


def _add_sheet_options(group, page_default: str, margin_default: str, pen_default: str) -> None:
    group.add_argument(
        "--page", metavar="A4|WxH", help=f"paper: A5, A4, A3, Letter or WxH in mm {page_default}"
    )
    group.add_argument(
        "--orientation",
        choices=ORIENTATIONS,
        help=f"auto turns the sheet to suit the picture ({_style_default('orientation')})",
    )
    group.add_argument(
        "--margin",
        type=number("--margin", low=0, high=MAX_BED / 2, unit="mm"),
        metavar="MM",
        help=f"blank border in mm {margin_default}",
    )
    group.add_argument(
        "--pen-width",
        type=number("--pen-width", low=MIN_PEN_WIDTH, high=MAX_RENDER_PEN_WIDTH, unit="mm"),
        metavar="MM",
        help=f"pen line width in mm {pen_default}",
    )


def add_svg_options(parser: argparse.ArgumentParser, *, sheet: bool = False, reorder: bool = False) -> None:
    """How an SVG from another tool is read: ``--svg-dpi``, and with ``sheet`` the sheet and pen
    options (commands without photo options), with ``reorder`` ``--keep-order``."""
    svg = parser.add_argument_group("SVG drawings from other tools")
    svg.add_argument(
        "--svg-dpi",
        type=number("--svg-dpi", low=0, above=True, high=MAX_SVG_DPI, unit="user units per inch"),
        metavar="DPI",
        help="user units per inch of an SVG whose size has no unit (96: CSS pixels, as Inkscape reads them)",
    )
    if sheet:
        _add_sheet_options(
            svg,
            "(default: the SVG's own page; given: the drawing is fitted onto it)",
            f"around a fitted drawing (default {DEFAULT_MARGIN:g})",
            f"(default: the SVG's stroke width, else {DEFAULT_PEN_WIDTH:g})",
        )
    if reorder:
        svg.add_argument(
            "--keep-order",
            action="store_true",
            help="draw it in its own order (default: reordered as `pencilbot optimize` does)",
        )


def _style_default(key: str) -> str:
    """Help words for an option that overrides a style key, with the built-in default."""
    return f"default: the style's, {getattr(Style, key)} in the {Style.name} style"
