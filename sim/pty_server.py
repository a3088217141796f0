"""Serve a virtual plotter on a pseudo-terminal, so any sender can open it like a USB port.

The pty is put in raw mode (no echo, no line editing) before the device path is handed out;
the server keeps its own handle on the device side open, so senders can connect, disconnect and
reconnect without the pty hanging up.

Like an Arduino whose DTR line resets the controller, the board power-cycles when a sender
opens the device while nobody else has it open (``reset_on_open``; seen through Linux inotify,
so elsewhere it does not).
A ``drop`` fault is a pulled cable: the pty goes away under the sender, the board keeps
running, and the server plugs it back in on a new pty — the way a USB adapter comes back,
often under another name — and reports the new path through ``on_new_path``.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import select
import struct
import threading
import tty
from collections.abc import Callable

from sim.wires import WiredBoard  # any family's plotter: the same surface

POLL = 0.002  # s: how often the machine clock advances while nobody talks
_IN_OPEN, _IN_CLOSE = 0x20, 0x08 | 0x10  # IN_CLOSE_WRITE | IN_CLOSE_NOWRITE
_EVENT = struct.Struct("iIII")  # inotify_event: wd, mask, cookie, len (then the name)


class _OpenWatch:
    """Tells when a path goes from closed to opened by some process (inotify IN_OPEN and
    IN_CLOSE); inert where inotify is missing.

    Only the first open counts: DTR rises when a port is opened while nobody has it open, so a
    second program opening a port in use (and failing to lock it) does not reset the board.
    """

    def __init__(self, path: str):
        self.fd = -1
        self.openers = 0
        try:
            libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
            fd = libc.inotify_init1(os.O_NONBLOCK | os.O_CLOEXEC)
            if fd >= 0 and libc.inotify_add_watch(fd, os.fsencode(path), _IN_OPEN | _IN_CLOSE) >= 0:
                self.fd = fd
            elif fd >= 0:
                os.close(fd)
        except (OSError, AttributeError):
            pass  # not Linux: no DTR emulation

    def opened(self) -> bool:
        """True if the path was opened while nobody else had it open, since the last call."""
        if self.fd < 0:
            return False
        try:
            data = os.read(self.fd, 4096)
        except BlockingIOError:
            return False
        offset, seen = 0, False
        while offset + _EVENT.size <= len(data):
            _, mask, _, length = _EVENT.unpack_from(data, offset)
            if mask & _IN_OPEN:
                seen = seen or self.openers == 0
                self.openers += 1
            if mask & _IN_CLOSE:
                self.openers = max(self.openers - 1, 0)
            offset += _EVENT.size + length
        return seen

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


class PtyServer:
    """A virtual plotter (:class:`~sim.wires.WiredBoard`) on a new pseudo-terminal; :attr:`path` is its device path.

    Use :meth:`serve_forever` (blocking, until :meth:`stop` or Ctrl-C) or as a context manager
    that serves in a background thread.

    Parameters
    ----------
    plotter : WiredBoard
        The board behind the pty.
    reset_on_open : bool
        Power-cycle the board whenever a sender opens the device (an Arduino's auto-reset).
    on_new_path : callable, optional
        Called with the new device path after a dropped link was plugged back in.
    """

    def __init__(
        self,
        plotter: WiredBoard,
        *,
        reset_on_open: bool = True,
        on_new_path: Callable[[str], None] | None = None,
    ):
        self.plotter = plotter
        self.reset_on_open = reset_on_open
        self.on_new_path = on_new_path
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._open_pty()

    def _open_pty(self) -> None:
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        self._watch = _OpenWatch(self.path)  # after our own open: only senders' opens count

    def serve_forever(self) -> None:
        """Shuttle bytes between the pty and the plotter until stopped."""
        out = b""
        try:
            while not self._stop.is_set():
                if self.plotter.firmware.link_dropped:
                    self._replug()
                    out = b""  # what was on its way to the old cable is gone
                readable, _, _ = select.select([self._master], [], [], POLL)
                # After the select, before the read: a sender that opened the device and wrote
                # at once has its bytes reach the board after the open's reset, never before.
                if (
                    self._watch.opened()
                    and self.reset_on_open
                    and getattr(self.plotter.firmware, "resets_on_open", True)
                ):
                    self.plotter.firmware.power_cycle()
                if readable:
                    try:
                        self.plotter.write(os.read(self._master, 4096))
                    except OSError:  # no sender has the device open right now
                        pass
                out += self.plotter.read()
                if out:
                    try:  # a full pty takes part of it; the rest waits, nothing is lost
                        out = out[os.write(self._master, out) :]
                    except BlockingIOError:
                        pass
        finally:
            self.close()

    def _replug(self) -> None:
        """The cable was pulled: the sender's device dies; a new one appears."""
        self.close()
        self._open_pty()
        self.plotter.firmware.link_dropped = False
        if self.on_new_path is not None:
            self.on_new_path(self.path)

    def stop(self) -> None:
        self._stop.set()

    def close(self) -> None:
        self._watch.close()
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass  # already closed

    def __enter__(self) -> PtyServer:
        self._thread = threading.Thread(target=self.serve_forever, name="sim-pty", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop()
        if self._thread is not None:
            self._thread.join(timeout=5)
