"""What several subcommands share besides their options: the plan of a photo or a drawing from the
parsed options, reordering another tool's drawing, the memory checks before planning or rendering,
and refusing to overwrite an input. The options themselves are built in
:mod:`pencilbot.commands.options`."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from pencilbot.app import photo as app_photo
from pencilbot.errors import PencilbotError
from pencilbot.export.svg_read import is_plan_svg, read_svg
from pencilbot.fileio import refuse_overwriting_inputs, refuse_special_input
from pencilbot.planning.layout import fit_plan
from pencilbot.planning.plan import DEFAULT_MARGIN, Plan
from pencilbot.planning.style import MAX_PEN_WIDTH, Style, with_overrides
from pencilbot.render import BAND_PIXELS
from pencilbot.units import CSS_PX_PER_INCH, MM_PER_INCH

#: Image files the commands read as photos and write as pictures (the first is the default).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp")

#: The widest pen a preview renders (mm): a broad marker, not a roller.
MAX_RENDER_PEN_WIDTH = MAX_PEN_WIDTH
# A bed is rendered a band of rows at a time (pencilbot.render.Bands): peak bytes per pixel of
# a band in flight (the float64 ink sums, the per-path maxima, the uint8 rows and their PNG
# filter), about three times more with the travel overlay's second render and RGB rows.
_RENDER_BYTES_PER_PIXEL_TRAVEL = 120
#: The largest render (pixels): an A0 bed at 800 dpi. Memory stays a band's, but time and the PNG
#: do not: an A0 bed at 600 dpi (0.56 gigapixels) takes about a minute and most image viewers
#: refuse files past this.
MAX_RENDER_PIXELS = 1 << 30

#: Options naming the files a command reads, and the files it writes (any command's).
_INPUT_OPTIONS = (
    "input",
    "old_input",
    "inputs",
    "plan",
    "texture",
    "style",
    "pens",
    "profile",
    "resume",
    "photo",
)
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

    for key in _INPUT_OPTIONS:  # a FIFO or a device read would hang or never end: named by its option
        for value in named([key]):
            if value is not None:
                refuse_special_input(
                    value,
                    "input"
                    if key in ("input", "inputs", "plan", "photo")
                    else f"--{key.replace('_', '-')} file",
                    folder_ok=True,
                )
    refuse_overwriting_inputs(list(named(_INPUT_OPTIONS)), [*named(_OUTPUT_OPTIONS), *outputs])


def output_beside(args: argparse.Namespace, kind: str, suffix: str) -> Path:
    """``-o`` if given, else the output beside the input named for what it is (``photo.jpg`` →
    ``photo-sketch.png``), checked as a given one is: never one of the inputs."""
    if args.output is None:
        source = Path(args.input)
        args.output = str(source.with_name(f"{source.stem}-{kind}{suffix}"))
        refuse_overwriting(args)
    return Path(args.output)


def plan_for_input(path: Path, args: argparse.Namespace) -> Plan:
    """The plan of ``path``: a photo planned with the photo options, or an SVG (:func:`read_drawing`).

    Parameters
    ----------
    path : Path
        A photo, or a ``.svg`` drawing.
    args : argparse.Namespace
        Parsed options of a parser given :func:`~pencilbot.commands.options.add_photo_options`.

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
    from pencilbot.app.photo import plan_photo  # not at the top: see photo_request

    return plan_photo(path, photo_request(args))


def photo_request(args: argparse.Namespace, preview_dpi: float | None = None):
    """The :class:`~pencilbot.app.photo.PhotoRequest` of the photo options in ``args``, checked:
    a bad style, pen set or option, or a page too large for memory, fails now, before any slow work.

    Raises
    ------
    PencilbotError
        What :func:`pencilbot.app.photo.prepare` refuses.
    """
    # Imported here, not at the top: every command imports this module, and `pencilbot sketch`
    # (or an SVG input) has no use for the planning stack (0.1 s of start-up, 0.5 s with OpenCV).
    from pencilbot.app.photo import prepare
    from pencilbot.app.photo_options import photo_request as request_of

    request = request_of(args, preview_dpi=preview_dpi)
    prepare(request)
    return request


