"""What every family's machine control can do (:class:`Control`); :mod:`pencilbot.driver.control`
opens the one a profile's firmware needs, and each family fills in its commands
(:mod:`pencilbot.driver.gcode.control`, :mod:`pencilbot.driver.ebb.control`,
:mod:`pencilbot.driver.hpgl.control`)."""

from __future__ import annotations

from pencilbot.errors import PlotError
from pencilbot.machine.profile import Profile
from pencilbot.machine.profile_edit import profile_with

#: What ``pen`` does: raise, lower, the other of the two, or lower then raise.
PEN_ACTIONS = ("up", "down", "toggle", "cycle")


class Control:
    """A plotter at hand; :func:`open_control` gives the one its firmware needs.

    Methods raise :class:`PlotError` with one line when the plotter refuses or cannot.
    """

    family = ""
    pen_heights = True  # the pen's up and down are heights one can try (not a solenoid's)

    def __init__(self, profile: Profile):
        self.profile = profile
        self.firmware = profile.firmware

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _serial(self):
        """The serial port this control holds (None before it has one)."""
        return None

    def close(self) -> None:
        """Let go of the port (the plotter stays as it is)."""
        port = self._serial()
        if port is not None:
            try:
                port.close()
            except Exception:  # noqa: BLE001 - a vanished port may fail to close
                pass

    # --- the pen ---------------------------------------------------------------------------

    def pen(self, action: str) -> bool | None:
        """``up``, ``down``, ``toggle`` or ``cycle`` (down, then up); the pen as the plotter
        reports it afterwards (True: down; None: this firmware does not say)."""
        if action not in PEN_ACTIONS:
            raise PlotError(f"pen {action}: say up, down, toggle or cycle")
        if action == "toggle":
            now = self.pen_state()
            if now is None:
                raise PlotError(
                    f"{self.family} does not report where its pen is, so it cannot be toggled; "
                    "say pen up or pen down"
                )
            action = "up" if now else "down"
        if action == "cycle":
            self._set_pen(True)
            self._set_pen(False)
        else:
            self._set_pen(action == "down")
        return self.pen_state()

    def pen_state(self) -> bool | None:
        """Whether the plotter reports its pen down (None: it does not say)."""
        return None

    def try_height(self, which: str, value: float) -> bool | None:
        """Put the pen ``which`` (``up`` / ``down``) at ``value`` (the profile's unit: percent,
        S value, Z mm or degrees) for this session; the pen as reported afterwards."""
        self.profile = profile_with(self.profile, {"pen": {which: value}}, where=f"pen {which} height")
        self._pen_setup()
        self._set_pen(which == "down")
        return self.pen_state()

    def _pen_setup(self) -> None:
        """Tell the board the profile's pen (its heights), where it keeps them."""

    def _set_pen(self, down: bool) -> None:
        raise NotImplementedError

    # --- the carriage ------------------------------------------------------------------------

    def motors(self, on: bool) -> str:
        """Switch the motors off (the carriage free, to place the paper) or on; what was done."""
        raise NotImplementedError

    def walk(self, dx: float, dy: float) -> tuple[float, float] | None:
        """Move the carriage by ``dx``, ``dy`` mm at the travel speed; where it then stands (mm,
        None when the firmware does not say)."""
        raise NotImplementedError

    def home(self) -> tuple[float, float] | None:
        """Raise the pen and take the carriage home (its switches, or where it started)."""
        raise NotImplementedError
