"""Open a serial port by URL and read lines from it.

Every transport goes through :func:`serial.serial_for_url`, so ``/dev/ttyUSB0``, ``COM3``,
``socket://host:23``, ``rfc2217://host:port`` and the virtual plotter's ``sim://…`` are one code
path. The driver never imports the simulator: whoever wants ``sim://`` ports registers them
(:func:`sim.register`), and pyserial finds the handler by package name.
"""

from __future__ import annotations

import errno
import os
import time
from urllib.parse import quote

import serial

try:  # POSIX ttys: the kernel's exclusive mode
    import fcntl
    import termios
except ImportError:  # Windows opens a COM port exclusively by itself
    fcntl = termios = None  # type: ignore[assignment]

from pencilbot.errors import PlotError
from pencilbot.firmware.base import DEFAULT_BAUD

DEFAULT_TIMEOUT = 10.0  # s of silence from the board before a job counts as stuck
#: How long one read waits for the first byte (s): short, so status polls keep their pace.
READ_SLICE = 0.02
# What an open of a port someone else holds fails with: a lock taken (EAGAIN/EWOULDBLOCK from
# flock, pyserial's ``exclusive``), or a device opened exclusively (EBUSY, TIOCEXCL; sim://).
_BUSY = {errno.EAGAIN, errno.EWOULDBLOCK, errno.EBUSY}


class PortLost(Exception):
    """The port stopped working (unplugged, pty closed, socket dropped)."""


def sim_url(url: str, profile: str | None) -> str:
    """``url``; a ``sim://`` URL that names no profile with ``profile=`` added, so the virtual
    plotter plays the board of the profile being drawn with (GRBL, grblHAL, HP-GL or EBB)."""
    if not url.startswith("sim://") or profile is None or "profile=" in url:
        return url
    return f"{url}{'&' if '?' in url else '?'}profile={quote(str(profile), safe='')}"


def open_port(url: str, *, baudrate: int = DEFAULT_BAUD, profile: str | None = None) -> serial.SerialBase:
    """Open ``url`` for streaming.

    Parameters
    ----------
    url : str
        A device path or any pyserial URL (``sim://…`` once :func:`sim.register` ran).
    baudrate : int
        Bits per second (ignored by sockets).
    profile : str, optional
        The profile being drawn with: a ``sim://`` URL that names none plays it (its firmware:
        GRBL, grblHAL, HP-GL, EBB), so the URL the user typed, and the journal, stay short.

    The port is ours alone while it is open: two senders on one board interleave their bytes,
    and each one's drawing is ruined. pyserial's ``exclusive`` takes an advisory lock (other
    senders that lock respect it), and a POSIX tty is also put in the kernel's exclusive mode
    (``TIOCEXCL``: any other open fails with EBUSY, whatever the program, unless it runs as
    root), cleared again when the port is closed; ``sim://NAME`` refuses a second open itself.

    Raises
    ------
    PlotError
        The port does not exist, is in use by another program, or the URL is malformed.
    """
    try:
        port = serial.serial_for_url(
            sim_url(url, profile), baudrate=baudrate, timeout=READ_SLICE, write_timeout=10, exclusive=True
        )
        _hold_exclusively(port)
        return port
    except (serial.SerialException, ValueError, OSError) as exc:
        if getattr(exc, "errno", None) in _BUSY:
            raise PlotError(
                f"{url} is in use by another program (another pencilbot draw?) — wait for it or close it"
            ) from None
        raise PlotError(
            f"could not open port {url!r}: {exc}. Check the cable and the port name "
            "(list ports with: python -m serial.tools.list_ports) and that no other program has it open."
        ) from None


def _hold_exclusively(port: serial.SerialBase) -> None:
    """Put a tty port in exclusive mode (``TIOCEXCL``) until it is closed.

    The mode belongs to the device, not to our handle: a pseudo-terminal whose other side
    stays open would keep it after we close, so closing the port clears it first (a port of a
    process that is killed loses it when the device's last handle closes).
    """
    fd = getattr(port, "fd", None)
    if termios is None or not hasattr(termios, "TIOCEXCL") or not isinstance(fd, int) or not os.isatty(fd):
        return  # a socket, rfc2217://, sim://, or a platform without it
    try:
        fcntl.ioctl(fd, termios.TIOCEXCL)
    except OSError:
        return  # a tty driver without it: the lock alone
    close = port.close

    def close_and_release() -> None:
        if isinstance(port.fd, int):
            try:
                fcntl.ioctl(port.fd, termios.TIOCNXCL)
            except OSError:
                pass  # the device is gone: nothing holds it
        close()

    port.close = close_and_release


def listened(port, asked: float) -> float:
    """Seconds a read begun at ``asked`` that found nothing spent listening: at most the port's
    read timeout, however long it took (more is the host's stall, not the board's silence)."""
    took = time.monotonic() - asked
    return min(took, port.timeout) if port.timeout else took


class LineReader:
    """Split what a port sends into text lines, with transport failures turned into :class:`PortLost`.

    Parameters
    ----------
    port : serial.SerialBase
        An open port (its read timeout bounds how long :meth:`read_lines` blocks).
    """

    def __init__(self, port: serial.SerialBase):
        self.port = port
        self._partial = b""
        self.last_rx = time.monotonic()
        self._listened = 0.0  # s spent in reads that found nothing, since the last byte
        self.listening = 0.0  # s spent in reads that found nothing, in all (a clock of the board's silence)

    def read_lines(self) -> list[str]:
        """Complete lines received so far (without line endings); waits at most one read slice."""
        asked = time.monotonic()
        try:
            data = self.port.read(max(self.port.in_waiting, 1))
        except (serial.SerialException, OSError) as exc:
            raise PortLost(str(exc)) from None
        if not data:
            heard_nothing = listened(self.port, asked)
            self._listened += heard_nothing
            self.listening += heard_nothing
            return []
        self.restart_silence()
        *lines, self._partial = (self._partial + data).split(b"\n")
        return [ln.strip(b"\r").decode("ascii", errors="replace") for ln in lines if ln.strip(b"\r")]

    def silent_for(self) -> float:
        """Seconds the board is proven silent: the time spent listening (in reads that found
        nothing) since the last byte received. Time the host spent elsewhere (a loaded machine,
        a suspended process) is not the board's silence: its answer may be waiting."""
        return self._listened

    def restart_silence(self) -> None:
        """Count silence from now (a byte received, a line sent that must be answered, the
        user's wait over)."""
        self.last_rx = time.monotonic()
        self._listened = 0.0

    def write(self, data: bytes | memoryview) -> None:
        """Send bytes; a failed write means the port is gone."""
        try:
            self.port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise PortLost(str(exc)) from None

    def discard_input(self) -> None:
        """Forget anything received and not yet read (after a wake or a reset)."""
        try:
            self.port.reset_input_buffer()
        except (serial.SerialException, OSError) as exc:
            raise PortLost(str(exc)) from None
        self._partial = b""
