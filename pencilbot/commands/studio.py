"""``pencilbot studio``: a local web page to make a drawing and watch it plot."""

from __future__ import annotations

import argparse
from pathlib import Path

from pencilbot.commands.options import MAX_REALTIME, Deprecated, add_profile_option, add_verbosity, number
from pencilbot.errors import PencilbotError, no_such_file


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "studio",
        help="a local web page: tune a drawing, plot it, watch it",
        description=(
            "Serve a page on this machine (the browser opens it) to make a drawing from a photo with "
            "live previews and figures, download its SVG, G-code and sketch, and plot it on a plotter "
            "or the virtual one while watching what it has drawn. Needs the studio extra: "
            "pip install 'pencilbot[studio]'."
        ),
    )
    parser.add_argument("photo", nargs="?", metavar="PHOTO", help="a photo to start with")
    # `--port` is the plotter in draw, pen, walk and home; here the page only lists one more
    # choice, so the option has its own name (the old spelling works for a release, with a note).
    parser.add_argument(
        "--offer-port",
        metavar="PORT",
        help="a plotter port the page offers besides those found (and sim://); you choose the plotter on the page",
    )
    parser.add_argument("--port", dest="offer_port", action=Deprecated, new="--offer-port")
    add_profile_option(parser)
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1, this machine only; another needs the printed token)",
    )
    parser.add_argument(
        "--listen-port",
        type=number("--listen-port", low=0, high=65535, whole=True),
        default=8765,
        metavar="N",
        help="TCP port of the page (default 8765; 0: any free one)",
    )
    parser.add_argument("--no-browser", action="store_true", help="do not open the page in a browser")
    parser.add_argument(
        "--realtime",
        type=number("--realtime", low=0, above=True, high=MAX_REALTIME),
        default=1.0,
        metavar="R",
        help="the virtual plotter moves R times faster than real time (default %(default)g: as fast "
        "as the real machine), as --realtime in simulate and sim-serve",
    )
    parser.add_argument(
        "--sim-speed",
        dest="realtime",
        type=number("--sim-speed", low=0, above=True, high=MAX_REALTIME),
        action=Deprecated,
        new="--realtime",
    )
    add_verbosity(parser)
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.photo is not None and not Path(args.photo).is_file():
        raise PencilbotError(no_such_file(args.photo, "a photo (PNG, JPEG, ...) or none"))
    try:
        from pencilbot.studio.server import serve
    except ImportError as err:
        raise PencilbotError(
            f"the studio needs its extra ({err.name} is missing): pip install 'pencilbot[studio]'"
        ) from None
    try:
        serve(
            Path(args.photo) if args.photo else None,
            port=args.offer_port,
            profile=args.profile,
            host=args.host,
            listen_port=args.listen_port,
            browser=not args.no_browser,
            sim_speed=args.realtime,
        )
    except KeyboardInterrupt:
        pass
    return 0
