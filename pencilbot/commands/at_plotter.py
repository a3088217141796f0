"""What the commands a person types at the plotter share (``pen``, ``align``, ``walk``, ``home``;
``draw``'s ``--port NAME``): the port options, plotters by name, opening the plotter."""

from __future__ import annotations

import argparse
import re
import sys

from pencilbot.commands.options import MAX_BAUD, add_profile_option, add_verbosity, number
from pencilbot.configs_io import user_folder, user_ports
from pencilbot.errors import PlotError

#: Seconds of silence from a board before a command gives up, at most (a minute).
MAX_CONTROL_TIMEOUT = 60.0
_DEVICE = re.compile(r"^(?:COM\d+|auto)$", re.IGNORECASE)


def add_plotter_options(parser: argparse.ArgumentParser) -> None:
    """``--port`` (a device, URL or plotter name), ``--profile``, ``--baud``, ``--timeout``, ``-q``/``-v``."""
    parser.add_argument(
        "--port",
        required=True,
        help="serial device or URL (/dev/ttyUSB0, COM3, sim://…), or a "
        "plotter's name: an EBB's nickname, or a name under [ports] in config.toml",
    )
    add_profile_option(parser)
    parser.add_argument(
        "--baud",
        type=number("--baud", low=1, high=MAX_BAUD, whole=True, unit="bit/s"),
        help="serial speed in bit/s (default: the firmware's)",
    )
    parser.add_argument(
        "--timeout",
        type=number("--timeout", low=0, above=True, high=MAX_CONTROL_TIMEOUT, unit="s"),
        default=5.0,
        help="seconds of silence from the plotter before giving up (default %(default)g)",
    )
    add_verbosity(parser)


def is_port(text: str) -> bool:
    """Whether ``text`` is a device or URL (else it is a plotter's name)."""
    return "://" in text or "/" in text or "\\" in text or bool(_DEVICE.match(text))


def resolve_port(text: str, *, quiet: bool = False, devices: list[str] | None = None) -> str:
    """The port of ``text``: itself when it is a device or URL; else the port config.toml's
    ``[ports]`` gives the name, else the EBB board (among ``devices``, default all) whose
    nickname it is.

    Raises
    ------
    PlotError
        No plotter goes by that name (one line: where it was looked for, how to name one).
    """
    if is_port(text):
        return text
    named = user_ports()
    if text in named:
        return named[text]
    from pencilbot.driver.ebb.names import find_named

    found = find_named(text, devices)
    if found is None:
        config = user_folder() / "config.toml"
        raise PlotError(
            f"no plotter named {text!r}: config.toml names {', '.join(sorted(named)) or 'none'} under "
            f"[ports], and no EBB board answered with that nickname; give a port (/dev/ttyUSB0, COM3) "
            f'or name one: {text} = "PORT" under [ports] in {config}'
        )
    if not quiet:
        print(f"{text} is the EBB board on {found}", file=sys.stderr, flush=True)
    return found


def open_plotter(args: argparse.Namespace):
    """The :class:`~pencilbot.driver.control.Control` of ``args.port`` for ``args.profile``."""
    import sim
    from pencilbot.driver.control import open_control

    sim.register()  # sim://… reaches the virtual plotter
    return open_control(
        resolve_port(args.port, quiet=args.quiet), args.profile, baud=args.baud, timeout=args.timeout
    )


def carriage_words(where) -> str:
    """Where the plotter says its carriage is, to 0.01 mm (an HP-GL unit is 0.02488 mm)."""
    return f"the carriage is at X{round(where[0], 2):g} Y{round(where[1], 2):g}"


def pen_words(down: bool | None) -> str:
    """How the plotter's report of its pen reads."""
    if down is None:
        return "(this firmware does not report its pen)"
    return f"the plotter reports the pen {'down' if down else 'up'}"
