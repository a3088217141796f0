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

from dataclasses import dataclass

from firmware_protocol import ebb as protocol
from firmware_protocol.ebb import CommandError
from sim.ebb.servo import Servos

RA0_COUNTS = 394  # the motor-current pot's voltage (the reference's example: 0.72 A)
PORTS = "ABCDE"
SL_SIZE = 32
#: MS1, MS2, MS3 of the A4988 drivers per microstepping (16x .. full step).
_MICROSTEP_PINS = {16: (1, 1, 1), 8: (1, 1, 0), 4: (0, 1, 0), 2: (1, 0, 0), 1: (0, 0, 0)}


def supply_counts(volts: float) -> int:
    """V+ as the board's ADC reads it: the supply less a 0.3 V diode drop, divided by 9.2."""
    return max(0, min(1023, int(round(max(volts - 0.3, 0.0) / 9.2 / 3.3 * 1023))))


@dataclass(frozen=True)
class Readings:
    """What the board's other parts say that these commands report: the firmware's number style
    (``old``: 2.8.1), the supply, the motors, the FIFO and the power threshold."""

    old: bool
    supply_volts: float
    microsteps: int
    enabled: tuple[int, int]
    fifo_size: int
    fifo_len: int
    threshold: int
    servos: Servos  # (``SR`` switches its power)


class Queries:
    """The board's commands beyond motion and the state they keep: RAM (``SL``/``QL``), the node
    counter, the port latches, the name in flash (kept through a reboot) and the servo's power
    timeout; the board holds one and asks it with its :class:`Readings`."""

    def __init__(self) -> None:
        self.nickname = ""  # ST / QT: kept in flash through reboots
        self.reset()

    def reset(self) -> None:
        """What a reboot clears (the name in flash stays)."""
        self.sl = [0] * SL_SIZE
        self.nodes = 0
        self.latches = dict.fromkeys(PORTS, 0)
        self.servo_timeout_ms = 60_000

    def answer(self, name: str, args: tuple, board: Readings) -> tuple[bool, str | None]:
        """``(handled, data)`` for the commands of this module; raises CommandError as the board refuses."""
        old = board.old
        if name == "QC":
            a, b = RA0_COUNTS, supply_counts(board.supply_volts)
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
            return True, self._pins(name, args, board)
        if name == "QR":
            return True, "1" if board.servos.powered else "0"
        if name == "SR":
            self.servo_timeout_ms = args[0]
            if len(args) > 1:
                board.servos.powered = bool(args[1])
            return True, None
        if name == "ST":
            self.nickname = args[0] if args else ""
            return True, None
        if name == "QT":
            shown = self.nickname if self.nickname and 32 < ord(self.nickname[0]) < 128 else ""
            return True, shown
        if name == "QU":
            return True, self._qu(args[0], board)
        return False, None

    def _pins(self, name: str, args: tuple, board: Readings) -> str | None:
        port, pin = args[0], args[1]
        if pin > 7 or port not in PORTS or (name == "PO" and args[2] > 1):
            raise CommandError(name, 6, "Invalid parameter value")
        if name == "PI":
            driven = _driver_pins(board)
            return str(driven[(port, pin)] if (port, pin) in driven else (self.latches[port] >> pin) & 1)
        if name == "PO":
            bit = 1 << pin
            self.latches[port] = (self.latches[port] | bit) if args[2] else (self.latches[port] & ~bit)
        return None

    def _qu(self, number: int, board: Readings) -> str:
        values = {
            1: "00",
            2: str(protocol.FIFO_MAX),
            3: str(board.fifo_size),
            4: "000",
            5: "000",
            6: str(board.fifo_len),
            60: str(board.threshold),
            61: "0",
            200: "0,0",
        }
        if number not in values:
            raise CommandError("QU", 6, "Invalid parameter value")
        return values[number]


def _driver_pins(board: Readings) -> dict[tuple[str, int], int]:
    """The pins the firmware drives for the stepper drivers (EBB v1.3+): the enables, low
    when a motor is on (RE0, RC1), and the microstep selects MS1..3 (RE2, RE1, RA6)."""
    ms = _MICROSTEP_PINS.get(board.microsteps, (1, 1, 1))
    return {
        ("E", 0): int(not board.enabled[0]),
        ("C", 1): int(not board.enabled[1]),
        ("E", 2): ms[0],
        ("E", 1): ms[1],
        ("A", 6): ms[2],
    }
