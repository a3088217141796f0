"""The virtual plotter's GRBL 1.1 serial front end: bytes in, bytes out.

A firmware that speaks GRBL's protocol with other limits (grblHAL) gets its own banner, receive
buffer, line buffer, planner depth and build info, from its :mod:`firmware_protocol` module.

:class:`Firmware` behaves like GRBL's serial ISR + protocol loop in front of a
:class:`sim.machine.Machine`:

* realtime bytes ``?`` ``!`` ``~`` 0x18 and jog cancel 0x85 act the moment they arrive, even
  when everything else is stuck; other bytes ≥ 0x80 (overrides) are discarded;
* other bytes go to the line being read; while the protocol loop is blocked (planner full in
  real-time mode, feed hold, a pen change waiting for motion to end, a critical alarm) they
  wait in a 128-byte receive ring, and bytes that arrive when it is full are **lost**, as on
  a real board — a sender that does not count characters corrupts its stream;
* each complete line gets exactly one ``ok`` or ``error:N`` (GRBL's filtering: whitespace and
  comments dropped, upper-cased, 79 significant characters at most, ``\\r`` and ``\\n`` both
  end a line), except when it raises an alarm;
* ``$`` system commands ``$ $$ $# $G $I $N $C $X $H $J= $RST=$ $N=V`` (a jog moves at its own
  F without touching the parser's modes; G-code is locked out while it runs);
* soft-limit breach → ``ALARM:2`` + ``[MSG:Reset to continue]`` and nothing is read until a
  reset; reset while moving → ``ALARM:3``; after a reset the banner, and in alarm
  ``[MSG:'$H'|'$X' to unlock]``.

Every complete line received is logged with its 1-based index and the reply (``ok``,
``error:N``, ``ALARM:N`` or ``-`` when a fault swallowed it), so tests can prove exactly-once
delivery. :class:`Faults` injects failures keyed by that index.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from firmware_protocol import grbl
from sim.machine import Machine, MachineAlarm, Parsed, grbl_settings

_EOL = b"\n\r"
_LINE_END = re.compile(rb"[\n\r]")
_SPECIAL = bytes(sorted(grbl.REALTIME_BYTES)) + bytes(range(0x80, 0x100))  # need byte-wise handling
_DROPPED = bytes(range(33)) + b"/"  # whitespace, control characters, block delete
_SETTING = re.compile(r"^\$(\d+)=(.*)$")
_FLOAT = re.compile(r"^[+-]?(?:\d+\.?\d*|\.\d+)$")
FAULT_KINDS = ("error", "alarm", "silent", "drop", "reset", "garbage")
GARBAGE = b"\xfe\x13#~garb\xa7ge\r\n"


@dataclass(frozen=True)
class Faults:
    """Failures to inject, keyed by the 1-based index of the complete line received (blank
    lines count too: the index is the one in :attr:`Firmware.log`).

    ``error@k[:N]`` answers line k with ``error:N`` (default 20) without running it;
    ``alarm@k`` raises ALARM:1 (hard limit) instead of running line k; ``silent@k`` stops
    answering anything from line k on (a hung board); ``drop@k`` drops the link when line k
    arrives (the port raises, the board keeps its state); ``reset@k`` reboots the board instead
    of running line k; ``garbage@k`` sends a line of noise before the reply to line k.
    """

    at: dict[int, tuple[str, int]] = field(default_factory=dict)

    @classmethod
    def parse(cls, spec: str) -> Faults:
        """From ``"error@5:22,silent@40"``; raises ``ValueError`` with a readable message."""
        at = {}
        for item in filter(None, (s.strip() for s in spec.split(","))):
            m = re.fullmatch(r"([a-z]+)@(\d+)(?::(\d+))?", item)
            if m is None or m.group(1) not in FAULT_KINDS:
                raise ValueError(
                    f"fault {item!r} is not KIND@LINE (KIND one of {', '.join(FAULT_KINDS)}; "
                    "error@LINE:CODE sets the error code)"
                )
            at[int(m.group(2))] = (m.group(1), int(m.group(3) or 20))
        return cls(at)


@dataclass(frozen=True)
class LoggedLine:
    """A complete line the board received: 1-based ``index``, the text, and its reply."""

    index: int
    text: str
    reply: str


def filter_line(raw: bytes, line_buffer: int = grbl.LINE_BUFFER_SIZE) -> str | None:
    """GRBL's protocol-loop filter: the significant characters, or ``None`` on overflow."""
    if b"(" in raw or b";" in raw:
        raw = re.sub(rb"\([^)]*\)?|;.*", b"", raw)
    text = raw.translate(None, _DROPPED).upper()
    if len(text) >= line_buffer:
        return None
    return text.decode("latin-1")


