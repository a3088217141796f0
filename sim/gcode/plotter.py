"""The virtual GRBL plotter (GRBL 1.1, grblHAL): its firmware (:mod:`sim.gcode.firmware`) and machine
(:mod:`sim.gcode.machine`) behind the wires, on the instant, real-time or line clock."""

from __future__ import annotations

import dataclasses

from pencilbot.machine.profile import Profile
from sim.faults import Faults
from sim.gcode.firmware import Firmware
from sim.gcode.machine import Machine
from sim.wires import WiredBoard, check_simulated

_IDLE_QUERY = 0.2  # simulated s a status query lets pass on the line clock when no line came
_CYCLE_START = b"~"  # what the operator's button sends, as GRBL's cycle-start pin does
#: Option values a real GRBL board has: the default, so tests meet what a sender meets.
REAL_BOARD = {"power": "zero", "abort": "lose", "limits": "profile"}
DEFAULT_BOARD = dict(REAL_BOARD)


class VirtualPlotter(WiredBoard):
    """A virtual GRBL plotter: firmware, machine, clock and wires, driven by :meth:`pump`.

    Parameters
    ----------
    profile : Profile
        The machine (see :func:`simulated_profile`).
    baud : int
        Emulated bit/s, 0 for unlimited.
    realtime : float
        0 for instant motion, else the speed-up over real time.
    tick : float
        > 0: the line clock (seconds a line takes; see the ``tick`` option), instead of either.
    faults : Faults
        Failures to inject.
    power, abort, limits : str
        How real the board is: see the ``sim://`` options of the same names (module docstring).
    operator : str
        ``"auto"``: cycle start is pressed at every ``M0`` pause (see the ``operator`` option).
    """

    def __init__(
        self,
        profile: Profile,
        *,
        baud: int = 0,
        realtime: float = 0.0,
        faults: Faults | None = None,
        power: str = DEFAULT_BOARD["power"],
        abort: str = DEFAULT_BOARD["abort"],
        limits: str = DEFAULT_BOARD["limits"],
        operator: str = "none",
        tick: float = 0.0,
    ):
        check_simulated(profile)
        self.operator = operator
        self._pauses_answered = 0
        self.profile = profile
        if limits == "bed":
            profile = dataclasses.replace(
                profile, bed=dataclasses.replace(profile.bed, homing=True, soft_limits=True)
            )
        self.machine = Machine(profile, instant=realtime == 0 and tick == 0)
        self.tick = tick
        self._answered = self._queries = 0  # lines and queries the line clock has counted
        self._answered_at_query = -1  # lines answered when the last query came
        self.firmware = Firmware(
            self.machine,
            faults,
            power_zero=power == "zero",
            abort_loses=abort == "lose",
            init_lock=limits != "bed",
        )
        self.realtime = realtime
        self._connect(baud)

    def _run(self, elapsed: float) -> None:
        """The line clock or the wall clock; cycle start pressed at a pause for ``operator=auto``."""
        if self.tick:
            self._line_clock()
        else:
            self.firmware.poll(elapsed * self.realtime)
        if self.operator == "auto" and self.machine.pauses > self._pauses_answered:
            self._pauses_answered = self.machine.pauses
            self.firmware.receive(_CYCLE_START)

    def _line_clock(self) -> None:
        """Let the simulated time of the lines and idle queries received pass (``tick``)."""
        fw = self.firmware
        for _ in range(1_000_000):
            lines, queries = len(fw.log) - self._answered, fw.queries - self._queries
            self._answered, self._queries = len(fw.log), fw.queries
            # A query is idle when no line came since the one before it: the sender has none
            # to send (a streaming sender always has, whatever its speed).
            idle = queries and len(fw.log) == self._answered_at_query
            if queries:
                self._answered_at_query = len(fw.log)
            seconds = lines * self.tick + (_IDLE_QUERY if idle else 0.0)
            if (not seconds and not fw.waiting_on_motion) or fw.signal_due is not None:
                return  # (a timed interrupt: the sender reacts before the clock runs on)
            fw.poll(seconds or self.tick)

    @property
    def seconds(self) -> float:
        """Simulated seconds of motion and dwell so far."""
        return self.machine.clock
