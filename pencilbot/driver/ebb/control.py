"""At an EBB plotter (AxiDraw, NextDraw, iDraw): the servo pen (``SC``/``SP``, read back from
``QG``), the motors (``EM``), walks (``XM`` on a mixed-axis carriage, ``SM`` on a plain one) and
home (``HM``: where the motors were switched on). See :mod:`pencilbot.driver.control`."""

from __future__ import annotations

import math

import numpy as np

from firmware_protocol import ebb as protocol
from pencilbot.driver.control_base import Control
from pencilbot.driver.ebb.link import EbbFault, EbbLink, greet
from pencilbot.driver.port import LineReader, PortLost, open_port
from pencilbot.errors import PlotError
from pencilbot.firmware.ebb import MICROSTEPS
from pencilbot.machine.ebb_motion import pen_commands

WAIT_EXTRA = 5.0  # s beyond a command's own time for the board to report it done


class EbbControl(Control):
    """An EBB board's pen, motors and carriage."""

    family = "EBB"

    def __init__(self, profile, port: str, name: str, baud: int, timeout: float):
        super().__init__(profile)
        self.reader = LineReader(open_port(port, baudrate=baud, profile=name))
        self.link = EbbLink(self.reader, timeout)
        try:
            try:
                self.version = greet(self.link)
            except (EbbFault, PortLost) as exc:
                raise PlotError(
                    f"no answer from an EBB board on {port} ({exc}): check the port and that the plotter "
                    "is an AxiDraw, NextDraw or other EBB machine (another needs a profile for it)"
                ) from None
            self._pen_setup()
        except BaseException:
            self.close()
            raise

    def _serial(self):
        return getattr(getattr(self, "reader", None), "port", None)

    def _guard(self, call, *args):
        try:
            return call(*args)
        except (EbbFault, PortLost) as exc:
            raise PlotError(f"EBB: {exc}") from None

    def _do(self, text: str, wait: float | None = None):
        return self._guard(self.link.command, text, wait)

    def _idle(self, seconds: float) -> None:
        self._guard(self.link.wait_idle, seconds + WAIT_EXTRA)

    # --- the pen -------------------------------------------------------------------------------

    def _pen_setup(self) -> None:
        for text in pen_commands(self.profile):  # servo heights and rates: the board forgets them at boot
            self._do(text)

    def _set_pen(self, down: bool) -> None:
        pen = self.profile.pen
        ms = max(round(1000 * (pen.down_delay if down else pen.up_delay)), 1)
        self._do(self.profile.ebb.pen_command(up=not down, ms=ms))  # on the servo's own pin (the 8511: RB2)
        self._idle(ms / 1000)

    def pen_state(self) -> bool:
        """From ``QG``'s pen bit (``QP`` is deprecated since firmware 3.0)."""
        return not self._guard(self.link.status) & protocol.QG_PEN_UP

    # --- the carriage --------------------------------------------------------------------------

    def _held(self) -> bool:
        mode = MICROSTEPS[self.profile.ebb.microstep_mode]
        return [int(v) for v in self._do("QE").data.split(",")[:2]] == [mode, mode]

    def motors(self, on: bool) -> str:
        mode = self.profile.ebb.microstep_mode
        self._do(f"EM,{mode},{mode}" if on else "EM,0,0")
        self._idle(0)
        if on:
            return (
                f"motors on (EM,{mode},{mode}): the carriage holds where it stands, which is now home "
                "(walk and home count from here)"
            )
        return "motors off (EM,0,0): the carriage moves freely; push it to its home corner before a plot"

    def _position(self) -> tuple[float, float]:
        steps = np.array([self._guard(self.link.steps)], dtype=float)
        x, y = self.profile.ebb.to_machine(steps)[0]
        return round(float(x), 4), round(float(y), 4)

    def walk(self, dx: float, dy: float) -> tuple[float, float]:
        setup, bed = self.profile.ebb, self.profile.bed
        if not self._held():
            self.motors(True)  # a free carriage: switched on where it stands (home from now)
        x, y = self._position()
        if not (-1e-6 <= x + dx <= bed.width + 1e-6 and -1e-6 <= y + dy <= bed.height + 1e-6):
            raise PlotError(
                f"walking X{dx:g} Y{dy:g} mm from X{x:g} Y{y:g} (mm from home) would leave the "
                f"{bed.width:g} x {bed.height:g} mm bed; nothing moved"
            )
        a, b = round(setup.steps_per_mm * dx), round(setup.steps_per_mm * dy)
        if not (a or b):
            return x, y
        motor = (abs(a + b), abs(a - b)) if setup.kinematics == "corexy" else (abs(a), abs(b))
        speed = self.profile.motion.travel_feed / 60.0  # mm/s
        ms = max(
            math.ceil(1000 * math.hypot(dx, dy) / speed),
            math.ceil(1000 * max(motor) / protocol.MAX_STEP_RATE),
            1,
        )
        self._do(f"XM,{ms},{a},{b}" if setup.kinematics == "corexy" else f"SM,{ms},{a},{b}")
        self._idle(ms / 1000)
        return self._position()

    def home(self) -> tuple[float, float]:
        self._set_pen(False)
        rate = self.profile.motion.travel_feed / 60.0 * self.profile.ebb.steps_per_mm
        steps = self._guard(self.link.steps)
        self._do(f"HM,{int(min(max(rate, 2), protocol.MAX_STEP_RATE))}")
        self._idle(max(abs(steps[0]), abs(steps[1])) / max(rate, 2))
        return self._position()
