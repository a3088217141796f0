"""A person at the virtual plotter who re-zeroes with the jog keys, as the terminal offers them.

:class:`SteppedHand` answers a re-zero through :class:`pencilbot.driver.keys.TerminalOperator`:
it presses the step keys (10, 1, 0.1 mm) and the direction keys, looking at where the carriage
really is, until the pen is within half the finest step of the mark in X and in Y, then Enter.
So a test's re-zero is only as exact as a person's, not an exact float.
"""

from __future__ import annotations

import io

from pencilbot.driver.keys import _JOG_KEYS, _JOG_STEPS, TerminalOperator
from pencilbot.driver.position import FINE_JOG_STEP


class _Keys:
    """The keys a person presses while looking at the carriage and the mark."""

    def __init__(self, plotter, mark):
        self.plotter, self.mark = plotter, mark
        self.step = None
        self.pressed: list[str] = []

    def key(self) -> str:
        x, y, _ = self.plotter.machine.carriage_position()
        for axis, d in enumerate((self.mark.xy[0] - x, self.mark.xy[1] - y)):
            for name, step in sorted(_JOG_STEPS.items(), key=lambda kv: -kv[1]):
                if abs(d) >= step / 2 and (step > FINE_JOG_STEP or abs(d) >= FINE_JOG_STEP / 2):
                    if self.step != step:
                        self.step = step
                        return self._press(name)
                    direction = 1 if d > 0 else -1
                    want = (direction, 0) if axis == 0 else (0, direction)
                    return self._press(next(k for k, v in _JOG_KEYS.items() if v == want))
        return self._press("\n")

    def _press(self, key: str) -> str:
        self.pressed.append(key)
        return key


class SteppedHand:
    """Answers pauses; re-zeroes with the terminal's jog keys (see the module docstring)."""

    jog_step = FINE_JOG_STEP

    def __init__(self, plotter):
        self.plotter = plotter
        self.prompts: list[str] = []
        self.keys: _Keys | None = None

    def pause(self, prompt):
        self.prompts.append(prompt)

    def jog_to_mark(self, prompt, mark, jog):
        self.prompts.append(prompt)
        self.keys = _Keys(self.plotter, mark)
        TerminalOperator(self.keys, out=io.StringIO()).jog_to_mark(prompt, mark, jog)


class Hand:
    """Someone at a virtual plotter who answers pauses (each prompt kept) and jogs the raised pen
    exactly where a fault matrix's subclass looks (:meth:`sighted`: where the pen is and where
    it should go), by name of the plotter in ``sim://``."""

    jog_step = 0.0

    def __init__(self, name):
        self.name, self.prompts = name, []

    def pause(self, prompt):
        self.prompts.append(prompt)

    def jog_to_mark(self, prompt, mark, jog):
        self.prompts.append(prompt)
        (x, y), (to_x, to_y) = self.sighted(mark)
        jog(to_x - x, to_y - y)

    def sighted(self, mark):
        raise NotImplementedError
