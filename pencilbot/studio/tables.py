"""The shipped and the user's pen sets' colour-separation tables, solved in the background when
the studio starts, so that the first colour preview of a set does not wait for its table.

A table takes 2-8 s to solve and is then kept in the user's cache folder
(:func:`~pencilbot.planning.separation.separation_table`); without this the first coarse preview
with a pen set took that long on top of its half second. The solving runs in its own process at a
low priority (the previews come first) and is stopped when the studio stops; a table it has not
reached is solved by the first preview that needs it, as before.

Run as ``python -m pencilbot.studio.tables``.
"""

from __future__ import annotations

import os
import subprocess
import sys

#: How much lower the solver's priority is than the studio's (``nice``).
NICENESS = 10


def start() -> subprocess.Popen | None:
    """The solver process, started (None where it cannot be)."""
    try:
        return subprocess.Popen(
            [sys.executable, "-m", "pencilbot.studio.tables"],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,  # a Ctrl-C at the terminal is the studio's to handle
        )
    except OSError:
        return None


def stop(process: subprocess.Popen | None) -> None:
    """Stop the solver if it is still running (a table half written is never read: writes are atomic)."""
    if process is not None and process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def solve_all() -> list[str]:
    """Solve (or find cached) the table of every pen set of several pens; the sets' names."""
    from pencilbot.errors import PencilbotError
    from pencilbot.machine.pens import list_pen_sets, load_pens
    from pencilbot.planning.separation import separation_table

    solved = []
    for name in list_pen_sets():
        try:
            pens = load_pens(name)
        except PencilbotError:
            continue  # a broken set of the user's is said when it is chosen
        if len(pens.pens) > 1:
            separation_table(tuple(pen.color for pen in pens.load_order))  # the order build plans in
            solved.append(name)
    return solved


if __name__ == "__main__":
    os.nice(NICENESS)
    solve_all()
