"""GRBL's state word and ``?`` status report (``report.c``), for :class:`sim.gcode.firmware.Firmware`."""

from __future__ import annotations

from firmware_protocol import grbl


class StatusReport:
    """The status of :class:`sim.gcode.firmware.Firmware`, a part of it kept apart: mixed into it,
    these methods read its machine, its flags (``_sleep``, ``_locked``, ``_homing``, ``_hold``,
    ``_jogging``), its receive ring and the WCO / override report counters.
    """

    def state(self) -> str:
        """GRBL's state word for the status report."""
        m = self.machine
        if self._sleep:
            return "Sleep"
        if self._locked:
            return "Alarm"
        if self._homing:
            return "Home"
        if self._hold:
            return "Hold:1" if m.planner.braking else "Hold:0"
        if m.check_mode:
            return "Check"
        if m.planner.busy:
            return "Jog" if self._jogging else "Run"
        return "Idle"  # also during a dwell: GRBL's cycle has ended by then

    def status_report(self) -> str:
        """The ``<…>`` line GRBL prints for ``?``, honouring ``$10``, ``$13`` and the WCO/Ov cadence."""
        m = self.machine
        state = self.state()
        busy = state in ("Run", "Hold:0", "Hold:1", "Jog", "Home")
        mask = int(m.settings[10])
        pos = m.machine_position()
        wco = m.work_offset()
        spindle = m.state.modal.spindle
        speed = m.spindle_output() if spindle != 5 else 0.0
        fields = dict(
            mpos=pos if mask & 1 else None,
            wpos=None if mask & 1 else tuple(p - o for p, o in zip(pos, wco)),
            buffer=(m.planner.free_blocks, self._ring_size - len(self._ring)) if mask & 2 else None,
            feed=m.current_speed() * 60.0 if state in ("Run", "Hold:1", "Jog") else 0.0,
            spindle=speed,
            pins=m.limit_pins() or None,
        )
        if m.offsets_changed:
            m.offsets_changed = False
            self._wco_counter = 0
        if self._wco_counter > 0:
            self._wco_counter -= 1
        else:
            self._wco_counter = (30 if busy else 10) - 1
            self._ovr_counter = self._ovr_counter or 1  # overrides on the next report
            fields["wco"] = wco
        if self._ovr_counter > 0:
            self._ovr_counter -= 1
        else:
            self._ovr_counter = (20 if busy else 10) - 1
            fields["overrides"] = (100, 100, 100)
            lit = {3: "S", 4: "C"}.get(spindle, "") if speed > 0 else ""
            fields["accessories"] = (lit + ("F" if m.state.modal.coolant == 8 else "")) or None
        name, _, sub = state.partition(":")
        return grbl.format_status(
            grbl.Status(name, int(sub) if sub else None, **fields), inches=bool(m.settings[13])
        )
