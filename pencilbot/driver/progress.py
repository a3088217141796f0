"""Show how a plot is going: a progress bar for people, JSON lines for scripts, or nothing.

The bar and the percentage count plot time, not lines (a thousand short hatch lines take less
time than one long outline): the motion estimate of the lines acknowledged over the whole
job's. The ETA comes from the estimate of the lines still to draw (distance over feed plus
dwells), scaled by the pace observed so far, because a plotter's acceleration and the serial
link make the raw estimate optimistic. The bar shows the time elapsed and the machine state
("paused: pen change: insert red" while the board holds).
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
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
    listener : callable, optional
        ``listener(record)`` with every record a JSON line would hold (``event``: progress, done
        or stopped), whatever the mode, at the same pace: a front end such as the studio page
        follows the plot through it.
    """

    def __init__(
        self,
        mode: str,
        total_lines: int,
        total_seconds: float,
        out: TextIO | None = None,
        listener: Callable[[dict], None] | None = None,
    ):
        if mode not in MODES:
            raise ValueError(f"progress mode must be one of {MODES}, not {mode!r}")
        self.mode = mode
        self.total_lines = total_lines
        self.total_seconds = total_seconds
        self.out = out or sys.stdout
        self.listener = listener
        self.started = time.monotonic()
        self._last_emit = -1.0
        self._bar = None
        self._done = (0, 0.0)  # lines, seconds of the last update
        if mode == "bar":
            self._bar = tqdm(
                total=100.0,
                dynamic_ncols=True,
                bar_format="{percentage:3.0f}% of plot time |{bar}| {elapsed} elapsed{postfix}",  # tqdm puts ", " before a postfix
            )

    def eta(self, done_seconds: float) -> float:
        """Seconds left (s): the motion estimate of the rest, slowed to the pace seen so far."""
        elapsed = time.monotonic() - self.started
        remaining = max(self.total_seconds - done_seconds, 0.0)
        pace = elapsed / done_seconds if done_seconds >= 1.0 else 1.0  # too early to judge before
        return remaining * max(pace, 1.0)

    def percent(self, done_seconds: float, lines_done: int) -> float:
        """Share of the plot time done (%); a job without motion counts its lines."""
        if self.total_seconds > 0:
            return min(100.0, 100.0 * done_seconds / self.total_seconds)
        return 100.0 * lines_done / max(self.total_lines, 1)

    def update(
        self,
        lines_done: int,
        done_seconds: float,
        state: str,
        force: bool = False,
        where: Callable[[], dict] | None = None,
    ) -> None:
        """Report progress: lines acknowledged, their motion estimate (s), machine state;
        ``where()`` (asked only when a listener is told) adds where the machine is."""
        now = time.monotonic()
        self._done = (lines_done, done_seconds)
        if (self.mode == "quiet" and self.listener is None) or (
            now - self._last_emit < MIN_INTERVAL and lines_done < self.total_lines and not force
        ):
            return
        self._last_emit = now
        eta = self.eta(done_seconds)
        percent = self.percent(done_seconds, lines_done)
        if self.listener is not None:
            self.listener(
                dict(
                    event="progress",
                    line=lines_done,
                    total=self.total_lines,
                    percent=round(percent, 2),
                    state=state,
                    elapsed_s=round(now - self.started, 1),
                    eta_s=round(eta, 1),
                    **(where() if where is not None else {}),
                )
            )
        if self.mode == "quiet":
            return
        if self._bar is not None:
            self._bar.n = round(percent, 1)
            self._bar.set_postfix_str(
                f"line {lines_done}/{self.total_lines}, {state or '?'}, "
                f"ETA {time.strftime('%H:%M:%S', time.gmtime(eta))}",
                refresh=False,
            )
            self._bar.refresh()
        else:
            self._emit(
                event="progress",
                line=lines_done,
                total=self.total_lines,
                percent=round(percent, 2),
                state=state,
                elapsed_s=round(now - self.started, 1),
                eta_s=round(eta, 1),
            )

    def show_state(self, state: str) -> None:
        """Show a new machine state (a pause) at once, with the progress so far."""
        self.update(*self._done, state, force=True)

    def close(self, status: str, message: str = "") -> None:
        """End the display: ``status`` is ``"done"`` or ``"stopped"``."""
        if self.listener is not None:
            self.listener(
                dict(event=status, elapsed_s=round(time.monotonic() - self.started, 2), message=message)
            )
        if self._bar is not None:
            self._bar.close()
        elif self.mode == "json":
            self._emit(event=status, elapsed_s=round(time.monotonic() - self.started, 2), message=message)

    def _emit(self, **record) -> None:
        self.out.write(json.dumps(record) + "\n")
        self.out.flush()