class Firmware:
    """GRBL 1.1 protocol front end of a virtual plotter.

    Parameters
    ----------
    machine : Machine
        The interpreter behind it (its ``instant`` flag decides the clock mode).
    faults : Faults
        Failures to inject.
    """

    def __init__(self, machine: Machine, faults: Faults | None = None):
        self.machine = machine
        # The protocol's limits and texts: GRBL 1.1's, or a firmware's that speaks it (grblHAL).
        self.protocol = machine.profile.firmware.protocol
        self._ring_size = self.protocol.RX_BUFFER_SIZE - 1  # one slot of the ring stays empty
        self.faults = faults or Faults()
        self.out = bytearray()
        self.log: list[LoggedLine] = []
        self.lost_bytes = 0  # bytes dropped because the receive ring was full
        self._rebooting = False
        self.link_dropped = False
        self.silent = False
        self._ring = bytearray()
        self._line = bytearray()
        # A line waiting to run, or (parsed None) run and waiting for its dwell to end.
        self._pending: tuple[int, str, Parsed | None] | None = None
        self._alarm = 0  # alarm code while in Alarm state
        self._critical = False  # soft/hard limit: nothing is read until reset
        self._hold = False
        self._jog = False  # the planner holds a $J= move
        self._wco_counter = 0
        self._ovr_counter = 0
        self._emit("\r\n" + self.protocol.BANNER)

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
            if m and not self._blocked and not self._deaf:
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
                    self.machine.stop()
                    self._jog = False
            elif b >= 0x80:
                continue  # other extended realtime commands (overrides) are not emulated
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
        if seconds > 0 and not self._hold and not self._critical:
            self.machine.advance(seconds)
        self._resume()

    def finish(self) -> None:
        """Instant mode: run all queued motion now (as if the host waited for it)."""
        if not self._hold and not self._critical and self._pending is None:
            self.machine.finish()

    @property
    def _deaf(self) -> bool:
        """Nothing more of the bytes being received gets through: a hung board, a pulled
        cable, or a board rebooting (what was in flight is lost)."""
        return self.silent or self.link_dropped or self._rebooting

    @property
    def _jogging(self) -> bool:
        """A ``$J=`` move is what the planner holds (jogging ends when the planner empties)."""
        self._jog = self._jog and self.machine.planner.busy
        return self._jog

    @property
    def _blocked(self) -> bool:
        return self._pending is not None or self._critical

    def _emit(self, text: str) -> None:
        self.out += text.encode("ascii") + b"\r\n"

    def _resume(self) -> None:
        if self._pending is not None:
            index, text, parsed = self._pending
            if parsed is None and not self.machine.dwelling:
                self._pending = None
                self._reply(index, text, "ok")
            elif parsed is not None and not self._must_wait(parsed):
                self._pending = None
                self._run_gcode(index, text, parsed)
        while not self._blocked and self._ring and not self._deaf:
            ring, self._ring = self._ring, bytearray()
            self.receive(bytes(ring))

    # --- realtime commands ------------------------------------------------------------------

    def _realtime(self, byte: int) -> None:
        if byte == 0x18:
            self.reset()
        elif byte == ord("?"):
            if self.machine.instant and not self._blocked and not self._hold:
                self.machine.finish()
            self._emit(self.status_report())
        elif byte == ord("!"):
            # GRBL 1.1 holds from Idle too (Hold:0 at once; what arrives next waits for ~),
            # but never in Alarm or check mode.
            if not self._alarm and not self.machine.check_mode:
                self._hold = True
        elif byte == ord("~"):
            if self._hold:
                self._hold = False
                self._resume()

    def reset(self, *, reboot: bool = False) -> None:
        """Ctrl-X soft reset (``reboot``: a power cycle or DTR reset — no ALARM:3, and a hung
        board comes back)."""
        moving = self.machine.stop()
        if reboot:
            self.silent = False
            self._rebooting = True  # the rest of what is arriving now is lost
        if moving and not reboot:
            self._emit("ALARM:3")
            self._alarm = 3
        self.machine.reset_modes()
        self._ring.clear()
        self._line.clear()
        self._pending = None
        self._critical = self._hold = False
        self._wco_counter = self._ovr_counter = 0
        self._emit("\r\n" + self.protocol.BANNER)
        if self._alarm:
            self._emit("[MSG:'$H'|'$X' to unlock]")

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
            return self._reply(index, text, f"error:{code}")
        elif kind == "alarm":
            self.machine.stop()
            self._raise_alarm(1)
            return self._reply(index, text, "ALARM:1", emit=False)
        elif kind == "silent":
            self.silent = True
            return self._reply(index, text, "-", emit=False)
        elif kind == "drop":
            self.link_dropped = True
            return self._reply(index, text, "-", emit=False)
        elif kind == "reset":
            self._reply(index, text, "-", emit=False)
            return self.reset(reboot=True)
        line = filter_line(raw, self.protocol.LINE_BUFFER_SIZE)
        if line is None:
            self._reply(index, text, "error:11")
        elif not line:
            self._reply(index, text, "ok")
        elif line[0] == "$":
            self._system(index, text, line)
        elif self._alarm or self._jogging:
            self._reply(index, text, "error:9")  # G-code is locked out in alarm and jog
        else:
            parsed = self.machine.parse(line)
            if isinstance(parsed, int):
                self._reply(index, text, f"error:{parsed}")
            elif self._must_wait(parsed):
                self._pending = (index, text, parsed)
            else:
                self._run_gcode(index, text, parsed)

    def _must_wait(self, parsed: Parsed) -> bool:
        return (self._hold or not self.machine.instant) and self.machine.must_wait(parsed)

    def _run_gcode(self, index: int, text: str, parsed: Parsed) -> None:
        try:
            self.machine.apply(parsed)
        except MachineAlarm as alarm:
            self._raise_alarm(alarm.code)
            return self._reply(index, text, f"ALARM:{alarm.code}", emit=False)
        for message in self.machine.messages:
            self._emit(message)
        self.machine.messages.clear()
        if self.machine.pause_requested:  # M0: ok now, then a feed hold until ~
            self.machine.pause_requested = False
            self._hold = True
        if self.machine.dwelling:
            self._pending = (index, text, None)  # GRBL answers a dwell when it has ended
        else:
            self._reply(index, text, "ok")

    def _raise_alarm(self, code: int) -> None:
        self._alarm = code
        self._critical = True
        self._hold = False
        self._emit(f"ALARM:{code}")
        self._emit("[MSG:Reset to continue]")

    def _reply(self, index: int, text: str, reply: str, *, emit: bool = True) -> None:
        self.log.append(LoggedLine(index, text, reply))
        if emit:
            self._emit(reply)

    def accepted_lines(self) -> list[str]:
        """Texts of the non-blank lines answered ``ok``, in order (the exactly-once record;
        blank lines, such as a sender's wake-up line ends, carry nothing to deliver)."""
        return [entry.text for entry in self.log if entry.reply == "ok" and entry.text]

    # --- $ commands -------------------------------------------------------------------------

    def _system(self, index: int, text: str, line: str) -> None:
        m = self.machine
        if m.instant and not self._hold:
            m.finish()
        idle = not m.planner.busy and not self._hold
        if line == "$G":
            self._emit(f"[GC:{m.gcode_state()}]")
        elif line == "$X":
            if self._alarm:
                self._emit("[MSG:Caution: Unlocked]")
                self._alarm = 0
        elif line == "$C":
            if m.check_mode:
                m.check_mode = False
                self._emit("[MSG:Disabled]")
                self._reply(index, text, "ok")
                return self.reset()
            if self._alarm or not idle:
                return self._reply(index, text, "error:8")
            m.check_mode = True
            self._emit("[MSG:Enabled]")
        elif line.startswith("$J"):
            if self._alarm or self._hold or (m.planner.busy and not self._jogging):
                return self._reply(index, text, "error:8")
            if not line.startswith("$J="):
                return self._reply(index, text, "error:3")
            code = m.jog(line[3:])
            if code:
                return self._reply(index, text, f"error:{code}")
            self._jog = True
        elif line == "$H":
            if not m.settings[22]:
                return self._reply(index, text, "error:5")
            if not idle:
                return self._reply(index, text, "error:8")
            m.home()
            self._alarm = 0
        elif not idle:
            return self._reply(index, text, "error:8")
        elif line == "$":
            self._emit(self.protocol.HELP)
        elif line == "$$":
            for number, value in m.settings.items():
                self._emit(grbl.format_message(grbl.Setting(number, value)))
        elif line == "$#":
            for name in ("G54", "G55", "G56", "G57", "G58", "G59", "G28", "G30"):
                self._emit(f"[{name}:0.000,0.000,0.000]")
            self._emit("[G92:" + ",".join(f"{v:.3f}" for v in m.g92) + "]")
            self._emit("[TLO:0.000]")
            self._emit("[PRB:0.000,0.000,0.000:0]")
        elif line == "$I":
            for info in self.protocol.BUILD_INFO:
                self._emit(info)
        elif line == "$N":
            self._emit("$N0=")
            self._emit("$N1=")
        elif line == "$RST=$":
            m.settings = grbl_settings(m.profile)
        elif match := _SETTING.match(line):
            return self._reply(index, text, self._store_setting(int(match.group(1)), match.group(2)))
        else:
            return self._reply(index, text, "error:3")
        self._reply(index, text, "ok")

    def _store_setting(self, number: int, value_text: str) -> str:
        settings = self.machine.settings
        if not _FLOAT.match(value_text):
            return "error:2"
        value = float(value_text)
        if number not in settings:
            return "error:3"
        if value < 0:
            return "error:4"
        if number == 0 and value < 3:
            return "error:6"
        if number == 20 and value and not settings[22]:
            return "error:10"
        settings[number] = int(value) if number in grbl.INTEGER_SETTINGS else value
        return "ok"

    # --- status -----------------------------------------------------------------------------

    def state(self) -> str:
        """GRBL's state word for the status report."""
        m = self.machine
        if self._alarm:
            return "Alarm"
        if self._hold:
            return "Hold:0"
        if m.check_mode:
            return "Check"
        if m.planner.busy or m.dwelling:
            return "Jog" if self._jogging else "Run"
        return "Idle"

    def status_report(self) -> str:
        """The ``<…>`` line GRBL prints for ``?``, honouring ``$10`` and the WCO/Ov cadence."""
        m = self.machine
        state = self.state()
        busy = state not in ("Idle", "Alarm", "Check")
        mask = int(m.settings[10])
        pos = m.machine_position()
        executing = m.planner.executing or (m.planner.queue[0] if m.planner.queue else None)
        feed = executing.nominal * 60.0 if executing is not None and state == "Run" else 0.0
        fields = dict(
            mpos=pos if mask & 1 else None,
            wpos=None if mask & 1 else tuple(p - o for p, o in zip(pos, m.g92)),
            buffer=(m.planner.free_blocks, self.protocol.RX_BUFFER_SIZE - len(self._ring)) if mask & 2 else None,
            feed=feed,
            spindle=m.s if m.spindle != 5 else 0.0,
        )
        if self._wco_counter > 0:
            self._wco_counter -= 1
        else:
            self._wco_counter = (30 if busy else 10) - 1
            self._ovr_counter = self._ovr_counter or 1  # overrides on the next report
            fields["wco"] = m.g92
        if self._ovr_counter > 0:
            self._ovr_counter -= 1
        else:
            self._ovr_counter = (20 if busy else 10) - 1
            fields["overrides"] = (100, 100, 100)
            fields["accessories"] = {3: "S", 4: "C"}.get(m.spindle)
        name, _, sub = state.partition(":")
        return grbl.format_status(grbl.Status(name, int(sub) if sub else None, **fields))
