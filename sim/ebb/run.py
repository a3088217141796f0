"""Parts of the virtual EBB (:mod:`sim.ebb.board`): a queued command as it runs, and a command's
characters as the firmware keeps them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from firmware_protocol import ebb as protocol


@dataclass
class Run:
    """A queued command being executed: motion (per-axis steps, rates, accels, ticks) or a
    servo move / delay (``ticks`` of waiting)."""

    command: protocol.Command
    start: np.ndarray  # counters when it started (int64)
    steps: np.ndarray  # signed per axis
    rates: tuple[int, ...]
    accels: tuple[int, ...]
    carry: tuple[int, int]
    axis_ticks: tuple[int, ...]
    ticks: int
    t0: float  # board clock when it started

    def steps_at(self, t: int) -> np.ndarray:
        done = [
            protocol.lm_steps_at(
                min(t, self.axis_ticks[i]),
                abs(int(self.steps[i])),
                self.rates[i],
                self.accels[i],
                self.carry[i],
            )
            if self.steps[i]
            else 0
            for i in range(2)
        ]
        return np.sign(self.steps) * np.array(done, dtype=np.int64)


_CONTROL = bytes(range(32))


def typed(raw: bytes | bytearray) -> str:
    """A command's characters as the firmware keeps them: control bytes dropped, a backspace
    taking back the character before it."""
    if b"\x08" not in raw:
        return bytes(raw).translate(None, _CONTROL).decode("ascii", errors="replace").replace("\ufffd", "?")
    kept: list[str] = []
    for byte in raw:
        if byte == 8:
            if kept:
                kept.pop()
        elif byte >= 32:
            kept.append(chr(byte) if byte < 128 else "?")
    return "".join(kept)
