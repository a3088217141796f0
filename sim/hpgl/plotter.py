"""The virtual HP-GL plotter: the 7475A board (:mod:`sim.hpgl.board`) behind wires, on the wall
clock or the poll clock."""

from __future__ import annotations

import math

from sim.hpgl.board import HpglBoard
from sim.wires import WiredBoard


class HpglPlotter(WiredBoard):
    """A virtual HP-GL plotter with its wires, driven like GRBL's :class:`sim.gcode.plotter.VirtualPlotter`
    (the ``sim://`` port and the pty server take either; writing, reading, the picture and the
    clock are the same, its board is both ``firmware`` and ``machine``).

    Parameters
    ----------
    profile : Profile
        An HP-GL plotter's profile (bed = hard-clip limits, buffer, speeds, pen delays).
    baud : int
        Emulated bit/s, 0 for unlimited.
    realtime : float
        0: instant; ``r > 0``: r times faster than real time.
    faults : sim.faults.Faults, optional
    xonxoff : bool
        Send XOFF / XON as the buffer fills and empties.
    tick : float
        > 0: the poll clock, ``tick`` plotter seconds per ``ESC.B`` answered (instead of either).
    """

    def __init__(
        self,
        profile,
        *,
        baud: int = 0,
        realtime: float = 0.0,
        faults=None,
        xonxoff: bool = False,
        tick: float = 0.0,
    ):
        self.profile = profile
        self.board = HpglBoard(profile, faults=faults, xonxoff=xonxoff)
        self.firmware = self.machine = self.board
        self.operator = "none"
        self.realtime = realtime
        self.tick = tick
        self._polls = 0
        self._connect(baud)

    def _run(self, elapsed: float) -> None:
        """The poll clock or the wall clock; a dropped link loses what was on its way."""
        if self.tick:
            polls, self._polls = self.board.polls - self._polls, self.board.polls
            self.board.poll(polls * self.tick)
            if self.board.link_dropped:  # a pulled cable does not stop the plotter: it draws what it holds
                self.board.poll(math.inf)
        else:
            self.board.poll(math.inf if not self.realtime else elapsed * self.realtime)
        if self.board.link_dropped:  # what was on its way in the cable is gone with it
            self._to_host.buf.clear()
            self.board.out.clear()
