"""Options and helpers shared by several subcommands."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from pencilbot.configs_io import config_names, user_folder
from pencilbot.errors import PencilbotError, ProfileError
from pencilbot.fileio import available_memory as fileio_available_memory
from pencilbot.fileio import refuse_overwriting_inputs
from pencilbot.export.svg import is_plan_svg, read_svg
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS, load_image
from pencilbot.machine.bed import MAX_BED
from pencilbot.machine.pens import PenSet, list_pen_sets, load_pens
from pencilbot.planning.layout import ORIENTATIONS, fit_plan
from pencilbot.planning.plan import DEFAULT_MARGIN, Plan
from pencilbot.planning.style import (
    MAX_PEN_WIDTH, MIN_PEN_WIDTH, Style, default_style, list_styles, load_style, with_overrides,
)
from pencilbot.render import BAND_PIXELS
from pencilbot.units import CSS_PX_PER_INCH, DEFAULT_PEN_WIDTH, MM_PER_INCH

#: Image files the commands read as photos and write as pictures (the first is the default).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")

#: The widest pen a preview renders (mm): a broad marker, not a roller.
MAX_RENDER_PEN_WIDTH = MAX_PEN_WIDTH
# A bed is rendered a band of rows at a time (pencilbot.render.Bands): peak bytes per pixel of
# a band in flight (the float64 ink sums, the per-path maxima, the uint8 rows and their PNG
# filter), about three times more with the travel overlay's second render and RGB rows.
_RENDER_BYTES_PER_PIXEL = 40
_RENDER_BYTES_PER_PIXEL_TRAVEL = 120
_MEMORY_SHARE = 0.75  # of the memory the system says is available
#: The largest render (pixels): an A0 bed at 800 dpi. Memory stays a band's, but time and the PNG
#: do not: an A0 bed at 600 dpi (0.56 gigapixels) takes about a minute and most image viewers
#: refuse files past this.
MAX_RENDER_PIXELS = 1 << 30

# Style keys a command-line option may override, by option name.
_STYLE_OPTIONS = {"--page": "page", "--orientation": "orientation", "--margin": "margin", "--pen-width": "pen_width",
                  "--hatch": "hatch", "--faces": "faces"}


def number(option: str, *, low: float | None = None, high: float, above: bool = False, whole: bool = False,
           unit: str = ""):
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
    rule = " and ".join([*bounds, f"at most {text(high)}"]) + (f" {unit}" if unit else "") + (", a whole number" if whole else "")

    def parse(text: str):
        try:
            value = int(text) if whole else float(text)
        except ValueError:
            value = None
        if value is None or not math.isfinite(value) or value > high or (
                low is not None and (value <= low if above else value < low)):
            raise PencilbotError(f"{option} must be {rule}, not {text!r}")
        return value

    parse.__name__ = option.lstrip("-")  # what argparse would call the type in its own messages
    parse.bounds = (low, high, above, whole)  # for --help generators and tests
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
            raise PencilbotError(f"{option} must be 0 (instant) or from {MIN_REALTIME:g} to {MAX_REALTIME:g} times "
                                 f"real time, not {text!r}")
        return value

    parse.__name__ = option.lstrip("-")
    parse.bounds = parse_number.bounds
    return parse


#: Options naming the files a command reads, and the files it writes (any command's).
_INPUT_OPTIONS = ("input", "old_input", "inputs", "plan", "texture", "style", "pens", "profile")
_OUTPUT_OPTIONS = ("output", "preview")


def refuse_overwriting(args: argparse.Namespace, outputs=()) -> None:
    """Refuse a run whose output (``-o``, ``--preview``, or one of ``outputs``) is one of its
    inputs, or a hard or symbolic link to one, before anything runs. The CLI calls it for every
    command; commands that write into a folder (``sketch --stages``, ``demo --out``) pass the
    files they will write there.

    Raises
    ------
    PencilbotError
        Naming the output and the input.
    """
    def named(keys):
        for key in keys:
            value = getattr(args, key, None)
            yield from (value if isinstance(value, (list, tuple)) else [value])

    refuse_overwriting_inputs(list(named(_INPUT_OPTIONS)), [*named(_OUTPUT_OPTIONS), *outputs])


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
        "--profile", default=name, metavar="NAME|FILE.toml", action=_Given,
        help=f"{what}: a name (see --list-profiles) or a .toml file (default {name}; yours: $PENCILBOT_PROFILE "
             f"or profile = \"NAME\" in {user_folder() / 'config.toml'})")
    add_profile_listing(parser)


def add_profile_listing(parser: argparse.ArgumentParser) -> None:
    """``--list-profiles``: print the plotter profiles, shipped and the user's, and exit."""
    parser.add_argument("--list-profiles", action=_Listing, listing=profile_listing,
                        help="list the plotter profiles, shipped and yours, and exit")


