"""pyserial URL handler ``sim://``: a serial port wired to an in-process virtual plotter, the board
the profile's firmware names (GRBL, EBB or HP-GL; this adapter only picks it and holds it by name).

Register the package once (:func:`sim.register`: whoever wants ``sim://`` ports does it; the
driver knows nothing of the simulator) and open ::

    serial.serial_for_url("sim://NAME?profile=grbl-servo-a4&baud=115200&realtime=0&faults=error@5")

URL parts (all optional):

``NAME``
    Registry key. Ports opened with the same name reach the same plotter (so a test can look
    at what a driver drew with :func:`plotter` and a sender can reconnect after a dropped
    link); without a name every open makes a fresh plotter. One port at a time: while one is
    open, another open of the name fails with ``EBUSY``, as a serial device another program
    holds does.
``profile``
    Plotter profile name or TOML path (bed, pen, motion, firmware); default
    :data:`~pencilbot.machine.profile.DEFAULT_PROFILE`. This adapter is the one place of the
    simulator that knows profile names: everything behind it takes the loaded description.
``baud``
    Emulated line speed in bit/s (10 bits per byte, both directions); ``0`` (default): no limit.
``realtime``
    ``0`` (default): instant — motion costs no wall time, the simulated clock still counts.
    ``r > 0``: the machine moves ``r`` times faster than real time (``1`` = real time), so the
    planner fills, ``ok`` waits for room and the receive buffer can overflow, as on hardware.
``tick``
    ``0`` (default): off. ``t > 0``: the line clock, for tests that must not depend on the host's
    speed: each line the board answers lets ``t`` simulated seconds pass, a status query that
    comes with no line since the last one lets 0.2 s pass (a sender waiting for the end), and a
    line that waits for the machine (planner room, a dwell) runs on until it is answered. The
    wall clock plays no part, so a fault at a line finds the machine at the same place, mid-move,
    every run. On an HP-GL plotter, the poll clock: ``t`` seconds per ``ESC.B`` it answers.
``faults``
    Comma-separated ``KIND@LINE[:CODE]`` (``hold`` and ``interrupt`` also ``KIND@SECONDSs``, a
    moment of the simulated clock, on GRBL-protocol boards), see :class:`sim.faults.Faults`.
``reset``
    ``1`` (default): opening the port resets the board like an Arduino's DTR line does (a
    power-up: banner, motion stopped, modes reset; see ``power``). ``0``: a board without
    auto-reset.
``power``
    What a power-up (DTR reset on open, the ``reset`` fault) does to the position. ``zero``: the
    controller counts from 0, 0, 0 again wherever the carriage stands and forgets any alarm,
    as a real GRBL board does (default). ``keep``: position and alarm lock survive, a forgiving
    board.
``abort``
    What a reset in motion (``ALARM:3``) or a hard-limit alarm does. ``lose``: the motors stop
    dead and the carriage coasts on (v²/2a), so the reported position is no longer where the
    pen is, as on a real board (default); ``keep``: the position stays true.
``limits``
    ``profile`` (default): the profile's own settings (GRBL's factory defaults: no homing, no soft limits,
    unless ``[bed] homing`` / ``soft_limits`` say so) in a standard build, which powers up in
    Alarm when homing is on. ``bed``: homing and soft limits on at the bed's
    edges, in a build without HOMING_INIT_LOCK (``$I`` shows ``OPT:VL``), so the board trusts
    the position it powers up with.

``xonxoff``
    ``1``: an HP-GL plotter sends XOFF / XON as its buffer fills and empties (default ``0``).
    A profile whose firmware names a ``sim_board`` (HP-GL) gets that board
    (:mod:`sim.hpgl.plotter`) instead of the GRBL one.
``firmware``
    An EBB board's firmware version (default 3.0.3; ``2.8.1``: no ``QU``, ``CU,4`` does nothing,
    the FIFO stays one deep).
``operator``
    ``none`` (default): an ``M0`` pause holds until the host sends ``~``, as on a real board.
    ``auto``: a virtual person at the plotter presses cycle start as soon as the machine stops at
    an ``M0`` (the pen change of a colour job done at once), for previews such as ``simulate``.

``port.plotter`` is the board behind an open port (a :class:`~sim.wires.WiredBoard`: GRBL's
:class:`~sim.gcode.plotter.VirtualPlotter`, :class:`~sim.ebb.plotter.VirtualEbb` or
:class:`~sim.hpgl.plotter.HpglPlotter`).
"""

