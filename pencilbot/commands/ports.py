"""``pencilbot ports [PORT...]``: the serial ports there are and which plotter answers on each."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pencilbot.commands.options import add_verbosity
from pencilbot.errors import PencilbotError


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "ports",
        help="list serial ports and which plotter answers on each",
        description=(
            "List the serial ports the system knows and probe each, and any PORT given (a pseudo-terminal "
            "from pencilbot sim-serve, socket://…, sim://…), without moving anything: a start-up banner, "
            "GRBL's $I, Marlin's M115, the EiBotBoard's V (AxiDraw, NextDraw, iDraw) and, at 9600 bit/s, "
            "HP-GL's OI;. Prints what answered on each. `pencilbot draw --port auto` uses the one plotter found."
        ),
    )
    parser.add_argument("ports", nargs="*", metavar="PORT", help="ports to probe besides the listed ones")
    parser.add_argument("--no-probe", action="store_true", help="only list the ports; send nothing")
    parser.add_argument("--json", action="store_true", help="print JSON")
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import sim
    from pencilbot.driver.ports import PortInfo, list_ports, probe_all

    sim.register()  # sim://… can be probed too
    listed = list_ports()
    known = {p.device for p in listed}
    infos = listed + [PortInfo(device) for device in args.ports if device not in known]
    if not args.no_probe:
        infos = probe_all(infos)
    if args.json:
        print(json.dumps([p.__dict__ for p in infos], indent=1))
    elif not args.quiet:
        if not infos:
            print("no serial ports found; name a port to probe it (pencilbot ports /dev/pts/3)")
        for p in infos:
            what = "not probed" if args.no_probe else p.summary()
            print(f"{p.device}\t{p.description or '-'}\t{what}")
    _refuse_missing(args.ports, infos, probed=not args.no_probe)
    return 0


def _refuse_missing(named: list[str], infos: list, *, probed: bool) -> None:
    """A port named on the command line that cannot be opened (or, unprobed, a device path that
    does not exist) is a usage mistake: exit 2 after the listing, naming it."""
    if probed:
        bad = [
            f"{p.device} ({p.error.removeprefix('cannot open: ')})"
            for p in infos
            if p.device in named and p.error.startswith("cannot open")
        ]
    else:
        bad = [
            f"{name} (no such device)" for name in named if name.startswith("/") and not Path(name).exists()
        ]
    if bad:
        raise PencilbotError(
            f"cannot open the port{'s' if len(bad) > 1 else ''} named: {'; '.join(bad)}; "
            "pencilbot ports without a PORT lists the ports there are"
        )
