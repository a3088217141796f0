"""GRBL's ``$`` system commands and startup lines (``system.c``), for :class:`sim.gcode.firmware.Firmware`.

``$ $$ $# $G $I $I= $N $Nx= $C $X $H $J= $SLP $RST=$ $RST=# $RST=* $x=val`` under GRBL's state
rules (``$$`` refused in Run and Hold, settings, ``$#``, ``$I``, ``$N``, ``$H`` only when Idle or
in Alarm, ``$J=`` only Idle or jogging). The ``$N`` startup lines run after every reset and
homing cycle, each reporting ``>line:status``.
"""

from __future__ import annotations

from firmware_protocol import grbl
from sim.gcode import parser as gp
from sim.gcode.settings import DEFAULT_SETTINGS, NUMBER, store_setting
from sim.gcode.status_report import gcode_modes


class SystemCommands:
    """The ``$`` lines of :class:`sim.gcode.firmware.Firmware`, a part of it kept apart: mixed into it,
    these methods use its machine, its replies and its state (``_emit``, ``_reply``,
    ``_status``, ``_start``, ``state()``, ``_locked``…), and the EEPROM's ``startup_lines`` and
    ``build_info`` it holds.
    """

    def _startup_steps(self):
        """The ``$N`` lines, run after a reset or homing; each reports ``>line:status``."""
        m = self.machine
        for stored in self.startup_lines:
            if stored:
                block = m.parse(stored)
                if not isinstance(block, int):
                    yield from m.execute(block)
                self._machine_output()
                self._emit(f">{stored}:" + (f"error:{block}" if isinstance(block, int) else "ok"))

    def _system(self, index: int, text: str, line: str) -> None:
        """A ``$`` line, under GRBL's state rules (system.c's system_execute_line)."""
        if self.machine.instant and not self._hold:
            self.machine.finish()
        kind = line[1:2]
        if kind == "J":
            self._jog_line(index, text, line)
        elif kind in ("", "$", "G", "C", "X"):
            self._report_or_toggle(index, text, line)
        else:
            self._settings_or_homing(index, text, line)

    def _jog_line(self, index: int, text: str, line: str) -> None:
        """``$J=``: Idle or jogging only; checked as a jog block, refused past the soft limits."""
        m = self.machine
        if self.state() not in ("Idle", "Jog"):
            return self._status(index, text, 8)
        if line[2:3] != "=":
            return self._status(index, text, 3)
        block = m.parse(line[3:], jog=True)
        code = block if isinstance(block, int) else m.jog_target_allowed(block)
        if code:
            return self._status(index, text, code)
        self._jog = True
        self._start(m.jog(block), self._answer(index, text), (index, text))

    def _report_or_toggle(self, index: int, text: str, line: str) -> None:
        """``$``, ``$$``, ``$G``, ``$C``, ``$X``: answered in any state but these few."""
        m, kind, state = self.machine, line[1:2], self.state()
        if len(line) > 2:
            return self._status(index, text, 3)
        if kind == "":
            self._emit(self.protocol.HELP)
        elif kind == "$":
            if state in ("Run", "Hold:0"):
                return self._status(index, text, 8)  # takes too long to print mid-cycle
            for number, value in m.settings.items():
                self._emit(grbl.format_message(grbl.Setting(number, value)))
        elif kind == "G":
            self._emit(f"[GC:{gcode_modes(m, inches=bool(m.settings[13]))}]")
        elif kind == "C":
            if m.check_mode:
                self._emit("[MSG:Disabled]")
                self._reply(index, text, "ok")
                return self.reset()
            if state != "Idle":
                return self._status(index, text, 8)
            m.check_mode = True
            self._emit("[MSG:Enabled]")
        elif self._locked:  # $X
            self._emit("[MSG:Caution: Unlocked]")
            self._locked = False
        self._reply(index, text, "ok")

    def _settings_or_homing(self, index: int, text: str, line: str) -> None:
        """``$#``, ``$H``, ``$SLP``, ``$I``, ``$RST=``, ``$N``, ``$x=``: Idle or Alarm only."""
        m, kind, state = self.machine, line[1:2], self.state()
        if state not in ("Idle", "Alarm"):
            return self._status(index, text, 8)
        if kind == "#":
            if len(line) > 2:
                return self._status(index, text, 3)
            self._report_parameters()
        elif kind == "H":
            if not m.settings[22]:
                return self._status(index, text, 5)
            if len(line) > 2:
                return self._status(index, text, 3)
            self._homing = True
            return self._start(self._homing_steps(), self._answer(index, text), (index, text))
        elif kind == "S":
            if line != "$SLP":
                return self._status(index, text, 3)
            self._reply(index, text, "ok")
            self._emit("[MSG:Sleeping]")
            self._sleep = True
            return
        elif kind == "I":
            if len(line) == 2:
                for report in self.protocol.build_report(
                    self.build_info, "V" + ("" if self.init_lock else "L")
                ):
                    self._emit(report)
            elif line[2] != "=":
                return self._status(index, text, 3)
            else:
                self.build_info = line[3:]
        elif kind == "R":
            return self._restore(index, text, line)
        elif kind == "N" and len(line) == 2:
            for n, stored in enumerate(self.startup_lines):
                self._emit(f"$N{n}={stored}")
        elif kind == "N":
            if state != "Idle":
                return self._status(index, text, 8)
            return self._store_startup_line(index, text, line)
        else:
            return self._status(index, text, store_setting(self.machine, line))
        self._reply(index, text, "ok")

    def _homing_steps(self):
        yield from self.machine.home()
        self._homing = self._locked = False
        if self._report_due:
            self._report_due = False
            self._emit(self.status_report())
        yield from self._startup_steps()

    def _restore(self, index: int, text: str, line: str) -> None:
        """``$RST=$`` settings, ``$RST=#`` offsets, ``$RST=*`` everything back to GRBL's defaults."""
        m = self.machine
        if line[2:5] != "ST=" or len(line) != 6 or line[5] not in "$#*":
            return self._status(index, text, 3)
        if line[5] in "$*":
            m.settings = dict(DEFAULT_SETTINGS)
            m.settings_changed()
        if line[5] in "#*":
            m.coord_data[:] = [(0.0, 0.0, 0.0)] * len(m.coord_data)
        if line[5] == "*":
            self.startup_lines = ["", ""]
            self.build_info = ""
        self._emit("[MSG:Restoring defaults]")
        self._reply(index, text, "ok")
        self.reset()

    def _store_startup_line(self, index: int, text: str, line: str) -> None:
        """``$Nx=line``: the line is run now (to check it), then stored for every reset."""
        number = NUMBER.match(line, 2)
        if number is None:
            return self._status(index, text, 2)
        if line[number.end() : number.end() + 1] != "=":
            return self._status(index, text, 3)
        stored = line[number.end() + 1 :]
        block = self.machine.parse(stored)
        if isinstance(block, int):
            return self._status(index, text, block)
        slot = int(float(number.group()))

        def store() -> None:
            if slot < len(self.startup_lines):  # GRBL writes past its two slots; not emulated
                self.startup_lines[slot] = stored
            self._reply(index, text, "ok")

        self._start(self.machine.execute(block), store, (index, text))

    def _report_parameters(self) -> None:
        """``$#``: G54–G59, G28, G30 (EEPROM), G92, tool length offset, last probe."""
        m = self.machine
        inches = bool(m.settings[13])
        names = [f"G{54 + i}" for i in range(gp.COORD_SYSTEMS)] + ["G28", "G30"]
        for name, values in zip(names, m.coord_data):
            self._emit(f"[{name}:{grbl.format_coords(values, inches=inches)}]")
        self._emit(f"[G92:{grbl.format_coords(m.state.coord_offset, inches=inches)}]")
        self._emit(f"[TLO:{grbl.format_coords((m.state.tool_length_offset,), inches=inches)}]")
        self._emit(f"[PRB:{grbl.format_coords(m.probe_position, inches=inches)}:{int(m.probe_succeeded)}]")