from __future__ import annotations

import errno
import math
import time
import urllib.parse

from serial.serialutil import PortNotOpenError, SerialBase, SerialException, Timeout

from pencilbot.machine.profile import DEFAULT_PROFILE, Profile, load_profile
from sim.ebb.plotter import VirtualEbb
from sim.faults import Faults
from sim.gcode.plotter import DEFAULT_BOARD, VirtualPlotter
from sim.hpgl.plotter import HpglPlotter
from sim.wires import WiredBoard, check_simulated

_OPTIONS = (
    "profile",
    "baud",
    "realtime",
    "tick",
    "faults",
    "reset",
    "power",
    "abort",
    "limits",
    "operator",
    "xonxoff",
    "firmware",
)
_OPERATORS = ("none", "auto")
_CHOICES = {"power": ("zero", "keep"), "abort": ("lose", "keep"), "limits": ("profile", "bed")}
_PLOTTERS: dict[str, WiredBoard] = {}
_OPEN: set[str] = set()  # names with a port open now: a second open is refused, as a busy device's
_SLICE = 0.001  # s between polls while a read waits


def simulated_profile(name_or_path: str) -> Profile:
    """Load a plotter profile the virtual plotter can play (GRBL's realtime protocol).

    Raises
    ------
    ProfileError
        Unknown or invalid profile, or one for firmware the simulator does not speak.
    """
    profile = load_profile(name_or_path)
    check_simulated(profile)
    return profile


def plotter(name: str) -> WiredBoard:
    """The plotter a ``sim://NAME`` port reaches (``KeyError`` if none was opened)."""
    return _PLOTTERS[name]


def forget(name: str) -> None:
    """Remove ``name`` from the registry (the next ``sim://NAME`` gets a fresh plotter)."""
    _PLOTTERS.pop(name, None)


def parse_url(url: str) -> tuple[str, dict[str, str]]:
    """``(name, options)`` from a ``sim://`` URL; ``SerialException`` says what is wrong."""
    parts = urllib.parse.urlsplit(url)
    if parts.scheme != "sim":
        raise SerialException(f"expected a sim:// URL, got {url!r}")
    options = {}
    for key, values in urllib.parse.parse_qs(parts.query, keep_blank_values=True).items():
        if key not in _OPTIONS:
            raise SerialException(f"unknown sim:// option {key!r}; use {', '.join(_OPTIONS)}")
        options[key] = values[-1]
    return parts.netloc + parts.path.strip("/"), options


