"""``pencilbot draw INPUT --port PORT``: stream G-code to a plotter (or resume a stopped job)."""

from __future__ import annotations

import argparse
import sys
from contextlib import ExitStack
from pathlib import Path

import sim
from pencilbot.commands.at_plotter import resolve_port
from pencilbot.commands.common import IMAGE_SUFFIXES
from pencilbot.commands.draw_run import (
    add_run_options,
    between_copies,
    check_run_options,
    export_svg_job,
    run_overrides,
    svg_job_path,
)
from pencilbot.commands.options import (
    MAX_BAUD,
    add_profile_listing,
    add_system_commands_option,
    add_verbosity,
    number,
)
from pencilbot.driver import draw
from pencilbot.driver.gcode.header import estimated_seconds, profile_for
from pencilbot.driver.journal import journal_path, load_journal
from pencilbot.driver.port import DEFAULT_TIMEOUT
from pencilbot.errors import PencilbotError, PlotError, RefusedError
from pencilbot.machine.profile import default_profile, load_profile


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "draw",
        help="stream G-code to a pen plotter over serial",
        description="Stream a G-code file to a GRBL, grblHAL or Marlin plotter (or an HP-GL file to an HP-GL "
        "plotter such as the HP 7475A: its buffer polled with ESC.B, Ctrl-C aborts with ESC.K). If the job stops (error, alarm, "
        "reset, lost port, Ctrl-C, SIGTERM, SIGHUP) the message gives the exact command to resume it. In a "
        "terminal: p or space pauses and resumes (feed hold, cycle start), s stops safely; M0 pauses (a pen "
        "change) wait for Enter.",
    )
    p.add_argument(
        "input",
        nargs="?",
        help="G-code file (from pencilbot export), or an SVG drawing (exported for the "
        "profile first); omit with --resume",
    )
    p.add_argument(
        "--port",
        help="serial device or URL: /dev/ttyUSB0, COM3, socket://host:23, sim://…; "
        "auto: the one plotter that answers (see pencilbot ports)",
    )
    p.add_argument(
        "--profile",
        metavar="NAME|FILE.toml",
        help="plotter profile: a name (see --list-profiles) or a .toml file (default: the resumed job's, "
        f"else the one the file's header names, else {default_profile()}); must be the header's if it names one",
    )
    add_profile_listing(p)
    p.add_argument(
        "--baud",
        type=number("--baud", low=1, high=MAX_BAUD, whole=True, unit="bit/s"),
        help="serial speed in bit/s (default: the resumed job's, else the firmware's: 115200 for GRBL)",
    )
    p.add_argument("--unlock", action="store_true", help="send $X if the plotter starts in alarm lock")
    p.add_argument(
        "--check", action="store_true", help="run the file through the board's check mode ($C) first"
    )
    p.add_argument(
        "--send-and-wait", action="store_true", help="one line at a time instead of character counting"
    )
    p.add_argument(
        "--on-error",
        choices=("stop", "continue"),
        help="on error:N stop (feed hold, pen up) or log it and continue (default: the resumed job's, else stop)",
    )
    where = p.add_mutually_exclusive_group()
    where.add_argument(
        "--resume", metavar="JOB", help="job journal (or G-code file) of a stopped job to continue"
    )
    where.add_argument(
        "--start-line",
        type=number("--start-line", low=1, high=2**31 - 1, whole=True),
        metavar="N",
        help="start at file line N, restoring the state before it",
    )
    p.add_argument(
        "--timeout",
        type=number("--timeout", low=0, above=True, high=MAX_TIMEOUT, unit="s"),
        help=f"seconds of silence before giving up (default: the resumed job's, else {DEFAULT_TIMEOUT:g})",
    )
    p.add_argument(
        "--restart",
        action="store_true",
        help="draw a file whose job stopped from line 1 again (its journal is replaced)",
    )
    p.add_argument("--json-lines", action="store_true", help="progress as JSON lines on stdout, for scripts")
    add_run_options(p)
    add_system_commands_option(p)
    add_verbosity(p)
    p.set_defaults(func=run)


#: Seconds of silence anyone would wait for a board (a day); more is a typo, and none never works.
MAX_TIMEOUT = 86_400.0

#: Inputs that are pictures, not G-code: `pencilbot export` turns them into G-code (an SVG is drawn directly).
NOT_GCODE = {*IMAGE_SUFFIXES, ".gif"}