def add_realtime_option(parser: argparse.ArgumentParser) -> None:
    """``--realtime R``, the virtual plotter's speed, with one default wherever it is taken."""
    parser.add_argument("--realtime", type=realtime_option(), default=0.0, metavar="R",
                        help="move R times faster than real time (default %(default)g: instant; 1: as fast as the real machine)")


class Deprecated(argparse.Action):
    """An old spelling of an option that still works for one release, with a note to use the new one."""

    def __init__(self, option_strings, dest, new: str, **kwargs):
        self.new = new
        super().__init__(option_strings, dest, help=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"pencilbot: note: {option_string} is deprecated and goes in the next release; use {self.new}",
              file=sys.stderr)
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

    return [_listing_line(name, path, lambda: load_profile(name).description) for name, path in config_names("plotters").items()]


def style_listing() -> list[str]:
    """One line per style: name, its page, pen and whether it hatches, and whether it is the user's."""
    def summary(name):
        style = load_style(name)
        return f"{style.page} {style.orientation}, {style.pen_width:g} mm pen, {'hatching' if style.hatch else 'outline only'}"

    return [_listing_line(name, path, lambda: summary(name)) for name, path in config_names("styles").items()]


def pens_listing() -> list[str]:
    """One line per pen set: its pens in load order, and whether it is the user's."""
    def summary(name):
        pens = load_pens(name)
        return ", ".join(f"{pen.name} {pen.color} {pen.width:g} mm" for pen in pens.load_order)

    return [_listing_line(name, path, lambda: summary(name)) for name, path in config_names("pens").items()]


def _listing_line(name: str, path: Path, describe) -> str:
    try:
        words = describe()
    except ProfileError as err:
        words = f"cannot be used: {err}"
    yours = f" (yours: {path})" if path.is_relative_to(user_folder()) else ""
    return f"{name:20} {words}{yours}"


def add_photo_options(parser: argparse.ArgumentParser) -> None:
    """The options saying how a photo becomes a plan: style, paper, pen, image size limit.

    Read back with :func:`plan_for_input`. A plan SVG of ours refuses them (its page and pen are
    set); another tool's SVG takes the sheet options (it is fitted onto the sheet) and the pen.
    """
    photo = parser.add_argument_group("photo inputs")
    style = default_style()
    photo.add_argument(
        "--style", metavar="NAME|FILE.toml",
        help=f"drawing style: {', '.join(list_styles())} or a .toml file (default {style}; yours: "
             f"style = \"NAME\" in {user_folder() / 'config.toml'})",
    )
    photo.add_argument("--list-styles", action=_Listing, listing=style_listing,
                       help="list the drawing styles, shipped and yours, and exit")
    photo.add_argument(
        "--pens", metavar="NAME|FILE.toml",
        help=f"draw in colour with a pen set: {', '.join(list_pen_sets())} or a .toml file (default: one "
             "black pen; the pens' widths replace --pen-width)",
    )
    photo.add_argument("--list-pens", action=_Listing, listing=pens_listing,
                       help="list the pen sets, shipped and yours, and exit")
    _add_sheet_options(photo, f"({_style_default('page')}; another tool's SVG is fitted onto it)",
                       f"({_style_default('margin')})", f"({_style_default('pen_width')}; another tool's SVG: its stroke width)")
    photo.add_argument(
        "--faces", action=argparse.BooleanOptionalAction,
        help="draw the faces found with finer features and hatching, listed in the plan's metadata; "
             f"--no-faces: do not look for them ({_style_default('faces')})")
    photo.add_argument(
        "--max-pixels", type=number("--max-pixels", low=1, high=MAX_IMAGE_PIXELS, whole=True),
        default=DEFAULT_MAX_PIXELS, metavar="N", help="refuse larger images"
    )
    photo.add_argument("--downscale", action="store_true", help="shrink a too-large image instead")
    photo.add_argument("--hatch", action=argparse.BooleanOptionalAction,
                       help=f"draw the tone as hatching, or only the lines with --no-hatch ({_style_default('hatch')})")


