"""The pen model: how a plotter lifts and lowers its pen, and what that costs in time.

One model serves every side: the G-code writer takes its commands and dwells, the time estimate
asks whether lifting is a move of the axes (a Z pen) or a pause (a servo), and how fast, the
driver asks whether a tracked machine state has the pen down and which lines raise it, and the
virtual plotter asks whether what it executed put the pen on the paper. It is built from a profile's ``[pen]`` table by
:meth:`pencilbot.machine.profile.Profile.pen_model`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pencilbot.machine.motion import Motion

#: How the pen moves: ``spindle`` (a servo on the spindle PWM: ``M3 S…`` down/up, ``M5`` up),
#: ``z`` (the Z axis), ``servo`` (``M280 … S<angle>``).
PEN_KINDS = ("spindle", "z", "servo")
_FEED_WORD = re.compile(r"F\s*([-+]?(?:\d+\.?\d*|\.\d+))", re.IGNORECASE)
_FEED_MOVE = re.compile(r"G0*1(?![0-9.])", re.IGNORECASE)


@dataclass(frozen=True)
class PenModel:
    """How a plotter raises and lowers its pen.

    Parameters
    ----------
    kind : {"spindle", "z", "servo"}
        What moves the pen (see :data:`PEN_KINDS`).
    up, down : float
        The S value, Z height (mm) or servo angle (degrees) for pen up and pen down.
    up_lines, down_lines : tuple of str
        The G-code lines that raise / lower the pen on this plotter.
    up_delay, down_delay : float
        Seconds to wait after the pen command (a dwell), s.
    """

    kind: str = "spindle"
    up: float = 30.0
    down: float = 90.0
    up_lines: tuple[str, ...] = ()
    down_lines: tuple[str, ...] = ()
    up_delay: float = 0.0
    down_delay: float = 0.0

    def is_down(self, value: float) -> bool:
        """Whether an S value, Z height (mm) or servo angle puts the pen on the paper (it is
        closer to ``down`` than to ``up``)."""
        return abs(value - self.down) < abs(value - self.up)

    @property
    def moves_with_the_axes(self) -> bool:
        """Whether lifting and lowering are planner moves (a Z pen): they join the drawing's
        motion at corners instead of stopping it, as a spindle or servo change does."""
        return self.kind == "z"

    def z_speed(self, motion: Motion, *, lifting: bool) -> float:
        """mm/s of a Z pen's lift (or drop): its line's ``G1 … F`` feed, else the axis's rapid rate."""
        for line in self.up_lines if lifting else self.down_lines:
            code = line.split(";")[0]
            if _FEED_MOVE.search(code):
                feed = _FEED_WORD.search(code)
                return min(float(feed.group(1)) if feed else motion.draw_feed, motion.axis_rate) / 60.0
        return motion.axis_rate / 60.0
