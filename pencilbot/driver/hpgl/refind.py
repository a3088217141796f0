"""Where a plotter that acknowledges nothing (HP-GL) was drawing when it lost its buffer (switched
off and on, reset): found on the sheet with the person at the machine.

Such a plotter knows where its pen is (it homes at power-up), but not what it had drawn: the
instructions still in its buffer are gone, and the sender knows only that those before the last
poll's floor ran and those after the last one sent did not. So the resume asks the person to
jog the raised pen (``PU x,y`` moves) to where the last line on the sheet ends; that point is
taken on the drawing moves between the floor and the last instruction sent (within
:func:`~pencilbot.driver.position.rezero_tolerance`, the first that passes there), and the job
goes on from it: pen down there, the rest of that move, and everything after it, once.
"""

from __future__ import annotations

import math

import numpy as np

from pencilbot.driver.position import FINE_JOG_STEP, Mark, rezero_tolerance
from pencilbot.errors import PlotError


def refind(
    link, fw, program, journal, operator, plotter, timeout: float, why: str
) -> tuple[int, tuple[int, int]]:
    """Find where the job stopped on the sheet with ``operator`` (see the module docstring).

    Returns
    -------
    (int, (int, int))
        The entry to send next, and where (plotter units) the pen goes down before it.

    Raises
    ------
    PlotError
        The sync point went unanswered, or the point the person showed is on none of the moves.
    """
    unit = plotter.paper.unit_mm
    width, height = round(plotter.bed.width / unit), round(plotter.bed.height / unit)
    low = max(journal.acked_line - 1, 0)
    high = min(max(journal.sent_line, journal.next_line - 1), len(program))
    link.write(fw.lift_command + fw.sync_command)
    start = link.position(fw, timeout)
    if start is None:
        raise PlotError("the plotter did not answer while the stop was being found; nothing was drawn")
    here = [float(start[0]), float(start[1])]

    def jog(dx: float, dy: float) -> None:
        here[0] = min(max(here[0] + dx / unit, 0.0), width)
        here[1] = min(max(here[1] + dy / unit, 0.0), height)
        link.write(fw.protocol.encode("PU", round(here[0]), round(here[1])))

    operator.jog_to_mark(
        f"{why}. Jog the raised pen until it stands exactly over the end of the last line the plotter drew on the "
        f"sheet (close enough: within {FINE_JOG_STEP / 2:g} mm of it in X and in Y), then confirm",
        Mark((math.nan, math.nan), "the end of the last line drawn on the sheet"),
        jog,
    )
    link.write(fw.sync_command)
    shown = link.position(fw, timeout)
    if shown is None:
        raise PlotError("the plotter did not answer while the stop was being found; nothing was drawn")
    found = _on_moves(program, np.array(shown[:2], dtype=np.float64), low, high, rezero_tolerance() / unit)
    if found is None:
        raise PlotError(
            f"the pen stands at {shown[0]},{shown[1]} (plotter units), on none of the lines the job was drawing "
            f"(instructions {low + 1}..{high}); nothing was drawn. Restart from an instruction you choose: "
            f"pencilbot draw {journal.gcode} --start-line N --port {journal.port} --profile {journal.profile}"
        )
    return found


def _on_moves(
    program, point: np.ndarray, low: int, high: int, tolerance: float
) -> tuple[int, tuple[int, int]] | None:
    """The first drawing move among entries ``low .. high - 1`` that passes within ``tolerance``
    units of ``point``, and the nearest whole point of it."""
    for i in range(max(low, 1), high):
        if not program.down[i]:  # entry i draws from where entry i - 1 left the pen
            continue
        a, b = program.xy[i - 1].astype(np.float64), program.xy[i].astype(np.float64)
        d = b - a
        t = float(np.clip(np.dot(point - a, d) / max(float(np.dot(d, d)), 1e-18), 0.0, 1.0))
        if float(np.hypot(*(a + t * d - point))) <= tolerance:
            at = np.rint(a + t * d).astype(np.int64)
            return i, (int(at[0]), int(at[1]))
    return None