def plotter_from_options(options: dict[str, str]) -> WiredBoard:
    """Build a plotter from URL / command-line options (strings)."""
    try:
        baud = int(options.get("baud", 0))
        realtime = float(options.get("realtime", 0))
        tick = float(options.get("tick", 0))
        faults = Faults.parse(options.get("faults", ""))
    except ValueError as exc:
        raise SerialException(f"bad sim:// option: {exc}") from None
    if baud < 0 or not 0 <= realtime < math.inf or not 0 <= tick < math.inf:
        raise SerialException("sim:// baud, realtime and tick must be 0 or positive (and finite)")
    board = {}
    for key, choices in _CHOICES.items():
        board[key] = options.get(key, DEFAULT_BOARD[key])
        if board[key] not in choices:
            raise SerialException(f"sim:// option {key}={board[key]!r}: use {' or '.join(choices)}")
    operator = options.get("operator", "none")
    if operator not in _OPERATORS:
        raise SerialException(f"sim:// option operator={operator!r}: use {' or '.join(_OPERATORS)}")
    profile = simulated_profile(options.get("profile", DEFAULT_PROFILE))
    if faults.timed and (profile.firmware.capabilities.host_motion or profile.firmware.sim_board == "hpgl"):
        raise SerialException(
            "sim:// faults at a moment (KIND@SECONDSs) are for GRBL-protocol boards; use KIND@LINE"
        )
    if profile.firmware.capabilities.host_motion:  # an EBB board: the firmware is chosen by the profile
        version = options.get("firmware")
        if version is not None:
            from firmware_protocol.ebb import version_tuple

            try:
                version_tuple(version)
            except ValueError as exc:
                raise SerialException(f"bad sim:// option firmware: {exc}") from None
        try:
            supply = float(options.get("supply", 9.1))
        except ValueError:
            supply = -1.0
        if not 0 <= supply <= 40:
            raise SerialException(
                "sim:// option supply: volts at the board's power jack, 0 (unplugged) to 40"
            )
        return VirtualEbb(
            profile,
            baud=baud,
            realtime=realtime,
            faults=faults,
            operator=operator,
            version=version,
            supply=supply,
        )
    if profile.firmware.sim_board == "hpgl":  # an HP-GL plotter (sim.hpgl.plotter)
        return HpglPlotter(
            profile,
            baud=baud,
            realtime=realtime,
            faults=faults,
            xonxoff=options.get("xonxoff") == "1",
            tick=tick,
        )
    return VirtualPlotter(
        profile, baud=baud, realtime=realtime, faults=faults, operator=operator, tick=tick, **board
    )


class Serial(SerialBase):
    """The pyserial port class pyserial finds for ``sim://`` URLs."""

    plotter: WiredBoard | None = None
    is_open: bool  # (SerialBase's own, declared for the type checker)

    def open(self) -> None:
        if self.is_open:
            raise SerialException("Port is already open.")
        name, options = parse_url(self.portstr)
        if name in _OPEN:
            # A board has one cable: a second sender gets what a locked serial device gives.
            raise SerialException(errno.EBUSY, f"could not open sim://{name}: it is open already")
        fresh = not name or name not in _PLOTTERS
        self.plotter = plotter_from_options(options) if fresh else _PLOTTERS[name]
        if name:
            _PLOTTERS[name] = self.plotter
            _OPEN.add(name)
        self._name = name
        firmware = self.plotter.firmware
        firmware.link_dropped = False  # plugged back in
        if not fresh and options.get("reset", "1") != "0" and getattr(firmware, "resets_on_open", True):
            firmware.power_cycle()
        self._rx = bytearray()
        self.is_open = True

    def close(self) -> None:
        if self.is_open and self._name:
            _OPEN.discard(self._name)
        self.is_open = False

    def _reconfigure_port(self) -> None:
        """Line settings mean nothing to a virtual wire."""

    def _check(self) -> WiredBoard:
        plotter = self.plotter
        if not self.is_open or plotter is None:
            raise PortNotOpenError()
        if plotter.firmware.link_dropped:
            raise SerialException("device reports readiness to read but returned no data (link dropped)")
        return plotter

    def _pump(self) -> None:
        self._rx += self._check().read()

    @property
    def in_waiting(self) -> int:
        self._pump()
        return len(self._rx)

    def read(self, size: int = 1) -> bytes:
        timeout = Timeout(self._timeout)
        while True:
            self._pump()
            if len(self._rx) >= size or timeout.expired():
                break
            time.sleep(_SLICE)
        data = bytes(self._rx[:size])
        del self._rx[:size]
        return data

    def write(self, data) -> int:
        self._check().write(bytes(data))
        return len(data)

    def reset_input_buffer(self) -> None:
        self._pump()
        self._rx.clear()

    def reset_output_buffer(self) -> None:
        self._check()

    def send_break(self, duration: float = 0.25) -> None:
        self._check()

    def _update_break_state(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    @property
    def cts(self) -> bool:
        return True

    @property
    def dsr(self) -> bool:
        return True

    @property
    def ri(self) -> bool:
        return False

    @property
    def cd(self) -> bool:
        return True
