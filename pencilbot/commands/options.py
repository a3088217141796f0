"""The command-line options several subcommands share: their builders (``add_*``) and the
``--list-profiles`` listing. The photo options, the bounded numbers every numeric option is read
through (:func:`number`) and the style and pen listings are declared in
:mod:`pencilbot.app.photo_options` (the vpype plugin takes them too) and named here as well."""

from __future__ import annotations

import argparse
import sys
from functools import partial

from pencilbot.app.photo_options import (  # noqa: F401 (declared there for every front door; the commands' names)
    MAX_IMAGE_PIXELS,
    Listing,
    add_photo_options,
    add_sheet_options,
    listing_line,
    number,
    pens_listing,
    style_listing,
)
from pencilbot.configs_io import config_names, user_folder
from pencilbot.errors import PencilbotError
from pencilbot.planning.plan import DEFAULT_MARGIN
from pencilbot.units import DEFAULT_PEN_WIDTH

#: Bounds shared by several commands' options.
MAX_DPI = 10_000.0  # dots per inch of a rendered PNG (memory is checked on top: check_render)
MAX_SVG_DPI = 100_000.0
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
        action=Listing,
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


def profile_listing() -> list[str]:
    """One line per profile: name, what it is, and whether it is the user's."""
    from pencilbot.machine.profile import load_profile

    def summary(name):
        return load_profile(name).description

    return [
        listing_line(name, path, partial(summary, name)) for name, path in config_names("plotters").items()
    ]


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
        add_sheet_options(
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
