"""At a board that acknowledges lines (GRBL, grblHAL, Marlin): the profile's pen lines, jogs,
homing, the motors by command or by GRBL's idle-delay setting. See :mod:`pencilbot.driver.control`."""

from __future__ import annotations

from pencilbot.driver.control_base import Control
from pencilbot.driver.faults import StreamFault
from pencilbot.driver.gcode.session import BoardSession
from pencilbot.driver.port import LineReader, PortLost, open_port
from pencilbot.errors import PlotError
from pencilbot.firmware.base import ERROR, OK
from pencilbot.machine.profile import Profile

#: mm of GRBL's there-and-back nudge that lets its idle delay release the motors at once.
NUDGE = 0.05


class GcodeControl(Control):
    """GRBL, grblHAL and Marlin: the profile's pen lines, jogs, homing, the motors by setting."""

    def __init__(self, profile: Profile, port: str, name: str, baud: int, timeout: float):
        super().__init__(profile)
        self.family = self.firmware.title
        self.link = LineReader(open_port(port, baudrate=baud, profile=name))
        self.session = BoardSession(
            self.link, self.firmware, receive_buffer=profile.receive_buffer, timeout=timeout
        )
        try:
            self.session.wake()
        except BaseException:
            self.close()
            raise

    def _serial(self):
        return getattr(getattr(self, "link", None), "port", None)

    def _do(self, line: str) -> None:
        """Send one line and wait for its ``ok``; a refusal or an alarm is one line."""
        try:
            reply = self.session.command(line)
        except StreamFault as fault:
            raise PlotError(f"{self.family} stopped at {line}: {fault}") from None
        if reply.kind != OK:
            raise PlotError(f"{self.family} refused {line}: {reply.detail or reply.text}")

    def _settle(self) -> None:
        """Until what was sent has run (the pen has moved, the carriage stands)."""
        if self.firmware.drain_command:
            self._do(self.firmware.drain_command)
        else:
            try:
                self.session.wait_until_still()
            except StreamFault as fault:
                raise PlotError(f"{self.family}: {fault}") from None

    def _ask(self, line: str) -> list[str]:
        """The lines a query answers before its ``ok`` (``$G``, ``$$``)."""
        self.link.write(self.firmware.frame(line, 0))
        got: list[str] = []
        self.link.restart_silence()  # the timeout is time spent listening: a host's stall is not silence
        try:
            while self.link.silent_for() <= self.session.timeout and len(got) < 2000:  # (or a talker)
                for text in self.link.read_lines():
                    kind = self.firmware.parse(text).kind
                    if kind == OK:
                        return got
                    if kind == ERROR:
                        raise PlotError(f"{self.family} refused {line}: {text}")
                    got.append(text)
        except PortLost as exc:
            raise PlotError(f"the port was lost ({exc})") from None
        raise PlotError(f"{self.family} did not answer {line} within {self.session.timeout:g} s")

    def _set_pen(self, down: bool) -> None:
        pen = self.profile.pen_model
        for line in pen.down_lines if down else pen.up_lines:
            self._do(line)
        dwell = self.firmware.dwell(pen.down_delay if down else pen.up_delay)
        if dwell:
            self._do(dwell)
        self._settle()

    def pen_state(self) -> bool | None:
        """A Z pen from the reported Z; a spindle pen from ``$G`` (``M3``/``M5`` and ``S``)."""
        pen = self.profile.pen_model
        if not self.firmware.capabilities.status_reports or pen.kind == "servo":
            return None  # Marlin reports no pen; GRBL knows no servo (M280) it could report
        if pen.kind == "z":
            status = self.session.query_status()
            z = status.wpos[2] if status.wpos is not None else status.mpos[2] - self.session.wco[2]
            return pen.is_down(z)
        words = next((w for w in self._ask("$G") if w.startswith("[GC:")), "").strip("[]").split()
        spindle_on = any(w in ("M3", "M4") for w in words)
        speed = next((float(w[1:]) for w in words if w.startswith("S")), 0.0)
        return spindle_on and pen.is_down(speed)

    def motors(self, on: bool) -> str:
        fw = self.firmware
        line = fw.motors_on_command if on else fw.motors_off_command
        if line:
            self._do(line)
            return f"motors {'on' if on else 'off'} ({line})" + ("" if on else ": the carriage moves freely")
        if fw.idle_hold_setting is None:
            raise PlotError(f"{fw.title} has no command that switches its motors {'on' if on else 'off'}")
        key = f"${fw.idle_hold_setting}"
        current = next((w.split("=", 1)[1] for w in self._ask("$$") if w.startswith(f"{key}=")), None)
        held = current is not None and float(current) == 255
        if on:
            if not held:
                self._do(f"{key}=255")
            return (
                f"motors on: {fw.title} holds them at rest ({key}=255"
                + ("" if held else f", was {current}")
                + ")"
            )
        if held:
            self._do(f"{key}=25")  # the firmware's default idle delay
            self._move(NUDGE, 0)  # a move ending now lets the idle delay release them
            self._move(-NUDGE, 0)
            return (
                f"motors off: {fw.title} releases them 25 ms after each move ({key}=25, was 255); "
                "the carriage moves freely (pencilbot align --on holds them again)"
            )
        return f"motors off: {fw.title} releases them {current} ms after each move ({key}={current}); the carriage moves freely"

    def _move(self, dx: float, dy: float) -> None:
        fw, feed = self.firmware, self.profile.motion.travel_feed
        line = fw.jog(dx, dy, feed)
        lines = [line] if line else ["G91", f"G0X{dx:.4f}Y{dy:.4f}F{feed:g}", "G90"]  # Marlin: no jog
        for text in lines:
            self._do(text)
        self._settle()

    def walk(self, dx: float, dy: float) -> tuple[float, float] | None:
        self._move(dx, dy)
        return self._where()

    def _where(self) -> tuple[float, float] | None:
        if not self.firmware.capabilities.status_reports:
            return None
        self.session.query_status()
        return self.session.work_position()

    def home(self) -> tuple[float, float] | None:
        self._set_pen(False)
        fw = self.firmware
        line = fw.home_command if self.profile.bed.homing else fw.origin_move(self.profile.motion.travel_feed)
        if not line:
            raise PlotError(f"{fw.title} has no way to go home")
        self._do(line)
        self._settle()
        return self._where()
