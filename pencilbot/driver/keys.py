"""The person at the terminal during ``draw``: keys that pause and stop, answers to prompts.

:class:`KeyReader` reads single keys from a terminal in cbreak mode (no Enter needed, no echo)
in a background thread: ``p`` or space pauses the plotter (feed hold) and resumes it (cycle
start), ``s`` stops it safely (as Ctrl-C does). It is used only when standard input is a
terminal; the terminal's mode is restored when it closes. :class:`TerminalOperator` answers the
driver's prompts (a pen change, a re-zero) from the same keys, so nothing else reads the
terminal at the same time.
"""

from __future__ import annotations

import os
import queue
import select
import sys
import threading

from pencilbot.driver.position import FINE_JOG_STEP
from pencilbot.errors import PlotError

PAUSE_KEYS, STOP_KEYS = "p ", "s"
_JOG_STEPS = {"1": FINE_JOG_STEP, "2": 1.0, "3": 10.0}  # mm a jog key moves, by the step chosen
_JOG_KEYS = {"h": (-1, 0), "l": (1, 0), "j": (0, -1), "k": (0, 1)}


class KeyReader:
    """Keys typed on a terminal (``stream``: a file on a tty, standard input by default)."""

    def __init__(self, stream=None):
        import termios
        import tty

        self.stream = stream or sys.stdin
        self.fd = self.stream.fileno()
        self._saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd)
        self._keys: queue.Queue[str] = queue.Queue()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, name="keys", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self.fd], [], [], 0.1)
            if ready:
                data = os.read(self.fd, 32)
                if not data:
                    return  # the terminal went away
                for char in data.decode("utf-8", "replace"):
                    self._keys.put(char)

    def poll(self) -> list[str]:
        """Requests typed since the last call: ``"pause"`` or ``"stop"``."""
        requests: list[str] = []
        while True:
            try:
                char = self._keys.get_nowait()
            except queue.Empty:
                return requests
            if char in PAUSE_KEYS:
                requests.append("pause")
            elif char.lower() in STOP_KEYS:
                requests.append("stop")

    def key(self) -> str:
        """The next key typed (waits)."""
        return self._keys.get()

    def close(self) -> None:
        import termios

        self._stop.set()
        self._thread.join(timeout=1)
        termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)


class TerminalOperator:
    """Prompts on standard error, answered with keys from a :class:`KeyReader`."""

    jog_step = FINE_JOG_STEP  # the finest jog key: how close to a mark a person gets

    def __init__(self, keys: KeyReader, out=None):
        self.keys = keys
        self.out = out or sys.stderr

    def _say(self, text: str) -> None:
        self.out.write(f"\n{text}\n")
        self.out.flush()

    def pause(self, prompt: str) -> None:
        self._say(f"{prompt}. Press Enter to go on (cycle start).")
        while self.keys.key() not in "\r\n":
            pass

    def jog_to_mark(self, prompt, mark, jog) -> None:
        step = 1.0
        self._say(
            f"{prompt}. Keys: h/l move X -/+, j/k move Y -/+, 1/2/3 set the step to 0.1/1/10 mm, "
            "Enter when the pen is over the mark, q to give up."
        )
        while True:
            key = self.keys.key()
            if key in "\r\n":
                return
            if key == "q":
                raise PlotError(
                    "re-zero abandoned; nothing was drawn. Resume again when the pen can be jogged"
                )
            if key in _JOG_STEPS:
                step = _JOG_STEPS[key]
                self._say(f"step {step:g} mm")
            elif key in _JOG_KEYS:
                sx, sy = _JOG_KEYS[key]
                jog(sx * step, sy * step)


class AutoOperator:
    """``simulate``: nobody needs to insert a pen in a simulation, so pauses are announced and
    cycle start pressed at once; a lost position cannot happen (the board is fresh)."""

    def __init__(self, out=None):
        self.out = out or sys.stderr

    def pause(self, prompt: str) -> None:
        self.out.write(f"{prompt} (simulate presses cycle start)\n")
        self.out.flush()

    def jog_to_mark(self, prompt, mark, jog) -> None:
        raise PlotError(f"{prompt}: a simulation cannot be re-zeroed by hand")
