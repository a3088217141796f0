"""What every firmware module of the registry declares.

A firmware is described, not subclassed at the call sites: the G-code writer, the driver and the
virtual plotter ask the registry's entry for a profile (``profile.firmware``) what they need —
framing and validation of lines, what a reply means, the receive budget, capabilities, dwell
units — and never compare firmware names. Adding a firmware is one module here plus a profile.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Any

from firmware_protocol import ProtocolError

#: Serial speed (bit/s) of a board whose firmware says nothing else: GRBL's and most USB boards'.
DEFAULT_BAUD = 115200

#: What a reply from the board means to a sender.
OK = "ok"  # a line was taken (GRBL: parsed and queued; Marlin: executed)
ERROR = "error"  # a line was refused (``detail`` says why)
ALARM = "alarm"  # the machine stopped and locks motion until reset / unlock
RESET = "reset"  # a start-up banner: the board has just (re)booted
RESEND = "resend"  # the board lost a line (noise): send again from ``number``
BUSY = "busy"  # a keep-alive while a long command runs
STATUS = "status"  # a realtime status report (``status``)
OTHER = "other"  # anything else: logged and ignored


@dataclass(frozen=True)
class Reply:
    """One line from the board, classified.

    Attributes
    ----------
    kind : str
        One of :data:`OK`, :data:`ERROR`, :data:`ALARM`, :data:`RESET`, :data:`RESEND`,
        :data:`BUSY`, :data:`STATUS`, :data:`OTHER`.
    text : str
        The line as received.
    detail : str
        For errors and alarms, the code and its meaning in words; for a reset, the version.
    number : int or None
        The line number a resend asks for, or the one an ``ok`` acknowledges (Marlin's
        ADVANCED_OK ``N``).
    free : int or None
        Free slots of the board's command buffer after an ``ok`` (Marlin's ADVANCED_OK ``B``).
    status : object or None
        A status report: ``state``, ``substate``, ``mpos``, ``wpos``, ``wco`` (mm) attributes.
    """

    kind: str
    text: str = ""
    detail: str = ""
    number: int | None = None
    free: int | None = None
    status: Any = None  # grbl.Status or an HP-GL answer: read by attribute


@dataclass(frozen=True)
class Capabilities:
    """What a firmware can do beyond taking lines.

    Attributes
    ----------
    status_reports : bool
        Answers the realtime ``?`` with a position report at any time.
    feed_hold : bool
        Stops motion on a realtime feed hold (``!``) and resumes on ``~``.
    soft_reset : bool
        Resets on a realtime byte (0x18), dropping queued motion.
    check_mode : bool
        Has a mode that parses lines without moving (GRBL ``$C``).
    unlock : bool
        Leaves alarm lock on a command (GRBL ``$X``).
    line_numbers : bool
        Takes ``N<n> … *<checksum>`` lines and asks for lost ones again.
    realtime_protocol : bool
        Speaks GRBL's realtime protocol (``?`` ``!`` ``~`` 0x18, ``<…>`` reports): what the
        virtual plotter emulates.
    host_motion : bool
        Takes no G-code: the host plans every move and sends the board step commands (EBB);
        the driver translates a job's pen-down and pen-up moves for it.
    """

    status_reports: bool = False
    feed_hold: bool = False
    soft_reset: bool = False
    check_mode: bool = False
    unlock: bool = False
    line_numbers: bool = False
    realtime_protocol: bool = False
    host_motion: bool = False


class Firmware:
    """A firmware's facts and rules; the registry holds one instance per firmware.

    Attributes
    ----------
    name : str
        Registry key, as a profile's ``dialect`` names it.
    title : str
        The firmware's name in messages ("GRBL", "Marlin").
    protocol : module
        Its message grammar in :mod:`firmware_protocol`.
    capabilities : Capabilities
    receive_buffer : int
        Bytes of the board's serial receive buffer: the default receive budget.
    planner_blocks : int
        Moves the board can hold planned and not yet run, the one running included (GRBL's
        ``BLOCK_BUFFER_SIZE − 1``). With the receive buffer it bounds how far before the last
        line sent the machine can be when it stops (:meth:`moves_in_flight`).
    line_limit : int
        Most characters of one line the board takes (what counts is the firmware's rule).
    dwell_units : float
        ``G4 P`` units per second: 1 (seconds) or 1000 (milliseconds).
    rapids_take_feed : bool
        Whether ``G0`` moves at the modal ``F`` (Marlin) or at each axis's top rate, ignoring
        ``F`` (GRBL).
    idle_lock : float
        Seconds the board stands still, doing nothing else, each time the motion comes to rest
        with nothing queued (GRBL 1.1 waits out its stepper idle lock, ``$1`` ms, inside the
        stepper interrupt before it counts the motion as ended); 0 for boards that do not.
    errors_then_ok : bool
        Whether a refused line gets ``Error:…`` followed by the line's ``ok`` (Marlin) instead of
        an error in place of the ``ok`` (GRBL).
    frame_room : int
        Characters line numbering adds to a line in a file (0 without line numbers).
    wake_bytes : bytes
        What a sender writes to a board it has just opened.
    status_query, feed_hold, cycle_start, soft_reset : bytes
        Realtime bytes (empty when the firmware has none).
    unlock_command, check_command, drain_command : str
        Lines for leaving alarm lock, toggling check mode, and waiting for the queued moves to
        finish ("" when the firmware has none; without a drain command a sender waits for an
        idle status report).
    baud : int
        Serial speed (bit/s) the board's firmware is built for, the default of ``draw --baud``.
    program_language : str
        What a program for this firmware is written in: ``"gcode"`` (GRBL, grblHAL, Marlin, and
        EBB boards, whose G-code the host translates) or ``"hpgl"``. Exporters, ``stat``,
        ``simulate`` and ``demo`` ask it; nothing compares firmware names.
    flow : str
        How a sender paces the board: ``"acknowledged"`` (an answer per line, a receive budget)
        or ``"polled"`` (no answers: the sender polls the free buffer, HP-GL's ``ESC.B``).
    sim_board : str
        Which board the virtual plotter plays for it besides GRBL's and the EBB (``"hpgl"``), or ``""``.
    """

    name: str
    title: str
    protocol: ModuleType
    capabilities: Capabilities
    receive_buffer: int
    line_limit: int
    planner_blocks: int = 16
    dwell_units: float = 1.0
    rapids_take_feed: bool = False
    idle_lock: float = 0.0
    errors_then_ok: bool = False
    frame_room: int = 0
    wake_bytes: bytes = b"\n"
    status_query: bytes = b""
    feed_hold: bytes = b""
    cycle_start: bytes = b""
    soft_reset: bytes = b""
    unlock_command: str = ""
    check_command: str = ""
    drain_command: str = ""
    baud: int = DEFAULT_BAUD
    program_language: str = "gcode"
    flow: str = "acknowledged"
    sim_board: str = ""

    def moves_in_flight(self) -> int:
        """Most moves of lines the board has answered that may not have run yet: the planned
        ones, and one more whose end the stepper's segment buffer may still be running after
        the planner let it go."""
        return self.planner_blocks + 1

    # --- re-establishing a position (what a resume asks of the board) ------------------------

    #: The line that homes the machine on its switches ("" when the firmware has none).
    home_command: str = ""

    def set_origin(self, x: float, y: float, z: str = "") -> str:
        """The line that makes the machine's present position read ``x``, ``y`` (mm) in the work
        coordinates the job uses (``z``: the Z word to set too, already formatted); "" when the
        firmware cannot."""
        return ""

    def jog(self, dx: float, dy: float, feed: float) -> str:
        """The line that moves the carriage by ``dx``, ``dy`` mm at ``feed`` mm/min without
        touching the job's modal state ("" when the firmware has no such command)."""
        return ""

    # --- at the plotter (pencilbot.driver.control) -------------------------------------------

    #: Lines that switch the stepper motors off (the carriage moves freely) and on again ("" when
    #: the firmware has none: GRBL releases them by its idle delay, :attr:`idle_hold_setting`).
    motors_off_command: str = ""
    motors_on_command: str = ""
    #: The ``$`` setting whose value 255 keeps the motors on at rest and any other value releases
    #: them that many ms after each move (GRBL's step idle delay, ``$1``); None without one.
    idle_hold_setting: int | None = None

    def origin_move(self, feed: float) -> str:
        """The line that takes the carriage to machine 0, 0 (where it started, on a machine without
        homing switches) at ``feed`` mm/min ("" when the firmware cannot)."""
        return ""

    # --- writing G-code -------------------------------------------------------------------

    def dwell(self, seconds: float) -> str:
        """The ``G4`` line that waits ``seconds`` (``""`` for none), in this firmware's units."""
        value = round(seconds * self.dwell_units, 3 if self.dwell_units == 1 else 0)
        if value == 0:
            return ""
        text = f"{value:.3f}".rstrip("0").rstrip(".") if self.dwell_units == 1 else f"{value:.0f}"
        return f"G4 P{text}"

    def number_lines(self, lines: list[bytes]) -> list[bytes]:
        """A program's lines with this firmware's line numbers (only with ``line_numbers``)."""
        raise NotImplementedError(f"{self.title} has no line numbers")

    # --- sending --------------------------------------------------------------------------

    def frame(self, command: str, number: int) -> bytes:
        """The bytes that send one cleaned line (``number``: the line number, if numbered).

        Raises
        ------
        firmware_protocol.ProtocolError
            The board cannot take the line.
        """
        raise NotImplementedError

    def commands(self, cleaned: bytes) -> bytes:
        """Cleaned lines (one per line of the buffer) as this firmware's sender sends them:
        unchanged, unless the sender numbers lines itself (then numbers written in a file go)."""
        return cleaned

    def check_lines(self, job) -> tuple[int, str] | None:
        """The first line of ``job`` this firmware cannot take, and why; None if all are fine.

        ``job`` has ``len()``, ``line(i)``, ``frames`` and ``offsets`` (a
        :class:`pencilbot.driver.gcode.job.Job`). Firmware modules check the whole buffer with numpy and
        frame only the suspects; this fallback frames every line.
        """
        return self._first_refused(job, range(len(job)))

    def _first_refused(self, job, suspects, number: int | None = None) -> tuple[int, str] | None:
        """Frame each suspect line (numbered ``number``, else its position); the first refusal."""
        for index in suspects:
            text = job.frames[job.offsets[index] : job.offsets[index + 1] - 1].decode(
                "utf-8", errors="replace"
            )
            try:
                self.frame(text, index + 1 if number is None else number)
            except ProtocolError as exc:
                return index, str(exc)
        return None

    # --- system commands in a file (GRBL's ``$`` lines) ------------------------------------

    def system_command(self, line: str) -> str | None:
        """The name of the system command on cleaned ``line`` (a command that changes the board,
        not the drawing: settings, modes, stored blocks), None for any other line."""
        return None

    def system_effect(self, name: str) -> tuple[str, str | None, bool]:
        """What system command ``name`` does (words that follow "it"), what the board does after
        it instead of running the rest of a job (None: it goes on), and whether it is check mode
        (nothing after it is drawn)."""
        return "changes the board", None, False

    def waits_after(self, line: str) -> bool:
        """Whether the board takes no more lines until cleaned ``line`` has finished moving (GRBL
        refuses G-code while it jogs or homes: error:9)."""
        return False

    def system_covers(self, allowed: str, name: str) -> bool:
        """Whether a name the user allowed covers system command ``name``."""
        return allowed == name

    def renumber(self) -> tuple[str, int] | None:
        """The command (and its number) that restarts line numbering, or None."""
        return None

    def parse(self, text: str) -> Reply:
        """What one received line means."""
        raise NotImplementedError

    # --- status reports (firmware with ``status_reports``) ----------------------------------

    def is_moving(self, status) -> bool:
        """The machine is running a cycle, jogging or homing."""
        return False

    def is_finished(self, status) -> bool:
        """The machine has nothing left to do: the end of a job."""
        return False

    def is_paused(self, status) -> bool:
        """Held (feed hold, safety door, tool change): queued lines do not run."""
        return False

    def is_alarm(self, status) -> bool:
        """In alarm lock."""
        return False

    def is_at_rest(self, status) -> bool:
        """Not moving, so the reported position is where the pen stands (e.g. a completed hold)."""
        return False
