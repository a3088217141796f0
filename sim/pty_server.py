"""Serve a virtual plotter on a pseudo-terminal, so any sender can open it like a USB port.

The pty is put in raw mode (no echo, no line editing) before the device path is handed out;
the server keeps its own handle on the device side open, so senders can connect, disconnect and
reconnect without the pty hanging up.
"""

from __future__ import annotations

import os
import select
import threading
import tty

from sim.protocol_sim import VirtualPlotter

POLL = 0.002  # s: how often the machine clock advances while nobody talks


class PtyServer:
    """A :class:`VirtualPlotter` on a new pseudo-terminal; :attr:`path` is its device path.

    Use :meth:`serve_forever` (blocking, until :meth:`stop` or Ctrl-C) or as a context manager
    that serves in a background thread.
    """

    def __init__(self, plotter: VirtualPlotter):
        self.plotter = plotter
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def serve_forever(self) -> None:
        """Shuttle bytes between the pty and the plotter until stopped or the link drops."""
        out = b""
        try:
            while not self._stop.is_set() and not self.plotter.firmware.link_dropped:
                readable, _, _ = select.select([self._master], [], [], POLL)
                if readable:
                    self.plotter.write(os.read(self._master, 4096))
                out += self.plotter.read()
                if out:
                    try:  # a full pty takes part of it; the rest waits, nothing is lost
                        out = out[os.write(self._master, out):]
                    except BlockingIOError:
                        pass
        finally:
            self.close()

    def stop(self) -> None:
        self._stop.set()

    def close(self) -> None:
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
        self._thread.join(timeout=5)
