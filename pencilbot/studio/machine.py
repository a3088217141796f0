"""The page's machine controls: the pen up, down or toggled, the motors off or on, a walk of the
carriage, home — through the library's machine-control API (:mod:`pencilbot.driver.control`),
for every firmware family; one sentence of what the plotter did.

The port stays open between presses (:class:`Controls`): opening it resets many boards (GRBL's
wake-up reset lifts a spindle pen, an Arduino restarts), so a toggle or a walk must reach the
board the last press left. A plot takes the port over: it is let go first.
"""

from __future__ import annotations

import threading

from pencilbot.errors import PencilbotError

#: The controls, as the page names them.
ACTIONS = ("pen-up", "pen-down", "pen-toggle", "motors-off", "motors-on", "walk", "home")
#: The longest walk one press may ask for (mm): a slip of the finger must not cross the bed.
MAX_WALK = 50.0


class Controls:
    """The open :class:`~pencilbot.driver.control.Control` of the plotter last pressed for."""

    def __init__(self):
        self._lock = threading.Lock()
        self._open = None
        self._key: tuple[str, str] | None = None

    def press(self, url: str, profile: str, action: str, dx: float = 0.0, dy: float = 0.0) -> str:
        """Do ``action`` on the plotter at ``url`` (of ``profile``); what it did, in plain words.

        Raises
        ------
        PencilbotError
            An unknown action or a walk too long; the plotter refused or cannot do it
            (:class:`~pencilbot.errors.PlotError`).
        """
        if action not in ACTIONS:
            raise PencilbotError(f"no machine control called {action}; known: {', '.join(ACTIONS)}")
        if max(abs(dx), abs(dy)) > MAX_WALK:
            raise PencilbotError(
                f"a walk of more than {MAX_WALK:g} mm at once is refused; walk in smaller steps"
            )
        with self._lock:
            plotter = self._plotter(url, profile)
            try:
                return _do(plotter, action, dx, dy)
            except PencilbotError:
                self._let_go()  # a refusal may leave the link in doubt: the next press opens it again
                raise

    def try_height(self, url: str, profile: str, which: str, value: float) -> str:
        """Put the pen ``which`` (up / down) at ``value`` (the profile's unit) on the plotter at
        ``url``, for this session (the library's trial); what it did, in plain words."""
        with self._lock:
            plotter = self._plotter(url, profile)
            if not plotter.pen_heights:
                raise PencilbotError(
                    f"{plotter.family or 'this plotter'}'s pen has no heights to try: it is only up or down"
                )
            try:
                down = plotter.try_height(which, value)
            except PencilbotError:
                self._let_go()
                raise
        where = "" if down is None else " (the plotter reports it " + ("down)" if down else "up)")
        return f"pen {which} at {value:g}{where}"

    def release(self) -> None:
        """Let go of the port (a plot takes it over; the server stops)."""
        with self._lock:
            self._let_go()

    def _plotter(self, url: str, profile: str):
        import sim
        from pencilbot.driver.control import open_control

        if self._key != (url, profile):
            self._let_go()
            sim.register()  # sim://… reaches the virtual plotter, as api.draw does
            self._open, self._key = open_control(url, profile), (url, profile)
        return self._open

    def _let_go(self) -> None:
        if self._open is not None:
            self._open.close()
        self._open, self._key = None, None


def _do(plotter, action: str, dx: float, dy: float) -> str:
    if action.startswith("pen-"):
        down = plotter.pen(action.removeprefix("pen-"))
        return f"pen {action[4:]} sent" if down is None else "the pen is " + ("down" if down else "up")
    if action.startswith("motors-"):
        return plotter.motors(action == "motors-on").split(" (pencilbot ")[0]
    at = plotter.walk(dx, dy) if action == "walk" else plotter.home()
    verb = "walked" if action == "walk" else "home"
    return f"{verb}: the carriage is at {at[0]:.1f}, {at[1]:.1f} mm" if at is not None else f"{verb}: done"
