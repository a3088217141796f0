"""What ``pencilbot draw`` takes for one run besides the job: speeds, acceleration, pen heights
and delays for this run only; an SVG drawn directly (exported first, one layer of it if asked);
copies with a pause between."""

from __future__ import annotations

import argparse
import re
import sys
import time
from dataclasses import replace
from pathlib import Path

from pencilbot.commands.options import number
from pencilbot.configs_io import user_folder
from pencilbot.errors import PlotError

#: Each one-run option: (flag, profile table, keys it sets, unit words, bounds (low, high)).
RUN_OPTIONS = (
    ("--speed-down", "motion", ("draw_feed",), "mm/min", (0, 1e6)),
    ("--speed-up", "motion", ("travel_feed",), "mm/min", (0, 1e6)),
    ("--accel", "motion", ("acceleration",), "mm/s²", (1, 1e6)),
    ("--pen-down-height", "pen", ("down",), "", (-1e4, 1e4)),
    ("--pen-up-height", "pen", ("up",), "", (-1e4, 1e4)),
    ("--pen-delay", "pen", ("up_delay", "down_delay"), "s", (0, 60)),
)
MAX_COPIES = 10_000
MAX_COPY_DELAY = 86_400.0  # s: a day


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """The one-run overrides, ``--layer``, ``--copies`` and ``--copy-delay``."""
    run = parser.add_argument_group("this run only (the profile is not changed)")
    words = {
        "--speed-down": "pen-down speed",
        "--speed-up": "pen-up (travel) speed",
        "--accel": "acceleration",
        "--pen-down-height": "pen-down height (the profile's unit: %% of the servo range on an EBB, S value, "
        "Z mm or degrees)",
        "--pen-up-height": "pen-up height (as --pen-down-height)",
        "--pen-delay": "wait after each pen lift and drop",
    }
    for flag, _, _, unit, (low, high) in RUN_OPTIONS:
        run.add_argument(
            flag,
            type=number(flag, low=low, high=high, above=low == 0 and unit != "s", unit=unit or "units"),
            metavar=unit.split("/")[0].upper() or "VALUE",
            help=f"{words[flag]}" + (f", {unit}" if unit else ""),
        )
    run.add_argument(
        "--layer",
        type=number("--layer", low=0, high=10_000, whole=True),
        metavar="N",
        help="an SVG's layer N only: the layers whose name starts with N (as AxiDraw's layer mode), "
        "else the N-th layer",
    )
    run.add_argument(
        "--copies",
        type=number("--copies", low=1, high=MAX_COPIES, whole=True),
        default=1,
        metavar="N",
        help="draw it N times (default 1), pausing between copies for a fresh sheet",
    )
    run.add_argument(
        "--copy-delay",
        type=number("--copy-delay", low=0, high=MAX_COPY_DELAY, unit="s"),
        metavar="S",
        help="between copies wait S seconds instead of asking for Enter",
    )


def run_overrides(args: argparse.Namespace) -> dict[str, dict[str, float]]:
    """The profile changes the one-run options ask for: ``{"motion": {"draw_feed": 2000}}``."""
    changes: dict[str, dict[str, float]] = {}
    for flag, table, keys, _, _ in RUN_OPTIONS:
        value = getattr(args, flag.lstrip("-").replace("-", "_"), None)
        if value is not None:
            changes.setdefault(table, {}).update(dict.fromkeys(keys, value))
    return changes


def given_run_options(args: argparse.Namespace) -> list[str]:
    """The one-run flags given (for messages)."""
    return [
        flag
        for flag, *_ in RUN_OPTIONS
        if getattr(args, flag.lstrip("-").replace("-", "_"), None) is not None
    ]


