"""Waiting in tests for what another thread makes true, never for the wall clock to pass: the
result is the predicate's; the limit only ends a broken run (a loaded machine never reaches it)."""

import threading
import time

SAFETY = 30.0  # s: a bound for a broken run only; no result depends on it
POLL = 0.01  # s between looks at something another thread makes


def until(predicate, what: str, limit: float = SAFETY):
    """``predicate()`` once it is true."""
    end = time.monotonic() + limit
    while not (value := predicate()):
        assert time.monotonic() < end, f"never: {what}"
        threading.Event().wait(POLL)
    return value
