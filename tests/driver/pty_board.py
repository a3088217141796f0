"""A scripted serial board on a real pseudo-terminal, for protocols the virtual plotter lacks.

Subclasses implement ``_serve`` (run in a thread until ``_stop`` is set) and answer with
``_say``; the driver opens ``path`` like a USB serial port. A GRBL-like board serves with
:meth:`PtyBoard._serve_lines` and implements ``_realtime`` and ``_line``.
"""

import os
import select
import threading
import tty


class PtyBoard:
    newline = "\n"

    def __init__(self):
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join(timeout=5)
        os.close(self.master)
        os.close(self._slave)

    def _say(self, *lines):
        os.write(self.master, "".join(line + self.newline for line in lines).encode())

    def _serve(self):
        raise NotImplementedError

    def _serve_lines(self):
        """Read as GRBL does: a byte ``_realtime`` takes is acted on at once, the rest gathered
        into lines for ``_line`` (the line's text, without its end)."""
        line = b""
        while not self._stop.is_set():
            if not select.select([self.master], [], [], 0.05)[0]:
                continue
            try:
                data = os.read(self.master, 1024)
            except OSError:
                return
            for byte in data:
                if self._realtime(byte):
                    continue
                if byte in b"\r\n":
                    text, line = line.decode(), b""
                    self._line(text)
                else:
                    line += bytes([byte])
