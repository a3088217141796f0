"""The EiBotBoard (EBB): AxiDraw, NextDraw, EBB-compatible iDraw. The host plans the motion.

The board takes no G-code: it runs step commands (``LM`` constant-acceleration moves, ``SM``/
``XM`` constant-rate moves, ``HM`` home), servo moves (``SP``) and queries (``QG`` status byte,
``QS`` step counters). A sender keeps its motion commands in flight: the one running, those in
the FIFO (one deep at boot; ``CU,4`` deepens it on firmware 3.x, up to ``QU,2``) and the one the
board is parsing, which it answers only when the FIFO has room; send-and-wait therefore never
starves the motors as long as the queue outlasts a reply's round trip. What ran is read back
exactly: ``ES`` stops and flushes, then ``QS`` gives the motors' step counters. ``SM,ms,0,0`` is
a timed wait in the queue (a ``G4``). ``QG`` bit 6 says the supply dropped (with ``CU,60`` set),
after which the counters no longer tell where the pen is.

The machine's geometry (:class:`EbbSetup`, a profile's ``[ebb]`` table): a mixed-axis (CoreXY)
machine moves motor 1 by ``k·(x + y)`` and motor 2 by ``k·(x − y)`` steps, ``k`` the steps per mm
along X (AxiDraw: 2032 steps per inch at 16× microstepping, exactly 80 per mm; 2874 per inch
along the motors' own diagonal axes, as the maker's ``axidraw_conf.py`` says).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firmware_protocol import ebb as protocol
from pencilbot.firmware.base import OK, OTHER, Capabilities, Firmware, Reply

#: Microstepping of ``EM`` mode 1..5 (1/16 down to full steps).
MICROSTEPS = {1: 16, 2: 8, 3: 4, 4: 2, 5: 1}


@dataclass(frozen=True)
class EbbSetup:
    """A profile's ``[ebb]`` table: how the board's steps and servo map to the machine.

    Attributes
    ----------
    kinematics : {"corexy", "xy"}
        ``corexy``: mixed axes (AxiDraw, NextDraw, iDraw); ``xy``: motor 1 is X, motor 2 is Y.
    steps_per_mm : float
        Motor steps per mm of X travel at ``microstep_mode`` (AxiDraw 16×: 80).
    microstep_mode : int
        ``EM`` value, 1 (1/16 step) .. 5 (full step).
    servo_min, servo_max : int
        Servo positions (83.3 ns units) of pen height 0 % and 100 % (the pen's ``up``/``down``
        are percentages of this range, as AxiDraw's ``pen_pos_up``/``pen_pos_down``).
    servo_rate_up, servo_rate_down : int
        ``SC,11``/``SC,12``: servo position units per PWM period while raising / lowering (0: at
        once); the period is 3 ms per channel running: 24 ms with 8, 3 ms with 1.
    servo_pin : int
        Port B pin of the pen-lift servo: 1 (RB1, the standard servo), 2 (RB2: the narrow-band
        brushless servo of the NextDraw 8511 and AxiDraw's penlift 3). ``SP`` names it when not 1.
    servo_channels : int
        ``SC,8``: servo channels the board runs; 8 (a 24 ms period, the default) or 1 (a 3 ms
        period, which the narrow-band servo needs; AxiDraw's pen_handling.py sends ``SC,8,1``).
    min_move_ms : float
        The shortest move the board runs back to back without a gap (LM: 4 ms on firmware 3.x).
    """

    kinematics: str = "corexy"
    steps_per_mm: float = 80.0
    microstep_mode: int = 1
    servo_min: int = 9855
    servo_max: int = 27831
    servo_rate_up: int = 1618
    servo_rate_down: int = 1079
    min_move_ms: float = 4.0
    servo_pin: int = 1
    servo_channels: int = 8

    def pen_command(self, up: bool, ms: int) -> str:
        """``SP`` raising or lowering the pen and holding the queue ``ms``, on the servo's pin."""
        text = f"SP,{1 if up else 0},{int(ms)}"
        return text if self.servo_pin == 1 else f"{text},{self.servo_pin}"

    def servo_position(self, percent: float) -> int:
        """The servo position (83.3 ns units) of a pen height in percent."""
        return int(round(self.servo_min + percent / 100.0 * (self.servo_max - self.servo_min)))

    def to_motor(self, xy: np.ndarray) -> np.ndarray:
        """Machine mm ``(N, 2)`` → motor positions in (fractional) steps ``(N, 2)``."""
        xy = np.asarray(xy, dtype=np.float64)
        k = self.steps_per_mm
        if self.kinematics == "corexy":
            return np.column_stack([k * (xy[:, 0] + xy[:, 1]), k * (xy[:, 0] - xy[:, 1])])
        return k * xy

    def motor_of(self, x: float, y: float) -> tuple[float, float]:
        """:meth:`to_motor` of one point (plain floats, for a planner's inner loop)."""
        k = self.steps_per_mm
        return (k * (x + y), k * (x - y)) if self.kinematics == "corexy" else (k * x, k * y)

    def to_machine(self, steps: np.ndarray) -> np.ndarray:
        """Motor step positions ``(N, 2)`` → machine mm ``(N, 2)``."""
        steps = np.asarray(steps, dtype=np.float64)
        k = self.steps_per_mm
        if self.kinematics == "corexy":
            return np.column_stack(
                [(steps[:, 0] + steps[:, 1]) / (2 * k), (steps[:, 0] - steps[:, 1]) / (2 * k)]
            )
        return steps / k

    @property
    def max_speed(self) -> float:
        """mm/s along X at the board's top step rate (25 kHz on both motors)."""
        return protocol.MAX_STEP_RATE / self.steps_per_mm


class Ebb(Firmware):
    """The EiBotBoard, firmware 2.x and 3.x, either reply syntax."""

    name = "ebb"
    title = "EBB"
    protocol = protocol
    capabilities = Capabilities(host_motion=True)
    receive_buffer = protocol.MAX_COMMAND
    line_limit = protocol.MAX_COMMAND - 1
    rapids_take_feed = True  # the host moves pen-up at the profile's travel feed
    wake_bytes = b"\r"  # ends whatever half command a previous program left
    #: The motion FIFO's depth at boot (firmware 3.x deepens it with CU,4, up to QU,2). In
    #: flight: the command running, the FIFO's, and the one being parsed (not yet answered).
    fifo_depth = 1
    home_command = "HM"

    def dwell(self, seconds: float) -> str:
        """No ``G4`` in an EBB job: the pen's wait is ``SP``'s own Duration."""
        return ""

    def frame(self, command: str, number: int = 0) -> bytes:
        """One EBB command (``NAME,arg,...``) as bytes; refused the way the board refuses it."""
        name, *args = command.split(",")
        return protocol.encode(name, *(int(a) for a in args))

    def check_lines(self, job) -> tuple[int, str] | None:
        """Any G-code is taken: the host translates its moves (nothing is sent as written)."""
        return None

    def parse(self, text: str) -> Reply:
        if text.strip() in ("OK", "CUOK"):
            return Reply(OK, text)
        return Reply(OTHER, text)


EBB = Ebb()
