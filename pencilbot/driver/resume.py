"""Rebuild the machine state to continue a job from the middle.

A resumed job must look, to the paper, like the job never stopped: the lines before the resume
point are not sent again, but their lasting effects are — units, absolute/relative mode, feed,
the motion mode — and the pen travels *up* from wherever the machine is to the resume point
before it goes down again (if it was down there).
"""

from __future__ import annotations

from collections.abc import Sequence

from pencilbot.driver.modal import ModalState, PenModel, advance


def state_before(lines: Sequence[str], index: int, pen: PenModel) -> ModalState:
    """Modal state after ``lines[:index]`` (cleaned lines), i.e. just before ``lines[index]``."""
    state = ModalState()
    for line in lines[:index]:
        state = advance(state, line, pen)
    return state


def resume_preamble(
    state: ModalState, pen: PenModel, *, stop_xy: tuple[float, float] | None = None, decimals: int = 3
) -> list[str]:
    """G-code that puts a freshly woken machine into ``state``, travelling with the pen up.

    Parameters
    ----------
    state : ModalState
        The state the next job line expects (from :func:`state_before`).
    pen : PenModel
        Pen commands of the plotter.
    stop_xy : (float, float), optional
        Where the pen stopped inside the next line's move (job units). In absolute mode the next
        line, sent from there, draws exactly the rest of that move; without it the pen travels to
        the end of the previous line.
    decimals : int
        Digits after the point for coordinates and feed.

    Returns
    -------
    list of str
        Cleaned lines to send before the job's remaining lines.
    """
    x, y = stop_xy if (stop_xy is not None and not state.relative) else (state.x, state.y)
    fmt = f"{{:.{decimals}f}}"
    lines = ["G20" if state.inches else "G21", "G90", *pen.up_lines]
    lines.append(f"G0X{fmt.format(x)}Y{fmt.format(y)}")
    if state.pen_down:
        lines.extend(pen.down_lines)
    mode = f"G{state.motion}"
    lines.append(mode + (f"F{fmt.format(state.feed)}" if state.feed else ""))
    if state.relative:
        lines.append("G91")
    return lines