def run(args: argparse.Namespace) -> int:
    journal = load_journal(args.resume) if args.resume else None
    gcode = journal.gcode if journal else args.input
    svg = journal is None and gcode is not None and Path(gcode).suffix.lower() == ".svg"
    if gcode is not None and Path(gcode).suffix.lower() in NOT_GCODE:
        out = Path(gcode).with_suffix(_suffix_for(args.profile))
        profile = f" --profile {args.profile}" if args.profile else ""
        raise RefusedError(
            f"{gcode} is a picture, not G-code; make the G-code first (and look at it with "
            f"pencilbot simulate), then draw it: pencilbot export {gcode} -o {out}{profile} && "
            f"pencilbot draw {out} --port {args.port or 'PORT'}{profile}"
        )
    port = args.port or (journal.port if journal else None)
    if gcode is None:
        raise RefusedError(
            "give a G-code file to draw (pencilbot draw drawing.gcode --port PORT) or --resume JOB"
        )
    if port is None:
        raise RefusedError("give the plotter's port with --port (e.g. /dev/ttyUSB0, COM3 or sim://)")
    if svg:  # drawn directly: exported for the profile (its layer, this run's values) into the user folder
        gcode = _export_svg(args, Path(gcode))
    if journal is None and args.start_line is None and not args.restart:
        _refuse_a_stopped_job(Path(gcode))
    options = journal.options if journal else {}
    timeout, send_and_wait, on_error = connection_options(args, options)
    progress = "json" if args.json_lines else "quiet" if args.quiet else "bar"
    announce = None
    if args.verbose and not args.quiet:

        def announce(banner, job):
            # (port and baud as they stand when the job starts: a port by then)
            print("\n".join(banner_lines(port, baud, banner, job)), file=sys.stderr, flush=True)  # type: ignore[arg-type]

    sim.register()  # --port sim://… reaches the virtual plotter
    profile = args.profile if journal else profile_for(gcode, args.profile, default_profile())
    _check_file_kind(Path(gcode), profile or (journal.profile if journal else None))
    plotter = load_profile(profile or journal.profile)  # type: ignore[union-attr]  # no profile: a journal's
    check_run_options(args, Path(gcode), plotter, from_svg=svg)
    port = resolve_port(port, quiet=args.quiet)  # a plotter's name: config.toml's [ports], an EBB's nickname
    if port == "auto":
        port = auto_port(args.quiet, plotter)
    baud = args.baud or options.get("baud") or plotter.firmware.baud
    with ExitStack() as stack:
        keys = operator = None
        if sys.stdin.isatty() and not args.json_lines:
            from pencilbot.driver.keys import KeyReader, TerminalOperator

            keys = KeyReader()
            stack.callback(keys.close)
            operator = TerminalOperator(keys)
        for copy in range(1, args.copies + 1):
            if copy > 1:
                between_copies(copy - 1, args.copies, args.copy_delay, args.quiet, operator)
            result = draw(
                gcode,
                port,
                profile=profile,
                baud=baud,
                unlock=args.unlock,
                check=args.check,
                send_and_wait=send_and_wait,
                on_error=on_error,
                start_line=args.start_line,
                resume=args.resume,
                progress=progress,
                timeout=timeout,
                operator=operator,
                keys=keys,
                announce=announce,
                overrides=run_overrides(args) or None,
                allow_system=args.allow_system_commands,
            )
    if not args.quiet and not args.json_lines:
        rejected = f"; rejected lines: {result.rejected}" if result.rejected else ""
        print(f"drew {result.lines_sent} lines in {result.seconds:.1f} s{rejected}")
    return 1 if result.rejected else 0


def _export_svg(args: argparse.Namespace, svg: Path) -> Path:
    """The job of an SVG drawn directly, written for the profile with this run's values."""
    from pencilbot.commands.export import file_suffixes
    from pencilbot.machine.profile_edit import profile_with

    plotter = load_profile(args.profile or default_profile())
    target = svg_job_path(svg, args.layer, file_suffixes(plotter)[0])
    if args.start_line is None and not args.restart:
        _refuse_a_stopped_job(target)  # before it is written again: its resume needs it as it was
    said = export_svg_job(svg, target, profile_with(plotter, run_overrides(args)), args)
    if not args.quiet:
        print(f"exported {said}", file=sys.stderr, flush=True)
    return target


def connection_options(args: argparse.Namespace, options: dict) -> tuple[float, bool, str]:
    """Timeout, send-and-wait and on-error for this run: a resume runs as the job did (its
    journal's ``options``), unless an option is given again, which wins either way."""
    return (
        args.timeout or options.get("timeout", DEFAULT_TIMEOUT),
        args.send_and_wait or options.get("send_and_wait", False),
        args.on_error or options.get("on_error", "stop"),
    )


def _suffix_for(profile: str | None) -> str:
    """The file a profile's plotter draws: .hpgl for an HP-GL plotter, else .gcode."""
    from pencilbot.machine.profile import load_profile

    try:
        return ".hpgl" if profile and load_profile(profile).firmware.program_language == "hpgl" else ".gcode"
    except PencilbotError:
        return ".gcode"


