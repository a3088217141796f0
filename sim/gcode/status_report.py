"""GRBL's state word and ``?`` status report (``report.c``), for :class:`sim.gcode.firmware.Firmware`.

States Idle, Run, Hold:1, Hold:0, Jog, Home, Alarm, Check, Sleep. A feed hold slows the
machine along its path at its acceleration (``Hold:1``; a reset now is a reset in motion, a
``~`` is dropped) until it stands (``Hold:0``); the rest of the move then starts from rest.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from firmware_protocol import grbl
from pencilbot.units import MM_PER_INCH
from sim.gcode import parser as gp

if TYPE_CHECKING:
    from sim.gcode.machine import Machine


@dataclass(frozen=True)
class Flags:
    """What the firmware is doing, as the state word reads it (``jogging`` asked last, and only
    when the machine moves: asking ends a jog whose moves have run)."""

    sleep: bool
    locked: bool
    homing: bool
    hold: bool
    jogging: Callable[[], bool]


class StatusReport:
    """The status of a GRBL board's ``machine``: the state word from the firmware's flags, and the
    ``?`` report, whose work-offset and override fields come every few reports (it owns those
    counters)."""

    def __init__(self, machine: Machine) -> None:
        self.machine = machine
        self.restart()

    def restart(self) -> None:
        """A reset: the next report carries the work offset."""
        self.wco_counter = self.ovr_counter = 0

    def state(self, flags: Flags) -> str:
        """GRBL's state word for the status report."""
        m = self.machine
        if flags.sleep:
            return "Sleep"
        if flags.locked:
            return "Alarm"
        if flags.homing:
            return "Home"
        if flags.hold:
            return "Hold:1" if m.planner.braking else "Hold:0"
        if m.check_mode:
            return "Check"
        if m.planner.busy:
            return "Jog" if flags.jogging() else "Run"
        return "Idle"  # also during a dwell: GRBL's cycle has ended by then

    def report(self, flags: Flags, ring_free: int) -> str:
        """The ``<…>`` line GRBL prints for ``?``, honouring ``$10``, ``$13`` and the WCO/Ov cadence;
        ``ring_free``: the bytes free in the receive ring."""
        m = self.machine
        state = self.state(flags)
        busy = state in ("Run", "Hold:0", "Hold:1", "Jog", "Home")
        mask = int(m.settings[10])
        pos = m.machine_position()
        wco = m.work_offset()
        spindle = m.state.modal.spindle
        speed = m.spindle_output() if spindle != 5 else 0.0
        fields: dict[str, Any] = dict(
            mpos=pos if mask & 1 else None,
            wpos=None if mask & 1 else tuple(p - o for p, o in zip(pos, wco)),
            buffer=(m.planner.free_blocks, ring_free) if mask & 2 else None,
            feed=m.current_speed() * 60.0 if state in ("Run", "Hold:1", "Jog") else 0.0,
            spindle=speed,
            pins=m.limit_pins() or None,
        )
        if m.offsets_changed:
            m.offsets_changed = False
            self.wco_counter = 0
        if self.wco_counter > 0:
            self.wco_counter -= 1
        else:
            self.wco_counter = (30 if busy else 10) - 1
            self.ovr_counter = self.ovr_counter or 1  # overrides on the next report
            fields["wco"] = wco
        if self.ovr_counter > 0:
            self.ovr_counter -= 1
        else:
            self.ovr_counter = (20 if busy else 10) - 1
            fields["overrides"] = (100, 100, 100)
            lit = {3: "S", 4: "C"}.get(spindle, "") if speed > 0 else ""
            fields["accessories"] = (lit + ("F" if m.state.modal.coolant == 8 else "")) or None
        name, _, sub = state.partition(":")
        return grbl.format_status(
            grbl.Status(name, int(sub) if sub else None, **fields), inches=bool(m.settings[13])
        )


def gcode_modes(machine: Machine, inches: bool = False) -> str:
    """The ``$G`` text (report.c's report_gcode_modes): ``G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0``."""
    m, s = machine.state.modal, machine.state
    motion = f"{m.motion:.1f}" if m.motion in gp.PROBES else f"{m.motion:.0f}"
    feed = f"{s.feed / MM_PER_INCH:.1f}" if inches else f"{s.feed:.0f}"
    return (
        f"G{motion} G{54 + m.coord_select} G{17 + m.plane} G{21 if m.units_mm else 20} "
        f"G{90 if m.absolute else 91} G{93 if m.inverse_time else 94} M{m.spindle} M{m.coolant} "
        f"T{s.tool} F{feed} S{s.spindle_speed:.0f}"
    )
