"""Show how a plot is going: a progress bar for people, JSON lines for scripts, or nothing.

The ETA comes from the motion estimate of the lines still to draw (distance over feed plus
dwells), scaled by the pace observed so far, because a plotter's acceleration and the serial
link make the raw estimate optimistic.
"""

from __future__ import annotations

import json
import sys
import time
from typing import TextIO

from tqdm import tqdm

MODES = ("bar", "quiet", "json")
MIN_INTERVAL = 0.2  # s between JSON lines: the status poll rate, no more


class Progress:
    """Progress display of one streaming job.

    Parameters
    ----------
    mode : {"bar", "quiet", "json"}
        ``bar``: a tqdm bar on stderr; ``json``: one JSON object per line on ``out``;
        ``quiet``: nothing.
    total_lines : int
        Lines the job sends.
    total_seconds : float
        Motion estimate of the whole job (s).
    out : file, optional
        Where JSON lines go (stdout by default).
    """

    def __init__(self, mode: str, total_lines: int, total_seconds: float, out: TextIO | None = None):
        if mode not in MODES:
            raise ValueError(f"progress mode must be one of {MODES}, not {mode!r}")
        self.mode = mode
        self.total_lines = total_lines
        self.total_seconds = total_seconds
        self.out = out or sys.stdout
        self.started = time.monotonic()
        self._last_emit = -1.0
        self._bar = None
        if mode == "bar":
            self._bar = tqdm(
                total=total_lines,
                unit="line",
                dynamic_ncols=True,
                bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} lines{postfix}",
            )

    def eta(self, done_seconds: float) -> float:
        """Seconds left (s): the motion estimate of the rest, slowed to the pace seen so far."""
        elapsed = time.monotonic() - self.started
        remaining = max(self.total_seconds - done_seconds, 0.0)
        pace = elapsed / done_seconds if done_seconds >= 1.0 else 1.0  # too early to judge before
        return remaining * max(pace, 1.0)

    def update(self, lines_done: int, done_seconds: float, state: str) -> None:
        """Report progress: lines acknowledged, their motion estimate (s), machine state."""
        now = time.monotonic()
        if self.mode == "quiet" or (now - self._last_emit < MIN_INTERVAL and lines_done < self.total_lines):
            return
        self._last_emit = now
        eta = self.eta(done_seconds)
        if self._bar is not None:
            self._bar.n = lines_done
            self._bar.set_postfix_str(f"{state or '?'} ETA {time.strftime('%H:%M:%S', time.gmtime(eta))}", refresh=False)
            self._bar.refresh()
        else:
            self._emit(
                event="progress",
                line=lines_done,
                total=self.total_lines,
                percent=round(100.0 * lines_done / max(self.total_lines, 1), 2),
                state=state,
                eta_s=round(eta, 1),
            )

    def close(self, status: str, message: str = "") -> None:
        """End the display: ``status`` is ``"done"`` or ``"stopped"``."""
        if self._bar is not None:
            self._bar.close()
        elif self.mode == "json":
            self._emit(event=status, elapsed_s=round(time.monotonic() - self.started, 2), message=message)

    def _emit(self, **record) -> None:
        self.out.write(json.dumps(record) + "\n")
        self.out.flush()
