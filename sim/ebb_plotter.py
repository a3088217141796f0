"""The virtual EBB plotter: an :class:`~sim.ebb_board.EbbBoard` behind wires, with a drawing.

The same face as :class:`sim.protocol_sim.VirtualPlotter` (``write``/``read``/``pump``,
``firmware``, ``canvas``/``save_png``, ``seconds``), so ``sim://`` and ``sim-serve`` serve it
for any profile whose firmware has the host plan the motion (``capabilities.host_motion``).
Pen-down stretches are recorded as polylines in machine mm and rasterised by
:mod:`pencilbot.render`, as the GRBL simulator's are.
"""

from __future__ import annotations

import signal
import time

import numpy as np

from pencilbot.paths import Paths
from sim.ebb_board import EbbBoard
from sim.protocol_sim import VirtualPlotter
from sim.recorder import Polylines


class EbbDrawing:
    """What the pen drew and where it travelled (machine mm), in the GRBL machine's terms
    (``drawn``, ``strokes``, ``stroke_pauses``, ``travel``, ``bed_strokes``, ``bed_travel``),
    so ``simulate`` and ``demo`` read either simulator alike."""

    def __init__(self, profile, pauses):
        self.profile, self._pauses = profile, pauses
        self._strokes = Polylines()
        self._stroke: list[tuple[float, float]] = []
        self._stroke_pause = 0
        self._stroke_pauses: list[int] = []
        self._travel = Polylines()

    def record(self, start, end, drawing: bool) -> None:
        start, end = (float(start[0]), float(start[1])), (float(end[0]), float(end[1]))
        if drawing:
            if not self._stroke or self._stroke[-1] != start:
                self._close()
                self._stroke.append(start)
                self._stroke_pause = self._pauses()
            self._stroke.append(end)
        else:
            self._close()
            self._travel.add((start, end))

    def _close(self) -> None:
        if len(self._stroke) >= 2:
            self._strokes.add(self._stroke)
            self._stroke_pauses.append(self._stroke_pause)
        self._stroke = []

    def drawn(self) -> Paths:
        """Pen-down polylines so far, machine mm (the one being drawn last)."""
        return self._strokes.paths(self._stroke if len(self._stroke) >= 2 else None)

    @property
    def strokes(self) -> list[np.ndarray]:
        return list(self.drawn())

    @property
    def stroke_pauses(self) -> list[int]:
        """For each stroke, the pauses (PRG presses answered) passed when it began."""
        return self._stroke_pauses + ([self._stroke_pause] if len(self._stroke) >= 2 else [])

    @property
    def travel(self) -> list[np.ndarray]:
        return list(self._travel.paths())

    def bed_strokes(self) -> Paths:
        return self._bed_view(self.drawn())

    def bed_travel(self) -> Paths:
        return self._bed_view(self._travel.paths())

    def _bed_view(self, paths: Paths) -> Paths:
        return Paths(self.profile.bed.to_view(paths.points), paths.offsets) if len(paths.points) else paths


class VirtualEbb(VirtualPlotter):
    """A virtual AxiDraw-class plotter (EBB board, CoreXY carriage, servo pen).

    Parameters
    ----------
    profile : Profile
        An EBB profile (``[ebb]`` geometry, bed, pen).
    baud : int
        Emulated bit/s, 0 for unlimited (USB CDC has no baud rate; kept for the URL's sake).
    realtime : float
        0: instant; r > 0: the motors run r times faster than real time.
    faults : sim.faults.Faults, optional
        Failures keyed by the index of the command received (see :class:`~sim.ebb_board.EbbBoard`).
    operator : {"none", "auto"}
        ``auto``: the board's PRG button reads as pressed whenever the machine is idle (a pen
        change done at once).
    version : str, optional
        The firmware it plays (default 3.0.3; e.g. ``2.8.1``: no ``QU``, a FIFO one deep).
    """

    def __init__(self, profile, *, baud: int = 0, realtime: float = 0.0, faults=None, operator: str = "none",
                 version: str | None = None):
        self.profile = profile
        self.realtime = realtime
        self.operator = operator
        self.machine = EbbDrawing(profile, lambda: self.firmware.presses)
        self.firmware = EbbBoard(profile, self.machine.record, instant=realtime == 0, faults=faults, operator=operator,
                                 **({"version": version} if version else {}))
        self._connect(baud)

    def pump(self) -> None:
        now = time.monotonic()
        elapsed, self._last = now - self._last, now
        self.firmware.receive(self._to_board.take(now))
        self.firmware.poll(elapsed * self.realtime)
        self._to_host.put(self.firmware.take_output(), now)
        if self.firmware.signal_due is not None:  # an interrupt@ fault: once the command is taken
            signum, self.firmware.signal_due = self.firmware.signal_due, None
            signal.raise_signal(signum)

    def drawn(self) -> Paths:
        """Pen-down polylines so far, machine mm (the one being drawn last)."""
        return self.machine.drawn()

    @property
    def seconds(self) -> float:
        """Board seconds so far (motion, servo waits and idle time)."""
        return self.firmware.clock

    @property
    def busy_seconds(self) -> float:
        """Board seconds something in the motion queue ran."""
        return self.firmware.busy_time

    def position(self) -> np.ndarray:
        """The carriage's true position, machine mm."""
        return self.profile.ebb.to_machine(self.firmware._true_steps()[None].astype(float))[0]
