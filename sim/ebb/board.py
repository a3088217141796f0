"""A virtual EiBotBoard: the EBB command set (firmware 3.0.3), its motion FIFO, steps, servo.

What a sender meets (all from the EBB reference and the firmware source, see
:mod:`firmware_protocol.ebb`): replies in legacy syntax until ``CU,10,1`` switches to future
syntax; a motion command is parsed, and answered, only once the FIFO (1 deep at boot, ``CU,4``)
has room, and everything behind it waits; ``LM`` steps at the 25 kHz tick from its rate and
acceleration words exactly as the firmware's accumulators do, ``SM``/``XM`` at constant rates,
``HM`` in a straight line at the given step rate; the servo sweeps at its ``SC,11``/``SC,12``
rates (24 ms per update) while ``SP``'s Duration holds the queue; ``QG`` status byte, ``QS``
counters, ``ES`` stop and flush, ``EM`` (counters back to 0), ``CU,60`` power-lost flag.

The carriage's true position is kept apart from the step counters, so a power cycle (counters
back to 0 where the carriage stands) or lost steps show up in the drawing. Pen-down moves are
drawn only once the servo has reached the pen-down position: a sender that moves before the
pen lands leaves those moves out of the drawing, as the paper would.

Time: ``instant`` boards run motion only as far as a sender needs: to make FIFO room, and the
command running to its end per status query (a polling sender sees progress, a command at a
time, whatever the host's speed); otherwise :meth:`EbbBoard.poll` advances the clock.
"""

from __future__ import annotations

import numpy as np

from firmware_protocol import ebb as protocol
from firmware_protocol.ebb import CommandError
from sim.ebb import moves as ebb_moves
from sim.ebb.queries import Queries, Readings
from sim.ebb.run import Run as _Run
from sim.ebb.run import typed as _typed
from sim.ebb.servo import PenSide, Servos

BOOT_SERVO = (12000, 16000)  # SC,4 / SC,5 at boot
_GARBAGE = b"\xfe\x13#~garb\xa7ge\r\n"