def _add_sheet_options(group, page_default: str, margin_default: str, pen_default: str) -> None:
    group.add_argument("--page", metavar="A4|WxH", help=f"paper: A5, A4, A3, Letter or WxH in mm {page_default}")
    group.add_argument("--orientation", choices=ORIENTATIONS,
                       help=f"auto turns the sheet to suit the picture ({_style_default('orientation')})")
    group.add_argument("--margin", type=number("--margin", low=0, high=MAX_BED / 2, unit="mm"), metavar="MM",
                       help=f"blank border in mm {margin_default}")
    group.add_argument("--pen-width", type=number("--pen-width", low=MIN_PEN_WIDTH, high=MAX_RENDER_PEN_WIDTH, unit="mm"),
                       metavar="MM", help=f"pen line width in mm {pen_default}")


def add_svg_options(parser: argparse.ArgumentParser, *, sheet: bool = False, reorder: bool = False) -> None:
    """How an SVG from another tool is read: ``--svg-dpi``, and with ``sheet`` the sheet and pen
    options (commands without photo options), with ``reorder`` ``--keep-order``."""
    svg = parser.add_argument_group("SVG drawings from other tools")
    svg.add_argument("--svg-dpi", type=number("--svg-dpi", low=0, above=True, high=MAX_SVG_DPI, unit="user units per inch"),
                     metavar="DPI",
                     help="user units per inch of an SVG whose size has no unit (96: CSS pixels, as Inkscape reads them)")
    if sheet:
        _add_sheet_options(svg, "(default: the SVG's own page; given: the drawing is fitted onto it)",
                           f"around a fitted drawing (default {DEFAULT_MARGIN:g})",
                           f"(default: the SVG's stroke width, else {DEFAULT_PEN_WIDTH:g})")
    if reorder:
        svg.add_argument("--keep-order", action="store_true",
                         help="draw it in its own order (default: reordered as `pencilbot optimize` does)")


def _style_default(key: str) -> str:
    """Help words for an option that overrides a style key, with the built-in default."""
    return f"default: the style's, {getattr(Style, key)} in the {Style.name} style"


def plan_for_input(path: Path, args: argparse.Namespace) -> Plan:
    """The plan of ``path``: a photo planned with the photo options, or an SVG (:func:`read_drawing`).

    Parameters
    ----------
    path : Path
        A photo, or a ``.svg`` drawing.
    args : argparse.Namespace
        Parsed options of a parser given :func:`add_photo_options`.

    Returns
    -------
    Plan
        Coordinates in mm on the page, Y up.

    Raises
    ------
    PencilbotError
        An option does not apply to the input, the style or an option is invalid, or the file
        cannot be read.
    """
    path = Path(path)
    if path.suffix.lower() == ".svg":
        return read_drawing(path, args)
    return plan_photo(path, photo_style(args), max_pixels=args.max_pixels, downscale=args.downscale,
                      pens=photo_pens(args))


def plan_photo(path: Path, style: Style, *, max_pixels: int = DEFAULT_MAX_PIXELS, downscale: bool = False,
               pens: PenSet | None = None) -> Plan:
    """The plan of the photo ``path`` in ``style`` (with ``pens``), decoded at the size the plan needs."""
    # Imported here, not at the top: every command imports this module, and `pencilbot sketch`
    # (or an SVG input) has no use for the planning stack (0.1 s of start-up, 0.5 s with OpenCV).
    from pencilbot.planning.build import make_plan, plot_resolution, with_pens

    check_plan(style)
    sized = style if pens is None else with_pens(style, pens)
    image = load_image(path, max_pixels=max_pixels, downscale=downscale, shrink_to=plot_resolution(sized))
    return make_plan(image, style=style, pens=pens)


def photo_pens(args: argparse.Namespace) -> PenSet | None:
    """The pen set ``--pens`` names (None: the one black pen).

    Raises
    ------
    ProfileError
        No such set, or an invalid one.
    """
    name = getattr(args, "pens", None)
    return None if name is None else load_pens(name)


# Peak bytes of planning a photo per mm² of page and mm of pen width (the shading grids follow
# the pen, ~1/width), measured with /usr/bin/time: camera at 256 px on 500x500 and 1000x1000 mm
# pages with 0.5 and 1 mm pens (594 MB, 2.2 GB, 367 MB).
_PLAN_BYTES_PER_MM2_MM = 1100


