"""Machines for simulator tests: a plotter description built from a few keywords.

``description(width=100, pen=PenModel("z", up=4, down=0), max_rate=6000, ...)`` is the shipped
default profile with those parts replaced, so a test names only what it is about.
"""

import dataclasses

from pencilbot.machine.bed import Bed
from pencilbot.machine.motion import Motion
from pencilbot.machine.pen import PenModel
from pencilbot.machine.profile import DEFAULT_PROFILE, PenLift, load_profile

_COMMANDS = {"spindle": "M3 S{}", "z": "G0 Z{}", "servo": "M280 P0 S{}"}


def description(
    *,
    width=220.0,
    height=310.0,
    origin="bottom-left",
    invert_x=False,
    invert_y=False,
    pen=PenModel(),
    max_rate=6000.0,
    acceleration=800.0,
    junction_deviation=0.01,
    homing=False,
    soft_limits=False,
):
    """A plotter profile with this bed (and switches), pen and motion (the axes' top rate is
    ``max_rate``)."""
    base = load_profile(DEFAULT_PROFILE)
    return dataclasses.replace(
        base,
        bed=Bed(width, height, origin, invert_x, invert_y, homing, soft_limits),
        pen=PenLift(
            pen.kind,
            pen.up,
            pen.down,
            _COMMANDS[pen.kind].format("{up}"),
            _COMMANDS[pen.kind].format("{down}"),
        ),
        motion=Motion(
            draw_feed=min(3000.0, max_rate),
            travel_feed=max_rate,
            acceleration=acceleration,
            junction_deviation=junction_deviation,
        ),
    )
