"""The signals that stop a plot safely, one table for every driver and the studio.

Ctrl-C (SIGINT), SIGTERM (``kill``), SIGHUP (the terminal closed) and SIGQUIT (Ctrl-\\) each lift
the pen, stop the board, write the journal as stopped and say how to resume, whichever driver
runs the job (GRBL-protocol streaming, EBB, HP-GL) or the studio serves it. :func:`caught`
installs one handler for all of them while a plot runs (in the main thread: only it can have
signal handlers) and puts the old ones back after; :class:`RaiseOnce` is the handler of a driver
that stops by an exception: the first signal raises :class:`~pencilbot.driver.faults.Interrupted`,
any later one (during the stop itself) is noted and not obeyed.

A signal the process was started ignoring stays ignored: ``nohup pencilbot draw ...`` goes on
drawing when its terminal closes, and a script's background job (``pencilbot draw ... &``) is not
stopped by a Ctrl-C meant for the script; ``kill`` (SIGTERM) still stops them.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from pencilbot.driver.faults import Interrupted

#: Signal number → how a stop message names it ("stopped by ..."). Only those the platform has.
STOP_SIGNALS: dict[int, str] = {
    getattr(signal, name): said
    for name, said in (
        ("SIGINT", "Ctrl-C"),
        ("SIGTERM", "SIGTERM"),
        ("SIGHUP", "SIGHUP"),
        ("SIGQUIT", "SIGQUIT"),
    )
    if hasattr(signal, name)
}


@contextmanager
def caught(on_stop: Callable[[str], None]) -> Iterator[bool]:
    """While inside, every stop signal calls ``on_stop(name)`` (``name``: as :data:`STOP_SIGNALS`
    says it), except one the process ignores (see the module text). Yields whether the handlers
    are installed (False outside the main thread, where a library call cannot have them: its
    caller's handlers stay)."""
    if threading.current_thread() is not threading.main_thread():
        yield False
        return

    def handler(signum, _frame):
        on_stop(STOP_SIGNALS[signum])

    saved = {
        signum: signal.signal(signum, handler)
        for signum in STOP_SIGNALS
        if signal.getsignal(signum) is not signal.SIG_IGN
    }
    try:
        yield True
    finally:
        for signum, old in saved.items():
            signal.signal(signum, old)


class RaiseOnce:
    """A handler for :func:`caught` that raises :class:`Interrupted` for the first signal only
    (``stopping`` is set before it is raised: a second signal, however soon, finds it set)."""

    def __init__(self) -> None:
        self.stopping = False

    def __call__(self, name: str) -> None:
        if not self.stopping:
            self.stopping = True
            raise Interrupted(name)
