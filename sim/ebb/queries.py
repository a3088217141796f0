"""The virtual EBB's immediate commands beyond motion (:mod:`sim.ebb.board`), as firmware 3.0.3
(``UBW.c``, ``ebb.c``) and 2.8.1 answer them.

``QC`` (the current pot and the supply, raw 10-bit ADC counts: 3.0.3 prints them as they are,
2.8.1 with ``%04i``; the V+ net is the supply less a 0.3 V diode drop through a 1/9.2 divider,
3.3 V = 1023); ``SL``/``QL`` (32 bytes of RAM, ``SL``'s index over 31 is 31; 2.8.1 has one byte,
printed ``%03i``); ``SN``/``QN``/``NI``/``ND`` (the node counter; 2.8.1 prints ``%010lu``);
``PI``/``PO``/``PD`` (ports A to E, pins 0..7: ``!6`` otherwise; ``PI`` answers ``PI,v`` with
no OK); ``QR``/``SR`` (the servo's power); ``ST``/``QT`` (the name in flash, 16 characters,
kept through a reboot); ``QU`` (1, 2, 3, 4, 5, 6, 60, 61, 200; any other number ``!6``).
"""

from __future__ import annotations

from firmware_protocol import ebb as protocol
from firmware_protocol.ebb import CommandError

RA0_COUNTS = 394  # the motor-current pot's voltage (the reference's example: 0.72 A)
PORTS = "ABCDE"
SL_SIZE = 32
#: MS1, MS2, MS3 of the A4988 drivers per microstepping (16x .. full step).
_MICROSTEP_PINS = {16: (1, 1, 1), 8: (1, 1, 0), 4: (0, 1, 0), 2: (1, 0, 0), 1: (0, 0, 0)}


def supply_counts(volts: float) -> int:
    """V+ as the board's ADC reads it: the supply less a 0.3 V diode drop, divided by 9.2."""
    return max(0, min(1023, int(round(max(volts - 0.3, 0.0) / 9.2 / 3.3 * 1023))))


class Queries:
    """Mixin of :class:`sim.ebb.board.EbbBoard`: the state these commands keep and their answers."""

    supply_volts: float
    _version: tuple[int, ...]
    nickname: str

    def reset_io(self) -> None:
        """What a reboot clears (the name in flash stays)."""
        self.sl = [0] * SL_SIZE
        self.nodes = 0
        self.latches = dict.fromkeys(PORTS, 0)
        self.servo_timeout_ms = 60_000

    @property
    def old(self) -> bool:
        """Firmware before 3.0 (2.8.1): its own number formats."""
        return self._version < (3, 0)

    def answer_query(self, name: str, args: tuple) -> tuple[bool, str | None]:
        """``(handled, data)`` for the commands of this module; raises CommandError as the board refuses."""
        old = self.old
        if name == "QC":
            a, b = RA0_COUNTS, supply_counts(self.supply_volts)
            return True, f"{a:04d},{b:04d}" if old else f"{a},{b}"
        if name == "SL":
            if old and len(args) > 1:
                raise CommandError(name, 7, "Extra parameter")
            self.sl[min(args[1] if len(args) > 1 else 0, SL_SIZE - 1)] = args[0]
            return True, None
        if name == "QL":
            if old and args:
                raise CommandError(name, 7, "Extra parameter")
            value = self.sl[min(args[0] if args else 0, SL_SIZE - 1)]
            return True, f"{value:03d}" if old else str(value)
        if name == "SN":
            self.nodes = args[0]
            return True, None
        if name == "NI":
            self.nodes += self.nodes < 0xFFFFFFFE
            return True, None
        if name == "ND":
            self.nodes -= self.nodes > 0
            return True, None
        if name == "QN":
            return True, f"{self.nodes:010d}" if old else str(self.nodes)
        if name in ("PI", "PO", "PD"):
            return True, self._pins(name, args)
        if name == "QR":
            return True, "1" if self.servos.powered else "0"
        if name == "SR":
            self.servo_timeout_ms = args[0]
            if len(args) > 1:
                self.servos.powered = bool(args[1])
            return True, None
        if name == "ST":
            self.nickname = args[0] if args else ""
            return True, None
        if name == "QT":
            shown = self.nickname if self.nickname and 32 < ord(self.nickname[0]) < 128 else ""
            return True, shown
        if name == "QU":
            return True, self._qu(args[0])
        return False, None

    def _pins(self, name: str, args: tuple) -> str | None:
        port, pin = args[0], args[1]
        if pin > 7 or port not in PORTS or (name == "PO" and args[2] > 1):
            raise CommandError(name, 6, "Invalid parameter value")
        if name == "PI":
            driven = self._driver_pins()
            return str(driven[(port, pin)] if (port, pin) in driven else (self.latches[port] >> pin) & 1)
        if name == "PO":
            bit = 1 << pin
            self.latches[port] = (self.latches[port] | bit) if args[2] else (self.latches[port] & ~bit)
        return None

    def _driver_pins(self) -> dict[tuple[str, int], int]:
        """The pins the firmware drives for the stepper drivers (EBB v1.3+): the enables, low
        when a motor is on (RE0, RC1), and the microstep selects MS1..3 (RE2, RE1, RA6)."""
        ms = _MICROSTEP_PINS.get(self.microsteps, (1, 1, 1))
        return {
            ("E", 0): int(not self.enabled[0]),
            ("C", 1): int(not self.enabled[1]),
            ("E", 2): ms[0],
            ("E", 1): ms[1],
            ("A", 6): ms[2],
        }

    def _qu(self, number: int) -> str:
        values = {
            1: "00",
            2: str(protocol.FIFO_MAX),
            3: str(self.fifo_size),
            4: "000",
            5: "000",
            6: str(len(self.fifo)),
            60: str(self.threshold),
            61: "0",
            200: "0,0",
        }
        if number not in values:
            raise CommandError("QU", 6, "Invalid parameter value")
        return values[number]
