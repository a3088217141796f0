"""GRBL's ``$`` system commands and startup lines (``system.c``), for :class:`sim.gcode.firmware.Firmware`.

``$ $$ $# $G $I $I= $N $Nx= $C $X $H $J= $SLP $RST=$ $RST=# $RST=* $x=val`` under GRBL's state
rules (``$$`` refused in Run and Hold, settings, ``$#``, ``$I``, ``$N``, ``$H`` only when Idle or
in Alarm, ``$J=`` only Idle or jogging). The ``$N`` startup lines run after every reset and
homing cycle, each reporting ``>line:status``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from firmware_protocol import grbl
from sim.gcode import parser as gp
from sim.gcode.settings import DEFAULT_SETTINGS, NUMBER, store_setting
from sim.gcode.status_report import gcode_modes

if TYPE_CHECKING:
    from sim.gcode.firmware import Firmware


class SystemCommands:
    """The ``$`` lines of a :class:`sim.gcode.firmware.Firmware`, held by it: they answer through
    its public face (``emit``, ``reply``, ``answer_code``, ``start``, ``state()``, its ``locked``,
    ``homing``… flags) and keep the EEPROM's ``startup_lines`` and ``build_info``.
    """

    def __init__(self, fw: Firmware) -> None:
        self.fw = fw
        self.startup_lines = ["", ""]  # $N0, $N1 (EEPROM)
        self.build_info = ""  # $I= (EEPROM)

    def startup_steps(self):
        """The ``$N`` lines, run after a reset or homing; each reports ``>line:status``."""
        m = self.fw.machine
        for stored in self.startup_lines:
            if stored:
                block = m.parse(stored)
                if not isinstance(block, int):
                    yield from m.execute(block)
                self.fw.machine_output()
                self.fw.emit(f">{stored}:" + (f"error:{block}" if isinstance(block, int) else "ok"))

    def line(self, index: int, text: str, line: str) -> None:
        """A ``$`` line, under GRBL's state rules (system.c's system_execute_line)."""
        if self.fw.machine.instant and not self.fw.held:
            self.fw.machine.finish()
        kind = line[1:2]
        if kind == "J":
            self._jog_line(index, text, line)
        elif kind in ("", "$", "G", "C", "X"):
            self._report_or_toggle(index, text, line)
        else:
            self._settings_or_homing(index, text, line)

    def _jog_line(self, index: int, text: str, line: str) -> None:
        """``$J=``: Idle or jogging only; checked as a jog block, refused past the soft limits."""
        m = self.fw.machine
        if self.fw.state() not in ("Idle", "Jog"):
            return self.fw.answer_code(index, text, 8)
        if line[2:3] != "=":
            return self.fw.answer_code(index, text, 3)
        block = m.parse(line[3:], jog=True)
        if isinstance(block, int):
            return self.fw.answer_code(index, text, block)
        code = m.jog_target_allowed(block)
        if code:
            return self.fw.answer_code(index, text, code)
        self.fw.jog_planned = True
        self.fw.start(m.jog(block), self.fw.answer(index, text), (index, text))

    def _report_or_toggle(self, index: int, text: str, line: str) -> None:
        """``$``, ``$$``, ``$G``, ``$C``, ``$X``: answered in any state but these few."""
        m, kind, state = self.fw.machine, line[1:2], self.fw.state()
        if len(line) > 2:
            return self.fw.answer_code(index, text, 3)
        if kind == "":
            self.fw.emit(self.fw.protocol.HELP)
        elif kind == "$":
            if state in ("Run", "Hold:0"):
                return self.fw.answer_code(index, text, 8)  # takes too long to print mid-cycle
            for number, value in m.settings.items():
                self.fw.emit(grbl.format_message(grbl.Setting(number, value)))
        elif kind == "G":
            self.fw.emit(f"[GC:{gcode_modes(m, inches=bool(m.settings[13]))}]")
        elif kind == "C":
            if m.check_mode:
                self.fw.emit("[MSG:Disabled]")
                self.fw.reply(index, text, "ok")
                return self.fw.reset()
            if state != "Idle":
                return self.fw.answer_code(index, text, 8)
            m.check_mode = True
            self.fw.emit("[MSG:Enabled]")
        elif self.fw.locked:  # $X
            self.fw.emit("[MSG:Caution: Unlocked]")
            self.fw.locked = False
        self.fw.reply(index, text, "ok")

    def _settings_or_homing(self, index: int, text: str, line: str) -> None:
        """``$#``, ``$H``, ``$SLP``, ``$I``, ``$RST=``, ``$N``, ``$x=``: Idle or Alarm only."""
        m, kind, state = self.fw.machine, line[1:2], self.fw.state()
        if state not in ("Idle", "Alarm"):
            return self.fw.answer_code(index, text, 8)
        if kind == "#":
            if len(line) > 2:
                return self.fw.answer_code(index, text, 3)
            self._report_parameters()
        elif kind == "H":
            if not m.settings[22]:
                return self.fw.answer_code(index, text, 5)
            if len(line) > 2:
                return self.fw.answer_code(index, text, 3)
            self.fw.homing = True
            return self.fw.start(self._homing_steps(), self.fw.answer(index, text), (index, text))
        elif kind == "S":
            if line != "$SLP":
                return self.fw.answer_code(index, text, 3)
            self.fw.reply(index, text, "ok")
            self.fw.emit("[MSG:Sleeping]")
            self.fw.sleeping = True
            return
        elif kind == "I":
            if len(line) == 2:
                for report in self.fw.protocol.build_report(
                    self.build_info, "V" + ("" if self.fw.init_lock else "L")
                ):
                    self.fw.emit(report)
            elif line[2] != "=":
                return self.fw.answer_code(index, text, 3)
            else:
                self.build_info = line[3:]
        elif kind == "R":
            return self._restore(index, text, line)
        elif kind == "N" and len(line) == 2:
            for n, stored in enumerate(self.startup_lines):
                self.fw.emit(f"$N{n}={stored}")
        elif kind == "N":
            if state != "Idle":
                return self.fw.answer_code(index, text, 8)
            return self._store_startup_line(index, text, line)
        else:
            return self.fw.answer_code(index, text, store_setting(self.fw.machine, line))
        self.fw.reply(index, text, "ok")

    def _homing_steps(self):
        yield from self.fw.machine.home()
        self.fw.homing = self.fw.locked = False
        if self.fw.report_due:
            self.fw.report_due = False
            self.fw.emit(self.fw.status_report())
        yield from self.startup_steps()

    def _restore(self, index: int, text: str, line: str) -> None:
        """``$RST=$`` settings, ``$RST=#`` offsets, ``$RST=*`` everything back to GRBL's defaults."""
        m = self.fw.machine
        if line[2:5] != "ST=" or len(line) != 6 or line[5] not in "$#*":
            return self.fw.answer_code(index, text, 3)
        if line[5] in "$*":
            m.settings = dict(DEFAULT_SETTINGS)
            m.settings_changed()
        if line[5] in "#*":
            m.coord_data[:] = [(0.0, 0.0, 0.0)] * len(m.coord_data)
        if line[5] == "*":
            self.startup_lines = ["", ""]
            self.build_info = ""
        self.fw.emit("[MSG:Restoring defaults]")
        self.fw.reply(index, text, "ok")
        self.fw.reset()

    def _store_startup_line(self, index: int, text: str, line: str) -> None:
        """``$Nx=line``: the line is run now (to check it), then stored for every reset."""
        number = NUMBER.match(line, 2)
        if number is None:
            return self.fw.answer_code(index, text, 2)
        if line[number.end() : number.end() + 1] != "=":
            return self.fw.answer_code(index, text, 3)
        stored = line[number.end() + 1 :]
        block = self.fw.machine.parse(stored)
        if isinstance(block, int):
            return self.fw.answer_code(index, text, block)
        slot = int(float(number.group()))

        def store() -> None:
            if slot < len(self.startup_lines):  # GRBL writes past its two slots; not emulated
                self.startup_lines[slot] = stored
            self.fw.reply(index, text, "ok")

        self.fw.start(self.fw.machine.execute(block), store, (index, text))

    def _report_parameters(self) -> None:
        """``$#``: G54–G59, G28, G30 (EEPROM), G92, tool length offset, last probe."""
        m = self.fw.machine
        inches = bool(m.settings[13])
        names = [f"G{54 + i}" for i in range(gp.COORD_SYSTEMS)] + ["G28", "G30"]
        for name, values in zip(names, m.coord_data):
            self.fw.emit(f"[{name}:{grbl.format_coords(values, inches=inches)}]")
        self.fw.emit(f"[G92:{grbl.format_coords(m.state.coord_offset, inches=inches)}]")
        self.fw.emit(f"[TLO:{grbl.format_coords((m.state.tool_length_offset,), inches=inches)}]")
        self.fw.emit(f"[PRB:{grbl.format_coords(m.probe_position, inches=inches)}:{int(m.probe_succeeded)}]")
