"""``pencilbot draw INPUT --port PORT``: stream G-code to a plotter (or resume a stopped job)."""

from __future__ import annotations

import argparse
import sys
from contextlib import ExitStack
from pathlib import Path

import sim

from pencilbot.commands.common import IMAGE_SUFFIXES, MAX_BAUD, add_profile_listing, add_verbosity, number
from pencilbot.driver import draw
from pencilbot.driver.header import estimated_seconds, profile_for
from pencilbot.driver.journal import journal_path, load_journal
from pencilbot.errors import PlotError
from pencilbot.driver.stream import DEFAULT_TIMEOUT
from pencilbot.machine.profile import default_profile, load_profile


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "draw",
        help="stream G-code to a pen plotter over serial",
        description="Stream a G-code file to a GRBL, grblHAL or Marlin plotter. If the job stops (error, alarm, "
        "reset, lost port, Ctrl-C, SIGTERM, SIGHUP) the message gives the exact command to resume it. In a "
        "terminal: p or space pauses and resumes (feed hold, cycle start), s stops safely; M0 pauses (a pen "
        "change) wait for Enter.",
    )
    p.add_argument("input", nargs="?", help="G-code file (from pencilbot export); omit with --resume")
    p.add_argument("--port", help="serial device or URL: /dev/ttyUSB0, COM3, socket://host:23, sim://…")
    p.add_argument("--profile", metavar="NAME|FILE.toml",
                   help="plotter profile: a name (see --list-profiles) or a .toml file (default: the resumed job's, "
                   f"else the one the file's header names, else {default_profile()}); must be the header's if it names one")
    add_profile_listing(p)
    p.add_argument("--baud", type=number("--baud", low=1, high=MAX_BAUD, whole=True, unit="bit/s"),
                   help="serial speed in bit/s (default: the resumed job's, else the firmware's: 115200 for GRBL)")
    p.add_argument("--unlock", action="store_true", help="send $X if the plotter starts in alarm lock")
    p.add_argument("--check", action="store_true", help="run the file through the board's check mode ($C) first")
    p.add_argument("--send-and-wait", action="store_true", help="one line at a time instead of character counting")
    p.add_argument("--on-error", choices=("stop", "continue"),
                   help="on error:N stop (feed hold, pen up) or log it and continue (default: the resumed job's, else stop)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--resume", metavar="JOB", help="job journal (or G-code file) of a stopped job to continue")
    where.add_argument("--start-line", type=number("--start-line", low=1, high=2**31 - 1, whole=True), metavar="N",
                       help="start at file line N, restoring the state before it")
    p.add_argument("--timeout", type=number("--timeout", low=0, above=True, high=MAX_TIMEOUT, unit="s"),
                   help=f"seconds of silence before giving up (default: the resumed job's, else {DEFAULT_TIMEOUT:g})")
    p.add_argument("--restart", action="store_true",
                   help="draw a file whose job stopped from line 1 again (its journal is replaced)")
    p.add_argument("--json-lines", action="store_true", help="progress as JSON lines on stdout, for scripts")
    add_verbosity(p)
    p.set_defaults(func=run)


#: Seconds of silence anyone would wait for a board (a day); more is a typo, and none never works.
MAX_TIMEOUT = 86_400.0

#: Inputs that are pictures or plans, not G-code: `pencilbot export` turns them into G-code.
NOT_GCODE = {*IMAGE_SUFFIXES, ".gif", ".svg"}