def _check_file_kind(path: Path, profile: str | None) -> None:
    """An HP-GL file needs an HP-GL plotter's profile, G-code a G-code plotter's (the suffix says which)."""
    from pencilbot.export.hpgl import HPGL_SUFFIXES
    from pencilbot.machine.profile import list_profiles, load_profile

    if profile is None:
        return
    try:
        hpgl_profile = load_profile(profile).firmware.program_language == "hpgl"
    except PencilbotError:
        return  # the driver says what is wrong with it
    hpgl_file = path.suffix.lower() in HPGL_SUFFIXES
    if hpgl_file and not hpgl_profile:
        names = [n for n in list_profiles() if load_profile(n).firmware.program_language == "hpgl"]
        raise RefusedError(
            f"{path} is HP-GL and profile {profile} is not an HP-GL plotter's; give its profile: "
            f"--profile {' or '.join(names) or 'NAME'}"
        )
    if hpgl_profile and not hpgl_file:
        raise RefusedError(
            f"profile {profile} is an HP-GL plotter's and {path} is not HP-GL ({', '.join(HPGL_SUFFIXES)}); "
            f"export the drawing for it: pencilbot export DRAWING.svg -o {path.with_suffix('.hpgl').name} "
            f"--profile {profile}"
        )


def auto_port(quiet: bool = False, profile=None) -> str:
    """The port of the one plotter of ``profile``'s kind that answers (``--port auto``); says which on stderr."""
    from pencilbot.driver.ports import find_plotters, list_ports, wrong_kind

    found = find_plotters()
    if profile is not None:
        found, others = wrong_kind(found, profile)
        if others and not found:
            raise PlotError(others)
    if len(found) == 1:
        if not quiet:
            print(f"using {found[0].device}: {found[0].summary()}", file=sys.stderr, flush=True)
        return found[0].device
    if not found:
        listed = ", ".join(p.device for p in list_ports()) or "none"
        raise PlotError(
            f"--port auto: no plotter answered on the serial ports (listed: {listed}); "
            "check it is on and connected, or give --port (pencilbot ports PORT probes one)"
        )
    raise PlotError(
        "--port auto: several plotters answered ("
        + "; ".join(f"{f.device}: {f.summary()}" for f in found)
        + "); choose one with --port"
    )


def banner_lines(port: str, baud: int, banner: str, job) -> list[str]:
    """What ``draw -v`` says before it streams: the port, the profile, what the board said it
    is, the job's size and its estimated plot time."""
    from pencilbot.planning.stats import duration_text

    board = banner.removeprefix("banner '").removesuffix("'")  # a reset's reply: "banner 'Grbl 1.1h'"
    if not hasattr(job, "seconds_after"):  # an HP-GL program: (profile, instructions)
        profile, count = job
        return [
            f"port {port} at {baud} bit/s",
            f"profile {profile.name} ({profile.source}): {profile.description}",
            f"board: {board}",
            f"job: {count} HP-GL instructions",
        ]
    profile = job.profile
    header = estimated_seconds(job.source) if Path(job.source).is_file() else None
    seconds, how = (
        (header, "the file's estimate")
        if header is not None
        else (job.seconds_after(len(job) - 1), "distance over feed, without acceleration")
    )
    return [
        f"port {port} at {baud} bit/s",
        f"profile {profile.name} ({profile.source}): {profile.description}",
        f"board: {board}",
        f"job: {job.source}, {len(job)} command lines of {job.total_lines}",
        f"estimated plot time {duration_text(seconds)} ({how})",
    ]


def _refuse_a_stopped_job(gcode: Path) -> None:
    """Drawing a file whose job stopped would redraw what is on the paper: say how to resume."""
    path = journal_path(gcode)
    if not path.is_file():
        return
    try:
        journal = load_journal(path)
    except PlotError as err:
        # A journal that cannot be read may still be a stopped job's: drawing from line 1 would
        # draw over what is on the paper, so that takes --restart too.
        if "--restart" in str(err):
            raise
        raise RefusedError(f"{err}; or draw {gcode} again from line 1 with --restart") from None
    if journal.status in ("stopped", "running"):  # "running": the sender itself was killed
        how = journal.resume or f"pencilbot draw --resume {path} --port {journal.port}"
        why = f" ({journal.message})" if journal.message else ""
        if journal.status == "running":
            state = (
                f"is being drawn now (on {journal.port}), or its sender was killed at line "
                f"{journal.next_line}; if no pencilbot is drawing it"
            )
        else:
            state = f"stopped at line {journal.next_line}{why}; drawing it again would draw over what is on the paper."
        raise RefusedError(f"the job of {gcode} {state} Resume it with: {how} — or start over with --restart")
