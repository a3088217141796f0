"""``pencilbot sim-serve``: the virtual plotter on a pseudo-terminal, for any sender to open."""

from __future__ import annotations

import argparse
import signal
from pathlib import Path

from pencilbot.commands.common import PLOT_DPI, check_render
from pencilbot.commands.options import (
    MAX_BAUD,
    MAX_DPI,
    MIN_DPI,
    Deprecated,
    add_profile_option,
    add_realtime_option,
    add_verbosity,
    number,
)
from pencilbot.driver.stop_signals import STOP_SIGNALS
from pencilbot.errors import PencilbotError
from pencilbot.fileio import check_writable
from pencilbot.units import DEFAULT_PEN_WIDTH
from sim.faults import FAULT_KINDS


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "sim-serve",
        help="serve the virtual GRBL (or HP-GL) plotter on a pseudo-terminal",
        description=(
            "Start a virtual GRBL 1.1 (or grblHAL, or an HP 7475A speaking HP-GL, with such a profile) plotter on a "
            "new pseudo-terminal "
            "and print its device path; "
            "open that path with any sender (pencilbot draw --port PATH, Universal G-code Sender, "
            "a terminal). The board behaves like a real GRBL board on an Arduino: opening the port "
            "resets it, and its position restarts at 0,0,0 (--power keep and --abort keep make it "
            "forgiving). After a dropped link (the drop fault) it comes back on a new pty, whose path "
            "is printed. Runs until Ctrl-C, SIGTERM or SIGHUP, then saves what was drawn if -o is given."
        ),
    )
    add_profile_option(parser, "GRBL, grblHAL, HP-GL or EBB (axidraw-v3, ...) plotter profile")
    add_realtime_option(parser)
    _add_line_options(parser)
    _add_board_options(parser)
    parser.add_argument("-o", "--output", metavar="PLOT.png", help="on exit, save the drawing here")
    parser.add_argument(
        "--dpi",
        type=number("--dpi", low=MIN_DPI, high=MAX_DPI, unit="dots per inch"),
        default=PLOT_DPI,
        help="resolution of the saved drawing in dots per inch (default %(default)g)",
    )
    add_verbosity(parser)
    parser.set_defaults(func=run)


def _add_line_options(parser: argparse.ArgumentParser) -> None:
    """What the line to the board does: its emulated speed and the faults injected on it."""
    # `draw --baud` is the serial line's speed; here the board only emulates a slow line, so the
    # option has its own name (the old spelling works for a release, with a note).
    parser.add_argument(
        "--emulate-baud",
        type=number("--emulate-baud", low=0, high=MAX_BAUD, whole=True, unit="bit/s (0: unlimited)"),
        default=0,
        metavar="B",
        help="carry the bytes both ways no faster than a serial line of B bit/s (10 bits a byte; default "
        "%(default)s: unlimited, as a pty is)",
    )
    parser.add_argument(
        "--baud",
        dest="emulate_baud",
        type=number("--baud", low=0, high=MAX_BAUD, whole=True, unit="bit/s (0: unlimited)"),
        action=Deprecated,
        new="--emulate-baud",
    )
    parser.add_argument(
        "--faults",
        default="",
        metavar="KIND@LINE,...",
        help=f"inject faults, KIND@K (at the K-th line the board takes): KIND one of "
        f"{', '.join(FAULT_KINDS)}; error@K:N gives error N, interrupt@K:SIG a signal, and "
        "hold and interrupt also strike at a moment of the simulated clock (interrupt@1.45s)",
    )


def _add_board_options(parser: argparse.ArgumentParser) -> None:
    """How the board behaves at power-up, resets and limits, and which EBB board it plays."""
    # Defaults: a real board (sim.gcode.plotter.REAL_BOARD).
    parser.add_argument(
        "--power",
        choices=("zero", "keep"),
        default="zero",
        help="what a power-up or port-open reset does to the position (default zero)",
    )
    parser.add_argument(
        "--abort",
        choices=("lose", "keep"),
        default="lose",
        help="whether a reset in motion or a hard limit loses the position (default lose)",
    )
    parser.add_argument(
        "--limits",
        choices=("profile", "bed"),
        default="profile",
        help="profile: the profile's homing and soft limits (default); bed: soft limits "
        "at the bed's edges, trusted from power-up",
    )
    parser.add_argument(
        "--no-reset",
        action="store_true",
        help="a board without auto-reset: opening the port does not reset it",
    )
    parser.add_argument(
        "--firmware",
        metavar="VERSION",
        help="EBB profiles: the firmware the board plays (default 3.0.3; e.g. 2.8.1)",
    )
    parser.add_argument(
        "--supply",
        type=number("--supply", low=0, high=40, unit="V"),
        default=None,
        help="EBB profiles: volts at the board's power jack (default 9.1; 0: the motors have no power)",
    )


def run(args: argparse.Namespace) -> int:
    from serial import SerialException

    from sim.protocol_sim import plotter_from_options
    from sim.pty_server import PtyServer

    # Checked now, not on Ctrl-C: a session's drawing must not be lost to a typo in -o.
    if args.output and not args.output.lower().endswith(".png"):
        raise PencilbotError(f"name the output {args.output} with .png")
    if args.output and not Path(args.output).resolve().parent.is_dir():
        raise PencilbotError(f"cannot save to {args.output}: its folder does not exist; create it first")
    if args.output:
        check_writable(args.output)  # a read-only folder: now, not when the session's drawing is saved
    options = {
        "profile": args.profile,
        "realtime": str(args.realtime),
        "baud": str(args.emulate_baud),
        "faults": args.faults,
        "power": args.power,
        "abort": args.abort,
        "limits": args.limits,
    }
    options.update(
        {k: str(v) for k, v in (("firmware", args.firmware), ("supply", args.supply)) if v is not None}
    )
    try:
        plotter = plotter_from_options(options)
    except SerialException as exc:
        raise PencilbotError(f"{exc}; see pencilbot sim-serve --help") from None
    if args.output:  # checked now, not on exit: a session's drawing must not be lost to a typo
        check_render(plotter.profile.bed.width, plotter.profile.bed.height, args.dpi, DEFAULT_PEN_WIDTH)
    resets = getattr(plotter.firmware, "resets_on_open", True)  # an EBB (USB CDC) does not reset on open
    server = PtyServer(
        plotter, reset_on_open=not args.no_reset and resets, on_new_path=lambda path: print(path, flush=True)
    )
    print(server.path, flush=True)
    # Every stop signal (Ctrl-C, a kill, a closed terminal, Ctrl-\) ends the session and saves its
    # drawing, even one the process was started ignoring (a script's background job ignores
    # SIGINT): a virtual board has no plot to keep going, only its drawing to lose.
    for signum in STOP_SIGNALS:
        signal.signal(signum, lambda *_: server.stop())
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    if not args.quiet:
        print(
            f"simulated drawing time {plotter.seconds:.1f} s; "
            f"{len(plotter.firmware.accepted_lines())} lines accepted"
        )
    if args.output:
        plotter.save_png(args.output, dpi=args.dpi, pen_width=DEFAULT_PEN_WIDTH)
    return 0
