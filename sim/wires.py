"""What every virtual board shares: the two wires to the host, the clock that drives the board
(:meth:`WiredBoard.pump`), the picture of what it drew. Each family's plotter
(:class:`sim.gcode.plotter.VirtualPlotter`, :class:`sim.ebb.plotter.VirtualEbb`,
:class:`sim.hpgl.plotter.HpglPlotter`) is one, and :mod:`sim.protocol_sim` (the ``sim://`` adapter)
and :mod:`sim.pty_server` serve any of them alike.
"""

from __future__ import annotations

import signal
import time
from typing import Any

from pencilbot.errors import ProfileError
from pencilbot.machine.profile import Profile
from pencilbot.render import DEFAULT_DPI, Canvas, save_drawing_png
from pencilbot.units import DEFAULT_PEN_WIDTH


class Wire:
    """Bytes in flight over a serial line at ``baud`` bit/s (10 bits per byte); 0 = instant."""

    def __init__(self, baud: int):
        self.rate = baud / 10.0
        self.buf = bytearray()
        self.t = 0.0  # when the head byte started its way

    def put(self, data: bytes, now: float) -> None:
        if not self.buf:
            self.t = now
        self.buf += data

    def take(self, now: float) -> bytes:
        n = len(self.buf) if not self.rate else min(int((now - self.t) * self.rate), len(self.buf))
        chunk = bytes(self.buf[:n])
        del self.buf[:n]
        if self.rate:
            self.t += n / self.rate
        return chunk


def check_simulated(profile: Profile) -> None:
    """Raise :class:`ProfileError` unless the virtual plotter can play ``profile``'s firmware."""
    if not (
        profile.firmware.capabilities.realtime_protocol
        or profile.firmware.capabilities.host_motion
        or profile.firmware.sim_board
    ):
        raise ProfileError(
            f"profile {profile.name} is for {profile.firmware.title}; the virtual plotter speaks "
            "GRBL's protocol (GRBL 1.1, grblHAL) and the EBB's: use such a profile (e.g. grbl-servo-a4)"
        )


class WiredBoard:
    """A virtual board behind two wires at ``baud`` bit/s, driven by :meth:`pump`.

    A family's plotter sets ``profile``, ``firmware`` (bytes in, replies out, ``poll``, ``finish``,
    ``signal_due``), ``machine`` (what it drew: ``bed_strokes``, ``bed_travel``) and ``realtime``,
    calls :meth:`_connect`, and may run its clock its own way (:meth:`_run`).
    """

    profile: Profile
    firmware: Any
    machine: Any
    realtime: float = 0.0
    operator: str = "none"

    def _connect(self, baud: int) -> None:
        """The two wires between host and board, at ``baud`` bit/s (0: instant), and the clock."""
        self._to_board, self._to_host = Wire(baud), Wire(baud)
        self._last = time.monotonic()

    def write(self, data: bytes) -> None:
        """Bytes from the host onto the wire."""
        self._to_board.put(data, time.monotonic())
        self.pump()

    def pump(self) -> None:
        """Deliver what has arrived at the board, run the clock, put its replies on the wire."""
        now = time.monotonic()
        elapsed, self._last = now - self._last, now
        self.firmware.receive(self._to_board.take(now))
        self._run(elapsed)
        self._to_host.put(self.firmware.take_output(), now)
        if self.firmware.signal_due is not None:
            # An interrupt@ fault: the sender's terminal sends the signal once the bytes are in.
            signum, self.firmware.signal_due = self.firmware.signal_due, None
            signal.raise_signal(signum)

    def _run(self, elapsed: float) -> None:
        """Let the board run for ``elapsed`` wall seconds (scaled by ``realtime``; 0: instant)."""
        self.firmware.poll(elapsed * self.realtime)

    def read(self) -> bytes:
        """What has reached the host so far."""
        self.pump()
        return self._to_host.take(time.monotonic())

    def canvas(
        self, *, dpi: float = DEFAULT_DPI, pen_width: float = DEFAULT_PEN_WIDTH, travel: bool = False
    ) -> Canvas:
        """The bed as drawn so far (queued motion finished first in instant mode)."""
        self.firmware.finish()
        bed = self.profile.bed
        canvas = Canvas(bed.width, bed.height, dpi=dpi, pen_width=pen_width)
        canvas.draw_paths(self.machine.bed_strokes())
        if travel:
            canvas.draw_travel(self.machine.bed_travel())
        return canvas

    def save_png(
        self, path, *, dpi: float = DEFAULT_DPI, pen_width: float = DEFAULT_PEN_WIDTH, travel: bool = False
    ) -> None:
        """Write the bed as drawn so far to a PNG, a band of rows at a time: the picture
        :meth:`canvas` would give, with memory bounded by a band instead of the bed."""
        self.firmware.finish()
        bed = self.profile.bed
        save_drawing_png(
            path,
            self.machine.bed_strokes(),
            bed.width,
            bed.height,
            dpi=dpi,
            pen_width=pen_width,
            travel=self.machine.bed_travel() if travel else None,
        )

    @property
    def seconds(self) -> float:
        """Simulated seconds of motion and dwell so far."""
        return self.machine.clock