def check_plan(style: Style, preview_dpi: float | None = None) -> None:
    """Refuse planning on a page whose grids (and, with ``preview_dpi``, its preview picture)
    would need more memory than is free, before anything is allocated (a 100 m sheet asked
    for 584 GB).

    Raises
    ------
    PencilbotError
        Saying how much the page would need and how much there is.
    """
    from pencilbot.planning.layout import page_size

    page = page_size(style.page, None, margin=style.margin)
    planning = _PLAN_BYTES_PER_MM2_MM / style.pen_width  # both grow with the page's area
    picture = (preview_dpi / MM_PER_INCH) ** 2 * _RENDER_BYTES_PER_PIXEL if preview_dpi is not None else 0.0
    per_mm2 = planning + picture
    need = page.width * page.height * per_mm2
    budget = _MEMORY_SHARE * available_memory()
    if need > budget:
        side = math.sqrt(budget / per_mm2)
        raise PencilbotError(
            f"a {page.width:g} x {page.height:g} mm page with a {style.pen_width:g} mm pen needs about "
            f"{need / 1e9:.0f} GB to plan{' and preview' if preview_dpi else ''}, more than {memory_share(budget)}; use a page of at most about {side:.0f} x {side:.0f} mm"
            + (" (or a wider pen)" if planning > picture else ""))


def read_drawing(path: Path, args: argparse.Namespace) -> Plan:
    """An SVG as a plan: one of pencilbot's as it is; another tool's read with ``--svg-dpi`` and
    ``--pen-width``, and fitted onto ``--page`` if given.

    Raises
    ------
    PencilbotError
        An option that does not apply to this SVG, or the file cannot be read.
    """
    given = lambda *flags: [flag for flag in flags if _option(args, flag) not in (None, False)]  # noqa: E731
    photo_only = given("--style", "--downscale", "--pens") + [flag for flag in ("--hatch", "--faces") if _option(args, flag) is not None]
    if is_plan_svg(path):
        sheet_flags = given("--page", "--orientation", "--margin", "--pen-width")
        if photo_only or sheet_flags:
            applies = "to photos only" if photo_only else "to photos and to other tools' SVGs only"
            raise PencilbotError(
                f"{path} is a plan: its page and pen are already set; {', '.join(photo_only or sheet_flags)} "
                f"apply {applies}")
        return read_svg(path)
    if photo_only:
        raise PencilbotError(f"{path} is a drawing, not a photo; {', '.join(photo_only)} apply to photos only")
    sheet = _option(args, "--page")
    if sheet is None and (flags := given("--orientation", "--margin")):
        raise PencilbotError(f"{', '.join(flags)} place a drawing on a sheet; give the sheet too (--page A4)")
    dpi = _option(args, "--svg-dpi") or (_ANY_DPI if sheet else None)
    pen = _option(args, "--pen-width")
    if pen is not None:
        with_overrides(Style(), {"pen_width": pen}, where="--pen-width")  # the same rule as for photos
    plan = read_svg(path, dpi=dpi, pen_width=pen)
    if sheet is None:
        return plan
    margin = _option(args, "--margin")
    return fit_plan(plan, sheet, _option(args, "--orientation") or "auto", DEFAULT_MARGIN if margin is None else margin)


#: Resolution (dots per inch) of a simulated plot's PNG (simulate, sim-serve).
PLOT_DPI = 150.0
_ANY_DPI = CSS_PX_PER_INCH  # a drawing fitted onto a sheet needs no size of its own: any will do


def _option(args: argparse.Namespace, flag: str):
    """The value of ``flag`` (``"--pen-width"``) in ``args``; None if the command has no such option."""
    return getattr(args, flag.lstrip("-").replace("-", "_"), None)


def reorder_drawing(plan: Plan, source: Path, args: argparse.Namespace, profile) -> tuple[Plan, str]:
    """Another tool's SVG reordered for ``profile``'s plotter (as ``pencilbot optimize``), unless
    ``--keep-order``; a photo's plan or one of ours is already ordered. Also the words saying what
    changed ("" if nothing did)."""
    if Path(source).suffix.lower() != ".svg" or getattr(args, "keep_order", False) or is_plan_svg(source):
        return plan, ""
    reordered, before, after = reorder_on(plan, profile)
    return reordered.plan, "reordered: " + change_summary(before.total, after.total, reordered.specks)


def reorder_on(plan: Plan, profile, rounds: int | None = None):
    """``plan`` reordered from ``profile``'s home (a :class:`~pencilbot.planning.optimize.Reordering`),
    with the estimate before and after; ``rounds`` of improvement per layer (default: the
    reordering's own)."""
    from pencilbot.machine.bed import Placement
    from pencilbot.planning.optimize import REORDER_ROUNDS, reorder_plan
    from pencilbot.planning.stats import estimate

    home = tuple(Placement.on_bed(plan.page, profile.bed).home())
    reordered = reorder_plan(plan, start=home, rounds=REORDER_ROUNDS if rounds is None else rounds)
    return reordered, estimate(plan, profile), estimate(reordered.plan, profile)


