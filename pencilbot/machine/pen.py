"""The pen model: how a plotter lifts and lowers its pen, and what that costs in time.

One model serves every side: the G-code writer and the time estimate ask it how long a lift or
a drop takes, the driver asks it whether a tracked machine state has the pen down and which
lines raise it, and the virtual plotter asks it whether what it executed put the pen on the
paper. It is built from a profile's ``[pen]`` table by
:meth:`pencilbot.machine.profile.Profile.pen_model`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pencilbot.machine.motion import Motion, move_times

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

    def change_seconds(self, motion: Motion) -> tuple[float, float]:
        """Seconds a lift and a drop take: the dwell, plus the Z travel for a Z pen.

        A Z pen's move runs from rest to rest (GRBL stops at the pen's corner only to within
        the junction speed, a few mm/s: negligible) at its own line's ``G1 F`` feed, else at the
        axis's rapid rate.
        """
        lift, drop = self.up_delay, self.down_delay
        if self.kind == "z":
            travel = abs(self.up - self.down)
            lift += float(move_times(travel, 0.0, 0.0, self._z_speed(self.up_lines, motion), motion.acceleration))
            drop += float(move_times(travel, 0.0, 0.0, self._z_speed(self.down_lines, motion), motion.acceleration))
        return lift, drop

    @staticmethod
    def _z_speed(lines: tuple[str, ...], motion: Motion) -> float:
        """mm/s of the Z move in ``lines``: a ``G1 … F`` feed, else the rapid rate."""
        for line in lines:
            code = line.split(";")[0]
            feed = _FEED_WORD.search(code)
            if _FEED_MOVE.search(code):
                return min(float(feed.group(1)) if feed else motion.draw_feed, motion.axis_rate) / 60.0
        return motion.axis_rate / 60.0
