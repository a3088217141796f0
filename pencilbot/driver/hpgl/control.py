"""At an HP-GL plotter (HP 7475A, 7470A, …): the pen by ``PU;``/``PD;`` read back from ``OA;``,
walks by ``PR``, home by ``PA0,0``. Its pen is lifted by a solenoid (no heights) and it has no
command that releases its motors. See :mod:`pencilbot.driver.control`."""

from __future__ import annotations

import serial

from pencilbot.driver.control_base import Control
from pencilbot.driver.hpgl.link import Answers, Lost
from pencilbot.driver.port import open_port
from pencilbot.errors import PlotError
from pencilbot.firmware.hpgl import Hpgl

#: The carousel slot a pen is taken from when the plotter holds none and is asked to lower one.
DEFAULT_SLOT = 1


class HpglControl(Control):
    """An HP-GL plotter's pen and carriage."""

    family = "HP-GL"
    pen_heights = False
    firmware: Hpgl

    def __init__(self, profile, port: str, name: str, baud: int, timeout: float):
        super().__init__(profile)
        self.timeout, self.name = timeout, port
        self.link = Answers(open_port(port, baudrate=baud, profile=name), self.firmware.parse_position)
        try:
            self.link.port.reset_input_buffer()
            self.link.write(self.firmware.wake_bytes)
            if self.link.wait(lambda t: t if t.strip().lstrip("-").isdigit() else None, timeout) is None:
                raise PlotError(
                    f"no answer from an HP-GL plotter on {port} (ESC.E): is it on, at {baud} bit/s, "
                    "on a null-modem cable?"
                )
        except (Lost, serial.SerialException, OSError) as exc:
            self.close()
            raise PlotError(f"the port {port} was lost ({exc})") from None
        except BaseException:
            self.close()
            raise

    def _serial(self):
        return getattr(getattr(self, "link", None), "port", None)

    def _send(self, data: bytes) -> tuple[int, int, bool]:
        """Send instructions and wait until they ran: the pen's ``(x, y, down)`` after them."""
        try:
            self.link.positions.clear()
            self.link.write(data + self.firmware.sync_command)
            where = self.link.position(self.firmware, self.timeout)
        except Lost as exc:
            raise PlotError(f"the port {self.name} was lost ({exc})") from None
        if where is None:
            raise PlotError(f"the HP-GL plotter on {self.name} did not answer OA; within {self.timeout:g} s")
        return where

    def _set_pen(self, down: bool) -> None:
        if not down:
            self._send(b"PU;")
            return
        # No pen in the holder: take one from the carousel.
        if not self._send(b"PD;")[2] and not self._send(f"SP{DEFAULT_SLOT};PD;".encode())[2]:
            raise PlotError(f"the plotter lowered no pen: put a pen in carousel slot {DEFAULT_SLOT}")

    def pen_state(self) -> bool:
        """From the pen flag of ``OA;``."""
        return bool(self._send(b"")[2])

    def try_height(self, which: str, value: float) -> bool | None:
        raise PlotError(
            "an HP-GL plotter's pen is lowered by a solenoid: it has no height to try "
            "(pen force, if any, is set on the plotter)"
        )

    def motors(self, on: bool) -> str:
        raise PlotError(
            "an HP-GL plotter has no command that switches its motors off or on; lift the pen "
            "(pencilbot pen up) and load the paper with the plotter's own paper lever and keys"
        )

    def _mm(self, where) -> tuple[float, float]:
        unit = self.profile.paper.unit_mm  # mm per plotter unit
        return round(where[0] * unit, 4), round(where[1] * unit, 4)

    def walk(self, dx: float, dy: float) -> tuple[float, float]:
        unit = self.profile.paper.unit_mm
        before = self._send(b"")
        ux, uy = round(dx / unit), round(dy / unit)
        after = self._send(f"PR{ux},{uy};PA;".encode())
        if (after[0], after[1]) != (before[0] + ux, before[1] + uy):
            raise PlotError(
                f"the plotter did not walk X{dx:g} Y{dy:g} mm from X{before[0] * unit:g} "
                f"Y{before[1] * unit:g}: past its hard-clip limits; it stands where it was"
            )
        return self._mm(after)

    def home(self) -> tuple[float, float]:
        return self._mm(self._send(b"PU;PA0,0;"))