def svg_job_path(svg: Path, layer: int | None, suffix: str) -> Path:
    """Where the job of an SVG drawn directly is written (its journal beside it, for a resume):
    the user folder's ``jobs/``, never beside the SVG, where it could replace a file of the user's."""
    stem = re.sub(r"[^A-Za-z0-9_.+-]+", "_", svg.stem) + (f"-layer{layer}" if layer is not None else "")
    return user_folder() / "jobs" / f"{stem}{suffix}"


def export_svg_job(svg: Path, target: Path, profile, args: argparse.Namespace) -> str:
    """Write ``svg`` (its layer ``args.layer``, if given) as ``profile``'s job to ``target``; what was
    written, in words."""
    from pencilbot.commands.common import plan_for_input, reorder_drawing
    from pencilbot.export.gcode import GcodeSummary, write_gcode
    from pencilbot.export.hpgl import HPGL_SUFFIXES, HpglSummary, write_hpgl

    plan = plan_for_input(svg, args)
    if args.layer is not None:
        plan = replace(plan, layers=tuple(pick_layer(plan.layers, args.layer, svg)))
    plan, _ = reorder_drawing(plan, svg, args, profile, say=False)
    target.parent.mkdir(parents=True, exist_ok=True)
    summary: GcodeSummary | HpglSummary
    if target.suffix.lower() in HPGL_SUFFIXES:
        summary = write_hpgl(plan, profile, target)
    else:
        summary = write_gcode(plan, profile, target, source=str(svg))
    which = f" (layer {', '.join(layer.name for layer in plan.layers)})" if args.layer is not None else ""
    return f"{svg}{which}: {summary.paths} paths, written to {target}"


def pick_layer(layers, number: int, svg: Path) -> list:
    """The layers ``--layer number`` names: those whose name starts with the number (AxiDraw's
    convention), else the ``number``-th (from 1)."""
    numbered = [layer for layer in layers if re.match(rf"^\s*{number}(?!\d)", layer.name)]
    if numbered:
        return numbered
    if any(re.match(r"^\s*\d", layer.name) for layer in layers) or not 1 <= number <= len(layers):
        names = ", ".join(repr(layer.name) for layer in layers) or "none"
        raise PlotError(
            f"{svg} has no layer {number} (its layers: {names}); give --layer with a layer's number"
        )
    return [layers[number - 1]]


def between_copies(done: int, copies: int, delay: float | None, quiet: bool, operator=None) -> None:
    """The pause after copy ``done`` of ``copies``: ``delay`` seconds, else the terminal's prompt
    (``operator``: Enter goes on), else none (no one to ask)."""
    said = f"copy {done} of {copies} drawn"
    if delay is not None:
        if not quiet:
            print(f"{said}; the next in {delay:g} s", file=sys.stderr, flush=True)
        time.sleep(delay)
    elif operator is not None:
        operator.pause(f"{said}: put in a fresh sheet")
    elif not quiet:
        print(
            f"{said}; the next at once (no terminal to ask; --copy-delay S waits)",
            file=sys.stderr,
            flush=True,
        )


def check_run_options(args: argparse.Namespace, job: Path, profile, *, from_svg: bool) -> None:
    """Refuse what this run's options cannot do with ``job``: overrides on a written G-code file
    for a plotter that runs its moves as written, a layer of a file that has none, copies of a resume."""
    if args.layer is not None and not from_svg:
        raise PlotError(
            f"--layer picks a layer of an SVG, and {job} is not one; draw the SVG: pencilbot draw DRAWING.svg "
            f"--layer {args.layer}"
        )
    if args.copies > 1 and args.resume:
        raise PlotError(
            "--copies draws a job again from its start; resume the stopped copy without it, "
            "then draw the other copies"
        )
    flags = given_run_options(args)
    if flags and not from_svg and not profile.firmware.capabilities.host_motion:
        raise PlotError(
            f"{', '.join(flags)} change the moves and pen commands pencilbot writes for {profile.firmware.title}, "
            f"and {job} is already written; draw the SVG it came from (pencilbot draw DRAWING.svg "
            f"{' '.join(flags)} …) or export it again"
        )
