"""``pencilbot draw INPUT --port PORT``: stream G-code to a plotter (or resume a stopped job)."""

from __future__ import annotations

import argparse
import sys
from contextlib import ExitStack
from pathlib import Path

import sim

from pencilbot.commands.common import IMAGE_SUFFIXES, add_verbosity
from pencilbot.driver import draw
from pencilbot.driver.journal import journal_path, load_journal
from pencilbot.errors import PlotError
from pencilbot.machine.profile import default_profile


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
    p.add_argument("--profile", help=f"plotter profile name or TOML file (default: the resumed job's, else {default_profile()})")
    p.add_argument("--baud", type=int, help="serial speed in bit/s (default: the resumed job's, else 115200)")
    p.add_argument("--unlock", action="store_true", help="send $X if the plotter starts in alarm lock")
    p.add_argument("--check", action="store_true", help="run the file through the board's check mode ($C) first")
    p.add_argument("--send-and-wait", action="store_true", help="one line at a time instead of character counting")
    p.add_argument("--on-error", choices=("stop", "continue"), default="stop",
                   help="on error:N stop (feed hold, pen up; default) or log it and continue")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--resume", metavar="JOB", help="job journal (or G-code file) of a stopped job to continue")
    where.add_argument("--start-line", type=int, metavar="N", help="start at file line N, restoring the state before it")
    p.add_argument("--timeout", type=float,
                   help="seconds of silence before giving up (default: the resumed job's, else 10)")
    p.add_argument("--restart", action="store_true",
                   help="draw a file whose job stopped from line 1 again (its journal is replaced)")
    p.add_argument("--json-lines", action="store_true", help="progress as JSON lines on stdout, for scripts")
    add_verbosity(p)
    p.set_defaults(func=run)


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
    # A resume runs as the job did: its connection options, unless given again.
    options = journal.options if journal else {}
    baud = args.baud or options.get("baud", 115200)
    timeout = args.timeout or options.get("timeout", 10.0)
    send_and_wait = args.send_and_wait or options.get("send_and_wait", False)
    on_error = args.on_error if args.on_error != "stop" else options.get("on_error", "stop")
    progress = "json" if args.json_lines else "quiet" if args.quiet else "bar"
    sim.register()  # --port sim://… reaches the virtual plotter
    with ExitStack() as stack:
        keys = operator = None
        if sys.stdin.isatty() and not args.json_lines:
            from pencilbot.driver.keys import KeyReader, TerminalOperator

            keys = KeyReader()
            stack.callback(keys.close)
            operator = TerminalOperator(keys)
        result = draw(
            gcode, port, profile=args.profile or (None if journal else default_profile()), baud=baud,
            unlock=args.unlock, check=args.check, send_and_wait=send_and_wait, on_error=on_error,
            start_line=args.start_line, resume=args.resume, progress=progress, timeout=timeout,
            operator=operator, keys=keys,
        )
    if not args.quiet and not args.json_lines:
        rejected = f"; rejected lines: {result.rejected}" if result.rejected else ""
        print(f"drew {result.lines_sent} lines in {result.seconds:.1f} s{rejected}")
    return 1 if result.rejected else 0


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
        raise PlotError(
            f"the job of {gcode} stopped at line {journal.next_line}{why}; drawing it again would draw "
            f"over what is on the paper. Resume it with: {how} — or start over with --restart"
        )