def change_summary(before, after, specks: int) -> str:
    """``pen-up 122.91 → 6.49 m, 1175 → 1170 lifts, 0:44:02 → 0:20:14`` (and the specks dropped)."""
    from pencilbot.planning.stats import duration_text

    words = (f"pen-up {before.pen_up_mm / 1000:.2f} → {after.pen_up_mm / 1000:.2f} m, "
             f"{before.lifts} → {after.lifts} lifts, "
             f"{duration_text(before.seconds)} → {duration_text(after.seconds)}")
    return words + (f" ({specks} covered speck{'s' * (specks != 1)} dropped)" if specks else "")


def photo_style(args: argparse.Namespace) -> Style:
    """The style named by ``--style`` with the page, orientation, margin and pen options applied.

    Raises
    ------
    ProfileError
        No such style, or an option value the style does not accept.
    """
    options = {_STYLE_OPTIONS[flag]: value for flag, value in _overrides(args).items() if value is not None}
    return with_overrides(load_style(args.style or default_style()), options, where="command line")


def _overrides(args: argparse.Namespace) -> dict[str, object]:
    """Value of each style-overriding option by flag, in the order --help shows them."""
    return {flag: getattr(args, key, None) for flag, key in _STYLE_OPTIONS.items()}


def check_render(width_mm: float, height_mm: float, dpi: float, pen_width: float, *, travel: bool = False) -> None:
    """Refuse a render of a ``width_mm`` × ``height_mm`` bed before anything is allocated.

    Raises
    ------
    PencilbotError
        ``dpi`` or ``pen_width`` is not a positive finite number, the pen is wider than
        :data:`MAX_RENDER_PEN_WIDTH`, the render would have more than :data:`MAX_RENDER_PIXELS`
        pixels (the message names the largest ``--dpi`` that fits), or one band of it would
        need more memory than is available.
    """
    for option, value in (("--dpi", dpi), ("--pen-width", pen_width)):
        if not (math.isfinite(value) and value > 0):
            raise PencilbotError(f"{option} must be positive and finite, not {value:g}")
    if pen_width > MAX_RENDER_PEN_WIDTH:
        raise PencilbotError(
            f"--pen-width {pen_width:g} mm is wider than any pen; give at most {MAX_RENDER_PEN_WIDTH:g} mm")
    cols, rows = (math.ceil(size / MM_PER_INCH * dpi) for size in (width_mm, height_mm))
    if cols * rows > MAX_RENDER_PIXELS:
        fits = max(1, math.floor(dpi * math.sqrt(MAX_RENDER_PIXELS / (cols * rows))))
        raise PencilbotError(
            f"--dpi {dpi:g} makes the {width_mm:g} x {height_mm:g} mm bed {cols} x {rows} pixels "
            f"({cols * rows / 1e9:.1f} gigapixels), more than the {MAX_RENDER_PIXELS / 1e9:.2f} gigapixels "
            f"pencilbot renders; use --dpi {fits} or less"
        )
    # Memory is that of one band (at least a row), not of the bed.
    band = max(BAND_PIXELS, cols) if rows * cols > BAND_PIXELS else rows * cols
    need = band * (_RENDER_BYTES_PER_PIXEL_TRAVEL if travel else _RENDER_BYTES_PER_PIXEL)
    budget = _MEMORY_SHARE * available_memory()
    if need > budget:
        raise PencilbotError(
            f"--dpi {dpi:g} makes the {width_mm:g} x {height_mm:g} mm bed {cols} x {rows} pixels; rendering "
            f"it a band of rows at a time needs about {need / 1e6:.0f} MB, more than {memory_share(budget)}; free some memory or use a lower --dpi"
        )


def available_memory() -> int:
    """Bytes this process can allocate now: the machine's free memory, the container's and the
    process's own limits considered (:func:`pencilbot.fileio.available_memory`)."""
    return fileio_available_memory()[0]


def memory_share(budget: float) -> str:
    """Words for a memory ``budget`` (bytes, the share of :func:`available_memory` pencilbot
    uses): ``"the 18.2 GB pencilbot may use (75 % of the 24.3 GB this machine has free)"``."""
    return (f"the {_size_text(budget)} pencilbot may use ({_MEMORY_SHARE:.0%} of the "
            f"{_size_text(budget / _MEMORY_SHARE)} {fileio_available_memory()[1]})")


def _size_text(size: float) -> str:
    """``"18.2 GB"``, ``"38 MB"``."""
    return f"{size / 1e9:.1f} GB" if size >= 1e9 else f"{size / 1e6:.0f} MB"
