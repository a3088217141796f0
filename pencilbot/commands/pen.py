"""``pencilbot pen up|down|toggle|cycle|trial --port PORT``: the pen, by hand, read back from the
plotter; ``trial`` tries pen heights and keeps the ones the person accepts in their profile."""

from __future__ import annotations

import argparse

from pencilbot.api import save_to_user_profile
from pencilbot.commands.at_plotter import add_plotter_options, open_plotter, pen_words
from pencilbot.commands.options import number
from pencilbot.driver.control import PEN_ACTIONS
from pencilbot.errors import PlotError, ProfileError
from pencilbot.machine.profile_edit import pen_unit as unit_of
from pencilbot.machine.profile_edit import profile_with


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "pen",
        help="raise, lower, toggle or cycle the pen; try pen heights",
        description="Move the plotter's pen and read back where the plotter says it is: up, down, toggle (the "
        "other of the two), cycle (down, then up). 'trial' lowers and raises the pen to heights you choose "
        "and keeps the ones you accept in your copy of the profile (in your user folder).",
    )
    p.add_argument("action", choices=(*PEN_ACTIONS, "trial"), help="what the pen does")
    p.add_argument(
        "--step",
        type=number("--step", low=0, above=True, high=1e4),
        help="trial: how far + and - move the height, in the profile's unit (default 5; a Z pen 0.5 mm)",
    )
    add_plotter_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    with open_plotter(args) as plotter:
        if args.action == "trial":
            return _trial(plotter, args)
        down = plotter.pen(args.action)
    if not args.quiet:
        print(f"pen {args.action}: {pen_words(down)}")
    return 0


def _trial(plotter, args: argparse.Namespace) -> int:
    """Each of pen down and pen up at a height the person accepts; both kept in their profile."""
    profile = plotter.profile
    if not plotter.pen_heights:
        plotter.try_height("down", profile.pen.down)  # says why not
    chosen = {}
    step = args.step or (0.5 if profile.pen.kind == "z" else 5.0)
    print(
        f"pen heights of {profile.name} in {unit_of(profile)}: Enter keeps a height, a number tries it, "
        f"+ or - moves it by {step:g}, q stops without saving"
    )
    for which in ("down", "up"):
        value = float(getattr(profile.pen, which))
        while True:
            down = plotter.try_height(which, value)
            answer = _ask(f"pen {which} at {value:g} ({pen_words(down)}): ")
            if answer == "":
                chosen[which] = value
                break
            if answer.lower() == "q":
                plotter.pen("up")
                print("stopped: nothing saved")
                return 0
            try:
                value = value + step if answer == "+" else value - step if answer == "-" else float(answer)
                profile_with(plotter.profile, {"pen": {which: value}}, where=f"pen {which} height")
            except (ValueError, ProfileError) as exc:
                value = float(getattr(plotter.profile.pen, which))
                print(f"{answer!r}: {exc if isinstance(exc, ProfileError) else 'give a number, +, - or q'}")
    plotter.pen("up")
    path = save_to_user_profile(profile, {"pen": chosen})
    print(f"saved pen down {chosen['down']:g}, pen up {chosen['up']:g} to {path}")
    return 0


def _ask(prompt: str) -> str:
    try:
        return input(prompt).strip()
    except EOFError:
        raise PlotError("the pen trial needs answers: run it in a terminal (nothing saved)") from None
