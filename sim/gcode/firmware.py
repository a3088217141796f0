"""The virtual plotter's GRBL 1.1h serial front end: bytes in, bytes out.

A firmware that speaks GRBL's protocol with other limits (grblHAL) gets its own banner, receive
buffer, line buffer, planner depth, help and build report, from its :mod:`firmware_protocol`
module (the profile's firmware says which).

:class:`Firmware` behaves like GRBL's serial interrupt, protocol loop and system commands
(``serial.c``, ``protocol.c``, ``system.c``, ``settings.c``, ``report.c``) in front of a
:class:`sim.gcode.machine.Machine`; the ``$`` commands live in :mod:`sim.gcode.system_commands`, the
settings in :mod:`sim.gcode.settings`, the state word and ``?`` report in :mod:`sim.gcode.status_report`:

* realtime bytes ``?`` ``!`` ``~`` 0x18 and jog cancel 0x85 act the moment they arrive; other
  bytes ≥ 0x80 (overrides, a UTF-8 BOM) never reach a line, as GRBL's interrupt drops them;
* other bytes go to the line being read; while the protocol loop is blocked (a line still
  executing: planner full, a pen change or dwell waiting for motion, an ``M0``; a feed hold;
  a critical alarm; sleep) they wait in a 128-byte receive ring, and bytes that arrive when it
  is full are **lost**, as on a real board — a sender that does not count characters corrupts
  its stream;
* each complete line gets exactly one ``ok`` or ``error:N`` when GRBL would send it (GRBL's
  filtering: whitespace and comments dropped, upper-cased, 79 significant characters at most,
  ``\\r`` and ``\\n`` both end a line; a ``%`` is not special and fails as error 1), except
  when it raises an alarm; ``M0`` answers after the cycle start that ends its pause;
* ``$`` system commands with GRBL's state rules (:mod:`sim.gcode.system_commands`);
* GRBL's states (:mod:`sim.gcode.status_report`); nothing is read in a feed hold until ``~``;
* a soft- or hard-limit alarm prints ``ALARM:N`` + ``[MSG:Reset to continue]`` and the board
  then answers nothing, not even ``?``, until a reset;
* a soft reset keeps the machine position when idle or held; in motion it raises ``ALARM:3``
  (``ALARM:6`` while homing) and locks G-code until ``$X`` or ``$H`` — and with
  ``abort_loses`` the carriage coasts on, so the position GRBL reports is no longer where it
  is. A power cycle (:meth:`Firmware.power_cycle`: a DTR reset or the ``reset`` fault) zeroes
  the position with ``power_zero``, as an Arduino does, and with homing enabled starts in
  Alarm (GRBL's HOMING_INIT_LOCK) unless ``init_lock`` is off. After every reset the banner,
  then ``[MSG:'$H'|'$X' to unlock]`` in Alarm, else the ``$N`` startup lines (``>line:ok``).

Every complete line received is logged with its 1-based index and the reply (``ok``,
``error:N``, ``ALARM:N`` or ``-`` when a fault swallowed it), so tests can prove exactly-once
delivery (:class:`sim.gcode.line_log.LineLog`). :class:`sim.faults.Faults` injects failures keyed by
that index.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator

from firmware_protocol import grbl
from sim.faults import GARBAGE, Faults
from sim.gcode.line_log import LineLog
from sim.gcode.lines import Task, filter_line
from sim.gcode.machine import Machine
from sim.gcode.motion_control import PAUSE, MachineAlarm
from sim.gcode.status_report import Flags, StatusReport
from sim.gcode.system_commands import SystemCommands

_EOL = b"\n\r"
_LINE_END = re.compile(rb"[\n\r]")
_SPECIAL = bytes(sorted(grbl.REALTIME_BYTES)) + bytes(range(0x80, 0x100))  # need byte-wise handling
HARD_LIMIT_ALARM, ABORT_ALARM, HOMING_RESET_ALARM = 1, 3, 6


class Firmware:
    """GRBL 1.1h protocol front end of a virtual plotter.

    Parameters
    ----------
    machine : Machine
        The interpreter behind it (its ``instant`` flag decides the clock mode).
    faults : Faults
        Failures to inject.
    power_zero : bool
        A power cycle restarts the position count at 0, 0, 0 (a real board); False keeps it.
    abort_loses : bool
        A reset or hard-limit alarm in motion lets the carriage coast on (a real board);
        False keeps the reported position true.
    init_lock : bool
        GRBL's HOMING_INIT_LOCK build option: with homing enabled, power up in Alarm.
    """

    def __init__(
        self,
        machine: Machine,
        faults: Faults | None = None,
        *,
        power_zero: bool = False,
        abort_loses: bool = False,
        init_lock: bool = True,
    ):
        self.machine = machine
        # The protocol's limits and texts: GRBL 1.1's, or a firmware's that speaks it (grblHAL).
        self.protocol = machine.profile.firmware.protocol
        # GRBL's ring has RX_BUFFER_SIZE + 1 slots, one always kept free
        self._ring_size = self.protocol.RX_BUFFER_SIZE
        self.faults = faults or Faults()
        self.power_zero, self.abort_loses, self.init_lock = power_zero, abort_loses, init_lock
        self.out = bytearray()
        self.log = LineLog()
        self.lost_bytes = 0  # bytes dropped because the receive ring was full
        self.link_dropped = False
        self.silent = False
        self.signal_due: int | None = None  # an interrupt@ fault's signal, for the host side
        self.queries = 0  # status queries received (the line clock counts idle ones)
        self.system = SystemCommands(self)  # the $ lines; the EEPROM's startup lines and build info
        self._rebooting = False
        self._ring = bytearray()
        self._line = bytearray()
        self._task: Task | None = None
        self._held_line: bytes | None = None  # a line the hold button stopped before it ran
        self._held_index = 0
        self._critical = False  # soft/hard limit: nothing is read or reported until reset
        self.held = False
        self.jog_planned = False  # the planner holds a $J= move
        self.homing = False
        self.sleeping = False
        self.report_due = False  # a ? that arrived while GRBL could not answer
        self.status = StatusReport(machine)
        self.locked = bool(machine.settings[22]) and init_lock  # Alarm: G-code refused until $X / $H
        self._restart()

    # --- bytes in / out ---------------------------------------------------------------------

    def receive(self, data: bytes) -> None:
        """Bytes from the host, in arrival order."""
        self._rebooting = False
        pos, n = 0, len(data)
        while pos < n and not self._deaf:
            if self._blocked:
                self._receive_bytes(data[pos:])
                return
            # Fast path: take everything up to the next line end in one piece.
            m = _LINE_END.search(data, pos)
            end = m.start() if m else n
            chunk = data[pos:end]
            if chunk.translate(None, _SPECIAL) == chunk:
                self._line += chunk
            else:
                self._receive_bytes(chunk)
            pos = end + 1
            if m and not self._deaf:
                if self._blocked:  # a realtime byte in the chunk blocked reading: the end waits too
                    self._receive_bytes(data[end:pos])
                else:
                    self._end_of_line()

    def _receive_bytes(self, data: bytes) -> None:
        """Byte by byte, as GRBL's serial interrupt sees them."""
        for b in data:
            if self._deaf:
                return
            if b in grbl.REALTIME_BYTES:
                self._realtime(b)
            elif b == grbl.JOG_CANCEL[0]:
                if self._jogging:
                    self._cancel_jog()
            elif b >= 0x80:
                continue  # other extended realtime commands (overrides, door) are not emulated
            elif self._blocked:
                if len(self._ring) < self._ring_size:
                    self._ring.append(b)
                else:
                    self.lost_bytes += 1
            elif b in _EOL:
                self._end_of_line()
            else:
                self._line.append(b)

    def take_output(self) -> bytes:
        """Everything the board has printed since the last call."""
        data = bytes(self.out)
        self.out.clear()
        return data

    def poll(self, seconds: float = 0.0) -> None:
        """Let ``seconds`` of machine time pass (real-time mode) and resume reading if the
        reason for blocking has gone."""
        if self.silent:
            return
        if (
            seconds > 0
            and not (self._critical or self.sleeping)
            and (self.machine.planner.braking or not self.held)
        ):
            now = self.machine.clock
            due = self.faults.next_due(now, now + seconds)
            if due is None:
                self.machine.advance(seconds)
            else:  # the clock stops at the fault's moment for this poll
                when, kind, code = due
                self.machine.advance(when - now)
                if kind == "hold":
                    self._begin_hold()
                else:
                    self.signal_due = code
        self._resume()

    def finish(self) -> None:
        """Instant mode: run all queued motion now (as if the host waited for it)."""
        if not (self.held or self._critical) and self._task is None:
            self.machine.finish()

    @property
    def waiting_on_motion(self) -> bool:
        """A line is being executed and waits for the machine (planner room, a dwell), not for
        a person (a hold, an ``M0``) or a reset (a critical alarm)."""
        return self._task is not None and not (self.held or self._critical or self.sleeping or self.silent)

    @property
    def _deaf(self) -> bool:
        """Nothing more of the bytes being received gets through: a hung board, a pulled
        cable, or a board rebooting (what was in flight is lost)."""
        return self.silent or self.link_dropped or self._rebooting

    @property
    def _jogging(self) -> bool:
        """A ``$J=`` move is what the planner holds (jogging ends when the planner empties)."""
        self.jog_planned = self.jog_planned and self.machine.planner.busy
        return self.jog_planned

    @property
    def _blocked(self) -> bool:
        return (
            self._task is not None
            or self._held_line is not None
            or self._critical
            or self.held
            or self.sleeping
        )

    def emit(self, text: str) -> None:
        self.out += text.encode("ascii") + b"\r\n"

    def _resume(self) -> None:
        if self._critical or self.held or self.sleeping:
            return
        if self._task is not None and not self._step():
            return
        if self._held_line is not None:
            self._line, self._held_line = bytearray(self._held_line), None
            self._end_of_line()
        while not self._blocked and self._ring and not self._deaf:
            ring, self._ring = self._ring, bytearray()
            self.receive(bytes(ring))

    # --- realtime commands ------------------------------------------------------------------

    def _realtime(self, byte: int) -> None:
        if byte == 0x18:
            self.reset()
        elif byte == ord("?"):
            self._status_query()
        elif byte == ord("!"):
            # GRBL holds from Idle too (Hold:0 at once; nothing more is read until ~), but
            # never in Alarm, check mode or sleep; a hold while jogging cancels the jog.
            if self._jogging:
                self._cancel_jog()
            elif not (self.locked or self.sleeping or self.homing or self.machine.check_mode):
                self._begin_hold()
        elif byte == ord("~") and self.held and not self.machine.planner.braking:
            # GRBL takes a cycle start only once the hold is complete (Hold:0): one that comes
            # while the machine is still slowing (Hold:1) is dropped.
            self.held = False
            self.machine.motion.release()
            self._resume()

    def _begin_hold(self) -> None:
        if not self.held:
            self.held = True
            self.machine.motion.hold()

    def _status_query(self) -> None:
        self.queries += 1
        if self._critical:
            return  # GRBL's critical-alarm loop services nothing but reset
        if self.homing:
            self.report_due = True  # the homing cycle does not stop to report
            return
        if self.machine.instant and not self._blocked:
            self.machine.finish()
        self.emit(self.status_report())

    def _cancel_jog(self) -> None:
        self.machine.stop()
        # A $J= still waiting for planner room goes on to plan its move, as in GRBL.
        self.jog_planned = self._task is not None

    def reset(self) -> None:
        """Ctrl-X soft reset: GRBL's mc_reset, then its re-initialisation."""
        m = self.machine
        moving = self.homing or (m.planner.busy and (m.planner.braking or not self.held))
        m.stop(lose=moving and self.abort_loses)
        if moving:
            code = HOMING_RESET_ALARM if self.homing else ABORT_ALARM
            self.emit(f"ALARM:{code}")
            self.locked = True
        self.locked = self.locked or self.sleeping  # position not guaranteed after sleep
        self._restart()

    def power_cycle(self) -> None:
        """Power or DTR reset: the controller restarts; settings and offsets (EEPROM) stay,
        a hung board comes back, and what is arriving right now is lost. A real board
        (``power_zero``) forgets its position and any alarm; the forgiving one keeps both."""
        self.machine.power_on(zero=self.power_zero)
        self.silent = False
        self._rebooting = True
        init_locked = bool(self.machine.settings[22]) and self.init_lock
        self.locked = init_locked or (self.locked and not self.power_zero)
        self._restart()

    def _restart(self) -> None:
        self.machine.reset_modes()
        self._ring.clear()
        self._line.clear()
        self._task = self._held_line = None
        self._critical = self.held = self.jog_planned = self.homing = self.sleeping = False
        self.report_due = False
        self.status.restart()
        self.emit("\r\n" + self.protocol.BANNER)
        if self.locked:
            self.emit("[MSG:'$H'|'$X' to unlock]")
        elif any(self.system.startup_lines):
            self.start(self.system.startup_steps(), lambda: None, None)

    # --- lines ------------------------------------------------------------------------------

    def _end_of_line(self) -> None:
        raw = bytes(self._line)
        self._line.clear()
        index = len(self.log) + 1
        text = raw.decode("latin-1").strip()
        kind, code = self.faults.at.get(index, ("", 0))
        if kind == "garbage":
            self.out += GARBAGE
        elif kind == "error":
            return self.reply(index, text, f"error:{code}")
        elif kind == "alarm":
            self.machine.stop(lose=self.abort_loses)
            self._raise_alarm(HARD_LIMIT_ALARM)
            return self.reply(index, text, f"ALARM:{HARD_LIMIT_ALARM}", emit=False)
        elif kind == "silent":
            self.silent = True
            return self.reply(index, text, "-", emit=False)
        elif kind == "drop":
            self.link_dropped = True
            return self.reply(index, text, "-", emit=False)
        elif kind == "reset":
            self.reply(index, text, "-", emit=False)
            return self.power_cycle()
        elif kind == "unplug":
            self.reply(index, text, "-", emit=False)
            self.power_cycle()
            self.out.clear()  # the banner of the restart: no cable to carry it
            self.link_dropped = True
            return
        elif kind == "abort":
            self.reply(index, text, "-", emit=False)
            self.reset()
            self._rebooting = True  # what was in the receive buffer with it is flushed
            return
        elif kind == "interrupt":
            self.signal_due = code  # sent by whoever pumps the board, after this delivery
        elif kind == "hold" and self._held_index != index:
            self._held_index, self._held_line = index, raw
            self._begin_hold()
            return
        line = filter_line(raw, self.protocol.LINE_BUFFER_SIZE)
        if line is None:
            self.reply(index, text, "error:11")
        elif not line:
            self.reply(index, text, "ok")
        elif line[0] == "$":
            self.system.line(index, text, line)
        elif self.locked or self._jogging:
            self.reply(index, text, "error:9")  # G-code is locked out in alarm and jog
        else:
            block = self.machine.parse(line)
            if isinstance(block, int):
                self.reply(index, text, f"error:{block}")
            else:
                self.start(self.machine.execute(block), self.answer(index, text), (index, text))

    def answer(self, index: int, text: str) -> Callable[[], None]:
        """The ``ok`` a line gets once its steps are done."""
        return lambda: self.reply(index, text, "ok")

    def start(self, steps: Iterator, finish: Callable[[], None], line: tuple[int, str] | None) -> None:
        """Run a line's steps now; if they block, the line stays in progress (see :meth:`_step`)."""
        self._task = Task(steps, finish, line)
        self._step()

    def _step(self) -> bool:
        """Advance the line in progress; True when it has finished (or failed)."""
        task = self._task
        assert task is not None  # (called with a line in progress)
        try:
            for signal in task.steps:
                self.machine_output()
                if signal == PAUSE:
                    self._begin_hold()  # M0: a feed hold; the line answers after ~
                return False
        except MachineAlarm as alarm:
            self._task = None
            self.machine_output()
            self._raise_alarm(alarm.code)
            if task.line is not None:
                self.reply(task.line[0], task.line[1], f"ALARM:{alarm.code}", emit=False)
            return True
        self._task = None
        self.machine_output()
        task.finish()
        return True

    def machine_output(self) -> None:
        m = self.machine
        for message in m.messages:
            self.emit(message)
        m.messages.clear()
        if m.alarm:  # a probe alarm: G-code locked, the line itself still answers
            m.alarm = 0
            self.locked = True

    def _raise_alarm(self, code: int) -> None:
        """A critical alarm (hard or soft limit): nothing more until reset."""
        self.locked = self._critical = True
        self.held = False
        self.machine.check_mode = False
        self.emit(f"ALARM:{code}")
        self.emit("[MSG:Reset to continue]")

    def answer_code(self, index: int, text: str, code: int) -> None:
        """Answer a line with ``ok`` (0) or ``error:code``."""
        self.reply(index, text, "ok" if code == 0 else f"error:{code}")

    def reply(self, index: int, text: str, reply: str, *, emit: bool = True) -> None:
        self.log.append(index, text, reply)
        if emit:
            self.emit(reply)

    def state(self) -> str:
        """GRBL's state word (:class:`~sim.gcode.status_report.StatusReport`)."""
        return self.status.state(self._flags())

    def status_report(self) -> str:
        """The ``<…>`` line GRBL prints for ``?``."""
        return self.status.report(self._flags(), self._ring_size - len(self._ring))

    def _flags(self) -> Flags:
        return Flags(self.sleeping, self.locked, self.homing, self.held, lambda: self._jogging)

    def accepted_lines(self) -> list[str]:
        """Texts of the non-blank lines answered ``ok``, in order (the exactly-once record)."""
        return self.log.texts_answered("ok")