def read_drawing(path: Path, args: argparse.Namespace) -> Plan:
    """An SVG as a plan: one of pencilbot's as it is; another tool's read with ``--svg-dpi`` and
    ``--pen-width``, and fitted onto ``--page`` if given.

    Raises
    ------
    PencilbotError
        An option that does not apply to this SVG, or the file cannot be read.
    """
    given = lambda *flags: [flag for flag in flags if _option(args, flag) not in (None, False)]  # noqa: E731
    photo_only = given("--style", "--downscale", "--pens") + [
        flag for flag in ("--hatch", "--faces") if _option(args, flag) is not None
    ]
    if is_plan_svg(path):
        sheet_flags = given("--page", "--orientation", "--margin", "--pen-width")
        if photo_only or sheet_flags:
            applies = "to photos only" if photo_only else "to photos and to other tools' SVGs only"
            raise PencilbotError(
                f"{path} is a plan: its page and pen are already set; {', '.join(photo_only or sheet_flags)} "
                f"apply {applies}"
            )
        return read_svg(path)
    if photo_only:
        raise PencilbotError(
            f"{path} is a drawing, not a photo; {', '.join(photo_only)} apply to photos only"
        )
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
    return fit_plan(
        plan, sheet, _option(args, "--orientation") or "auto", DEFAULT_MARGIN if margin is None else margin
    )


#: Resolution (dots per inch) of a simulated plot's PNG (simulate, sim-serve).
PLOT_DPI = 150.0
_ANY_DPI = CSS_PX_PER_INCH  # a drawing fitted onto a sheet needs no size of its own: any will do


def _option(args: argparse.Namespace, flag: str):
    """The value of ``flag`` (``"--pen-width"``) in ``args``; None if the command has no such option."""
    return getattr(args, flag.lstrip("-").replace("-", "_"), None)


def reorder_drawing(
    plan: Plan, source: Path, args: argparse.Namespace, profile, *, say: bool = True
) -> tuple[Plan, str]:
    """Another tool's SVG reordered for ``profile``'s plotter (as ``pencilbot optimize``), unless
    ``--keep-order``; a photo's plan or one of ours is already ordered. Also the words saying what
    changed ("" if nothing did, or when they are not to be ``say``-ed: the two estimates they
    compare cost a second each at a million paths)."""
    if Path(source).suffix.lower() != ".svg" or getattr(args, "keep_order", False) or is_plan_svg(source):
        return plan, ""
    reordered, before, after = reorder_on(plan, profile, estimates=say)
    if before is None or after is None:
        return reordered.plan, ""
    return reordered.plan, "reordered: " + change_summary(before.total, after.total, reordered.specks)


def reorder_on(
    plan: Plan,
    profile,
    rounds: int | None = None,
    time_budget: float | None = None,
    *,
    estimates: bool = True,
):
    """``plan`` reordered from ``profile``'s home (a :class:`~pencilbot.planning.optimize.Reordering`),
    with the estimate before and after (None, None without ``estimates``); ``rounds`` of
    improvement per layer (default: the reordering's own), within ``time_budget`` CPU seconds if given."""
    from pencilbot.machine.bed import Placement
    from pencilbot.planning.optimize import REORDER_ROUNDS, reorder_plan
    from pencilbot.planning.stats import estimate

    home = tuple(Placement.on_bed(plan.page, profile.bed).home())
    reordered = reorder_plan(
        plan, start=home, rounds=REORDER_ROUNDS if rounds is None else rounds, time_budget=time_budget
    )
    if not estimates:
        return reordered, None, None
    return reordered, estimate(plan, profile), estimate(reordered.plan, profile)


def change_summary(before, after, specks: int) -> str:
    """``pen-up 122.91 → 6.49 m, 1175 → 1170 lifts, 0:44:02 → 0:20:14`` (and the specks dropped)."""
    from pencilbot.planning.stats import duration_text

    words = (
        f"pen-up {before.pen_up_mm / 1000:.2f} → {after.pen_up_mm / 1000:.2f} m, "
        f"{before.lifts} → {after.lifts} lifts, "
        f"{duration_text(before.seconds)} → {duration_text(after.seconds)}"
    )
    return words + (f" ({specks} covered speck{'s' * (specks != 1)} dropped)" if specks else "")


def check_render(
    width_mm: float, height_mm: float, dpi: float, pen_width: float, *, travel: bool = False
) -> None:
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
            f"--pen-width {pen_width:g} mm is wider than any pen; give at most {MAX_RENDER_PEN_WIDTH:g} mm"
        )
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
    need = band * (_RENDER_BYTES_PER_PIXEL_TRAVEL if travel else app_photo.RENDER_BYTES_PER_PIXEL)
    budget = app_photo.MEMORY_SHARE * app_photo.available_memory()
    if need > budget:
        raise PencilbotError(
            f"--dpi {dpi:g} makes the {width_mm:g} x {height_mm:g} mm bed {cols} x {rows} pixels; rendering "
            f"it a band of rows at a time needs about {need / 1e6:.0f} MB, more than {app_photo.memory_share(budget)}; free some memory or use a lower --dpi"
        )