def run(args: argparse.Namespace) -> int:
    journal = load_journal(args.resume) if args.resume else None
    gcode = journal.gcode if journal else args.input
    if gcode is not None and Path(gcode).suffix.lower() in NOT_GCODE:
        out = Path(gcode).with_suffix(".gcode")
        profile = f" --profile {args.profile}" if args.profile else ""
        raise PlotError(
            f"{gcode} is a picture, not G-code; make the G-code first (and look at it with "
            f"pencilbot simulate), then draw it: pencilbot export {gcode} -o {out}{profile} && "
            f"pencilbot draw {out} --port {args.port or 'PORT'}{profile}"
        )
    port = args.port or (journal.port if journal else None)
    if gcode is None:
        raise PlotError("give a G-code file to draw (pencilbot draw drawing.gcode --port PORT) or --resume JOB")
    if port is None:
        raise PlotError("give the plotter's port with --port (e.g. /dev/ttyUSB0, COM3 or sim://)")
    if journal is None and args.start_line is None and not args.restart:
        _refuse_a_stopped_job(Path(gcode))
    options = journal.options if journal else {}
    timeout, send_and_wait, on_error = connection_options(args, options)
    progress = "json" if args.json_lines else "quiet" if args.quiet else "bar"
    announce = None
    if args.verbose and not args.quiet:
        def announce(banner, job):
            print("\n".join(banner_lines(port, baud, banner, job)), file=sys.stderr, flush=True)

    sim.register()  # --port sim://… reaches the virtual plotter
    profile = args.profile if journal else profile_for(gcode, args.profile, default_profile())
    baud = args.baud or options.get("baud") or load_profile(profile or journal.profile).firmware.baud
    from sim.protocol_sim import for_profile

    port = for_profile(port, profile or journal.profile)
    with ExitStack() as stack:
        keys = operator = None
        if sys.stdin.isatty() and not args.json_lines:
            from pencilbot.driver.keys import KeyReader, TerminalOperator

            keys = KeyReader()
            stack.callback(keys.close)
            operator = TerminalOperator(keys)
        result = draw(
            gcode, port, profile=profile, baud=baud,
            unlock=args.unlock, check=args.check, send_and_wait=send_and_wait, on_error=on_error,
            start_line=args.start_line, resume=args.resume, progress=progress, timeout=timeout,
            operator=operator, keys=keys, announce=announce,
        )
    if not args.quiet and not args.json_lines:
        rejected = f"; rejected lines: {result.rejected}" if result.rejected else ""
        print(f"drew {result.lines_sent} lines in {result.seconds:.1f} s{rejected}")
    return 1 if result.rejected else 0


def connection_options(args: argparse.Namespace, options: dict) -> tuple[float, bool, str]:
    """Timeout, send-and-wait and on-error for this run: a resume runs as the job did (its
    journal's ``options``), unless an option is given again, which wins either way."""
    return (
        args.timeout or options.get("timeout", DEFAULT_TIMEOUT),
        args.send_and_wait or options.get("send_and_wait", False),
        args.on_error or options.get("on_error", "stop"),
    )


def banner_lines(port: str, baud: int, banner: str, job) -> list[str]:
    """What ``draw -v`` says before it streams: the port, the profile, what the board said it
    is, the job's size and its estimated plot time."""
    from pencilbot.planning.stats import duration_text

    profile = job.profile
    board = banner.removeprefix("banner '").removesuffix("'")  # a reset's reply: "banner 'Grbl 1.1h'"
    header = estimated_seconds(job.source) if Path(job.source).is_file() else None
    seconds, how = (header, "the file's estimate") if header is not None else (
        job.seconds_after(len(job) - 1), "distance over feed, without acceleration")
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
    except PlotError:
        return  # an unreadable journal is replaced
    if journal.status in ("stopped", "running"):  # "running": the sender itself was killed
        how = journal.resume or f"pencilbot draw --resume {path} --port {journal.port}"
        why = f" ({journal.message})" if journal.message else ""
        if journal.status == "running":
            state = (f"is being drawn now (on {journal.port}), or its sender was killed at line "
                     f"{journal.next_line}; if no pencilbot is drawing it")
        else:
            state = f"stopped at line {journal.next_line}{why}; drawing it again would draw over what is on the paper."
        raise PlotError(f"the job of {gcode} {state} Resume it with: {how} — or start over with --restart")
