"""The virtual EBB plotter: an :class:`~sim.ebb.board.EbbBoard` behind wires, with a drawing.

The same face as GRBL's :class:`sim.gcode.plotter.VirtualPlotter` (both :class:`~sim.wires.WiredBoard`: ``write``/``read``/``pump``,
``firmware``, ``canvas``/``save_png``, ``seconds``), so ``sim://`` and ``sim-serve`` serve it
for any profile whose firmware has the host plan the motion (``capabilities.host_motion``).
Pen-down stretches are recorded as polylines in machine mm and rasterised by
:mod:`pencilbot.render`, as the GRBL simulator's are.
"""

from __future__ import annotations

import numpy as np

from pencilbot.paths import Paths
from sim.ebb.board import EbbBoard
from sim.recorder import StrokeRecorder
from sim.wires import WiredBoard


class EbbDrawing(StrokeRecorder):
    """What the pen drew and where it travelled (machine mm), recorded as the GRBL machine records
    it (:class:`~sim.recorder.StrokeRecorder`: ``drawn``, ``strokes``, ``stroke_pauses``,
    ``travel``, ``bed_strokes``, ``bed_travel``), so ``simulate`` and ``demo`` read either
    simulator alike. ``pauses`` counts the PRG presses answered (a pen change each)."""

    slip = (0.0, 0.0)  # the EBB's steps are where the carriage is

    def __init__(self, profile, pauses) -> None:
        super().__init__()
        self.profile, self._pauses = profile, pauses

    @property
    def pauses(self) -> int:  # type: ignore[override]  # read live from the board, not stored
        return self._pauses()

    def record(self, start, end, drawing: bool) -> None:
        """A stretch the carriage moved, pen down when ``drawing`` (machine mm)."""
        self._record(start, end, drawing)


class VirtualEbb(WiredBoard):
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
        Failures keyed by the index of the command received (see :class:`~sim.ebb.board.EbbBoard`).
    operator : {"none", "auto"}
        ``auto``: the board's PRG button reads as pressed whenever the machine is idle (a pen
        change done at once).
    version : str, optional
        The firmware it plays (default 3.0.3; e.g. ``2.8.1``: no ``QU``, a FIFO one deep).
    supply : float
        Volts at the power jack (``QC`` reports them; below 5 V the motors do not turn).
    """

    def __init__(
        self,
        profile,
        *,
        baud: int = 0,
        realtime: float = 0.0,
        faults=None,
        operator: str = "none",
        version: str | None = None,
        supply: float = 9.1,
    ):
        self.profile = profile
        self.realtime = realtime
        self.operator = operator
        self.machine = EbbDrawing(profile, lambda: self.firmware.presses)
        self.firmware = EbbBoard(
            profile,
            self.machine.record,
            instant=realtime == 0,
            faults=faults,
            operator=operator,
            supply=supply,
            **({"version": version} if version else {}),
        )
        self._connect(baud)

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
        return self.profile.ebb.to_machine(self.firmware.true_steps()[None].astype(float))[0]