class EbbBoard:
    """The board behind the wire: call :meth:`receive` with bytes, :meth:`poll` with time,
    :meth:`take_output` for its replies. ``record(start_mm, end_mm, drawing)`` is called for
    every stretch the carriage moves.

    Faults (:class:`sim.faults.Faults`, keyed by the 1-based index of the command received):
    ``error@k`` refuses command k (``!6``) without running it; ``silent@k`` runs it but its
    answer is lost; ``drop@k`` pulls the cable as it arrives (the board keeps running its queue);
    ``reset@k`` is a power cut (a reboot: the carriage stops where it is, counters 0 there,
    motors off); ``unplug@k`` pulls the USB cable, which powers the board's logic: the link drops
    and the board reboots as in a power cut; ``interrupt@k[:SIGNAL]`` runs command k and has the
    sender's process get SIGNAL (default SIGINT: Ctrl-C at its terminal) once it is taken;
    ``abort@k`` a dip of the supply (the carriage slips, ``QG`` bit 6 once ``CU,60`` set a
    threshold); ``garbage@k`` noise before the answer.
    """

    resets_on_open = False  # USB CDC: opening the port does not reset an EBB (no DTR reset)
    MOTOR_VOLTS = 5.0  # below this supply the stepper drivers do not turn the motors

    def __init__(
        self,
        profile,
        record,
        *,
        instant: bool = True,
        faults=None,
        operator: str = "none",
        version: str = protocol.VERSION,
        supply: float = 9.1,
    ):
        self.profile, self.record, self.instant = profile, record, instant
        self.pen_side = PenSide(self)  # where the pen is, what the carriage draws with it
        self.version, self._version = version, protocol.version_tuple(version)
        self.faults = faults.at if faults is not None else {}
        self.operator = operator
        self.supply_volts = supply  # V at the power jack (0: only USB: the motors have no power)
        self.queries = Queries()  # SL/QL, nodes, ports, the name in flash (kept through reboots)
        self.link_dropped = False
        self.clock = 0.0
        self.busy_time = 0.0  # seconds something ran (for gap measurements)
        self.gaps: list[float] = []  # idle stretches of the queue once the first move ran
        self._moved = False
        self.presses = 0  # PRG presses read by a sender (the pauses it was let through)
        self.signal_due: int | None = None  # an interrupt@ fault's signal, for the host side
        self.log: list[str] = []
        self._rx = bytearray()
        self._out = bytearray()
        self._received = 0
        self.carriage = np.zeros(2)  # true position, motor steps from the bed's origin
        self.power_cycle()

    # --- power and wires --------------------------------------------------------------------

    def power_cycle(self) -> None:
        """A reboot: counters 0 wherever the carriage stands, FIFO empty, legacy syntax."""
        self.future = False
        self.fifo_size = 1
        self.fifo: list[protocol.Command] = []
        self.running: _Run | None = None
        self.counters = np.zeros(2, dtype=np.int64)
        self.origin = self.carriage.copy()  # counters are relative to where they were zeroed
        self.carry = [0, 0]
        self.servo_up, self.servo_down = BOOT_SERVO
        self.rate_up = self.rate_down = 0
        self.servos = Servos(getattr(self.profile.ebb, "servo_pin", 1), self.pen_side.resting_servo())
        self.pen_up = True
        self.queries.reset()
        self.enabled = (0, 0)  # QE: motors off at boot, so the carriage is free to move
        self.microsteps = 16
        self.power_lost = False
        self.threshold = 0
        self.button = False
        self._rx.clear()
        self._idle_since: float | None = None

    def receive(self, data: bytes) -> None:
        self._rx += data
        self._process()

    def take_output(self) -> bytes:
        out, self._out = bytes(self._out), bytearray()
        return out

    def accepted_lines(self) -> list[str]:
        return list(self.log)

    def finish(self) -> None:
        """Run everything queued to its end."""
        while self.running is not None or self.fifo:
            self._advance(self._remaining() + 1e-9)
        self._process()

    # --- time ----------------------------------------------------------------------------------

    def poll(self, dt: float) -> None:
        if dt > 0:
            self._advance(dt)
        self._process()

    def _remaining(self) -> float:
        if self.running is None:
            return 0.0
        return max(self.running.t0 + self.running.ticks * protocol.TICK - self.clock, 0.0)

    def _advance(self, dt: float) -> None:
        """Run the queue for ``dt`` seconds of board time."""
        end = self.clock + dt
        while True:
            if self.running is None and self.fifo:
                self._start(self.fifo.pop(0))
                if not self.instant:
                    self._process()  # room in the FIFO: a waiting command is parsed at this instant
                continue
            if self.running is None:
                if self._idle_since is None:
                    self._idle_since = self.clock
                self.clock = end
                return
            finish = self.running.t0 + self.running.ticks * protocol.TICK
            if finish > end:
                self.busy_time += end - self.clock
                self.clock = end
                self._place(self.running, int((end - self.running.t0) / protocol.TICK))
                return
            self.busy_time += finish - self.clock
            self.clock = finish
            self._complete(self.running, self.running.ticks)

    def _start(self, command: protocol.Command) -> None:
        if self._idle_since is not None and self._moved:
            self.gaps.append(self.clock - self._idle_since)
        self._moved = self._moved or command.name in ("LM", "SM", "XM", "HM")
        self._idle_since = None
        self.running = ebb_moves.start_run(self, command)
        if self.running is None or self.running.ticks == 0:
            if self.running is not None:
                self._complete(self.running, 0)
            self.running = None

    def _place(self, run: _Run, t: int) -> None:
        self.counters = run.start + run.steps_at(t)

    def _complete(self, run: _Run, t: int) -> None:
        """``run`` ends (after ``t`` ticks: all of it, or where ES cut it)."""
        before = self.origin + run.start
        self.counters = run.start + run.steps_at(t)
        if run.steps.any() and self.supply_volts < self.MOTOR_VOLTS:  # counted, but the motors had no power
            self.origin = self.origin - (self.counters - run.start)
        elif run.steps.any():
            self.pen_side.record_move(before, run, t)
        for i in range(2):  # the accumulators keep their remainders for the next command
            if run.steps[i] and run.command.name == "LM" and t >= run.axis_ticks[i]:
                self.carry[i] = (
                    run.carry[i]
                    + run.rates[i] * t
                    + run.accels[i] * t * t // 2
                    - abs(int(run.steps[i])) * protocol.ACCUMULATOR
                )
        self.running = None

    # --- the pen and the drawing ---------------------------------------------------------------

    def true_steps(self) -> np.ndarray:
        return self.origin + self.counters

    # --- commands ------------------------------------------------------------------------------

    def _process(self) -> None:
        """Parse complete commands from the input while the FIFO lets them in."""
        while not self.link_dropped:
            ends = [i for i in (self._rx.find(b"\r"), self._rx.find(b"\n")) if i >= 0]
            if not ends:
                if len(self._rx) >= protocol.MAX_COMMAND:
                    self._rx.clear()
                    self._reply(
                        b"!3 Err: RX Buffer overrun\r\n"
                        if not self.future
                        else b"!3 Err: RX Buffer overrun\n"
                    )
                return
            cut = min(ends)  # CR or LF ends a command (UBW.c); a CR LF pair counts once
            text = _typed(self._rx[:cut])
            if not text:
                del self._rx[: cut + 1]
                continue
            try:
                command = protocol.parse_command(text)
                if self._version < protocol.SINCE.get(command.name, ()):  # not in this firmware
                    hexes = "".join(f"{ord(c):02X}" for c in command.name[:2])
                    raise CommandError(command.name, 8, f"Unknown command '{command.name[:2]}:{hexes}'")
                printed = ebb_moves.check(command, self._version)
            except CommandError as exc:
                del self._rx[: cut + 1]
                self._count(text)
                self._reply(self._error(exc))
                continue
            if printed is not None:  # a refusal the command prints itself, before it waits for room
                del self._rx[: cut + 1]
                self._count(text)
                self._reply(
                    ebb_moves.printed_refusal(
                        command.name, printed, future=self.future, version=self._version
                    )
                )
                continue
            if command.queued and (
                len(self.fifo) >= self.fifo_size or (self.running and self.fifo_size == 0)
            ):
                if not self.instant:
                    return  # parsed only when there is room: the sender's bytes wait
                self._advance(self._remaining() + 1e-9)  # an instant board makes room at once
                continue
            del self._rx[: cut + 1]
            fault, code = self._count(text)
            if fault == "drop":
                self.link_dropped = True
                return
            if fault in ("reset", "unplug"):
                if self.running is not None:  # the motors stop where they are: drawn so far
                    self._complete(self.running, int((self.clock - self.running.t0) / protocol.TICK))
                self.carriage = self.true_steps().astype(float)
                self.power_cycle()
                self.link_dropped = fault == "unplug"
                return
            if fault == "interrupt":
                self.signal_due = code
            if fault == "error":
                self._reply(self._error(CommandError(command.name, 6, "Invalid parameter value")))
                continue
            if fault == "abort":  # the supply dips: the motors lose their hold and the board notices
                self.power_lost = self.threshold > 0
                self.origin = self.origin + np.array([40, -40])  # the carriage slips half a mm
            if fault == "garbage":
                self._out += _GARBAGE
            self.log.append(text)
            at = len(self.log) - 1
            try:
                reply = self._run(command)
            except CommandError as exc:  # refused by the command itself (a port letter, a QU number)
                del self.log[at]
                reply = self._error(exc)
            if fault != "silent" and reply is not None:
                self._reply(reply)

    def _count(self, text: str) -> tuple[str | None, int]:
        """Count a command received; the fault (kind, code) that strikes it, if any."""
        self._received += 1
        return self.faults.get(self._received, (None, 0))

    def _reply(self, data: bytes) -> None:
        self._out += data

    def _error(self, exc: CommandError) -> bytes:
        """A refusal's bytes; ``QU`` and ``PI`` print their name first in either syntax."""
        if exc.name in ("QU", "PI") and self._version >= (3, 0):
            return (f"{exc.name},,{exc}\n" if self.future else f"{exc.name},{exc}\r\n").encode()
        return protocol.format_error(exc, future=self.future)

    def _run(self, command: protocol.Command) -> bytes | None:
        """Answer one parsed command (queued ones join the FIFO)."""
        name, args, future = command.name, command.args, self.future
        if name == "SP":  # its pin is taken at once (absent or over 7: RB1), whatever waits in the queue
            self.servos.set_sp_pin(args[2] if len(args) > 2 else 1)
            if not command.queued:  # SP,2 / SP,3: up at once, past the queue
                self.pen_side.move_servo(True)
        if command.queued:
            self.fifo.append(command)
            if self.running is None:
                self._start(self.fifo.pop(0))
            return protocol.format_reply(name, None, future=future)
        if name in ("QG", "QS", "QB", "QP", "QM") and self.instant:
            self._advance(self._remaining() + 1e-9 if (self.running or self.fifo) else 0.0)  # see "Time"
        data = None
        handled, data = self.queries.answer(name, args, self._readings())
        if handled:
            return protocol.format_reply(name, data, future=future, old=self.old)
        if name == "RB":  # a reboot: USB drops, the board starts again
            if self.running is not None:
                self._complete(self.running, int((self.clock - self.running.t0) / protocol.TICK))
            self.carriage = self.true_steps().astype(float)
            self.power_cycle()
            self.link_dropped = True
            return None
        if name == "V":
            data = protocol.version_text(self.version)
        elif name == "QG":
            data = f"{self._status():02X}"
            self.button = self.power_lost = False
        elif name == "QS":
            data = f"{self.counters[0]},{self.counters[1]}"
        elif name == "QB":
            pressed = self.button or (self.operator == "auto" and self.running is None and not self.fifo)
            data, self.button = ("1" if pressed else "0"), False
            self.presses += pressed
        elif name == "QP":
            data = "1" if self.pen_up else "0"
        elif name == "QR":
            data = "1"
        elif name == "QM":
            data = ",".join(str(b) for b in self._qm())
        elif name == "QE":
            data = f"{self.enabled[0]},{self.enabled[1]}"
        elif name == "ES":
            data = ebb_moves.stop(self)
        elif name == "CS":
            self.origin = self.true_steps()
            self.counters[:] = 0
            self.carry = [0, 0]
        elif name in ("SC", "CU"):
            switched = self._configure(name, args, future)
            if switched is not None:
                return switched
        return protocol.format_reply(name, data, future=future, old=self.old)

    def _configure(self, name: str, args, future: bool) -> bytes | None:
        """``SC`` (servo settings) and ``CU`` (firmware settings); the reply of a syntax switch."""
        key, value = args
        if name == "SC":
            if key == 4:
                self.servo_up = value
            elif key == 5:
                self.servo_down = value
            elif key == 10:
                self.rate_up = self.rate_down = value
            elif key == 11:
                self.rate_up = value
            elif key == 12:
                self.rate_down = value
            elif key == 8:
                self.servos.slots = min(value, len(self.servos.channels))
            elif key == 9:
                self.servos.slot_ms = min(value, 6)
        elif self._version < protocol.CU_SINCE.get(key, ()):
            pass  # CU: an older firmware takes it and does nothing
        elif key == 10:
            self.future = bool(value)
            return protocol.syntax_switch_reply(bool(value), future=future)
        elif key == 4:
            self.finish()
            self.fifo_size = max(1, min(value, protocol.FIFO_MAX))
        elif key == 60:
            self.threshold = value
        return None

    @property
    def old(self) -> bool:
        """Firmware before 3.0 (2.8.1): its own number formats."""
        return self._version < (3, 0)

    def _readings(self) -> Readings:
        return Readings(
            self.old, self.supply_volts, self.microsteps, self.enabled, self.fifo_size, len(self.fifo),
            self.threshold, self.servos,
        )  # fmt: skip

    def _status(self) -> int:
        qm = self._qm()
        bits = (qm[0] << 3) | (qm[1] << 2) | (qm[2] << 1) | qm[3]
        return (
            bits
            | (protocol.QG_PEN_UP if self.pen_up else 0)
            | (protocol.QG_BUTTON if self.button else 0)
            | (protocol.QG_POWER_LOST if self.power_lost else 0)
        )

    def _qm(self) -> tuple[int, int, int, int]:
        run = self.running
        moving = run.steps != 0 if run is not None else np.zeros(2, bool)
        return int(run is not None), int(bool(moving[0])), int(bool(moving[1])), int(bool(self.fifo))
