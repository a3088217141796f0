"""Where an EBB carriage stopped after its board lost count, found again with the person at the
machine: the guided re-zero of :mod:`pencilbot.driver.position`, on step commands.

A board that restarted (a power cut, a cable that took its power with it) or whose supply
dropped has let its motors go: its step counters no longer say where the carriage is. The
carriage itself stays where the job stopped if nobody pushes it. So the resume switches the
motors on there (``EM``: the counters are 0 at the stop point), lifts the pen, and asks the person
to jog the raised pen (``SM`` moves, counted by the board) to a mark it names: the start of the
job's first stroke, or home. The jog, counted, says where the pen had stopped: the mark less the
jog. That point is taken on the moves that may have been running when the job stopped (within
:func:`~pencilbot.driver.position.rezero_tolerance`), which also says which job line it was
drawing; the counters' origin is then that point (:attr:`EbbLink.origin`, kept in the journal),
and the raised pen goes back to it.
"""

from __future__ import annotations

import math

import numpy as np

from pencilbot.driver.position import FINE_JOG_STEP, mark_before, rezero_tolerance
from pencilbot.errors import PlotError
from pencilbot.firmware.ebb import protocol
from pencilbot.machine.ebb_motion import pen_commands, plan_ebb
from pencilbot.units import MM_PER_INCH

JOG_RATE = 0.8 * protocol.MAX_STEP_RATE  # steps/s a jog's faster motor runs at, at most


def rezero(link, profile, job, resumed, operator, why: str) -> tuple[tuple[int, int], int]:
    """Re-establish the carriage's position with ``operator`` (see the module docstring).

    Parameters
    ----------
    link : pencilbot.driver.ebb.link.EbbLink
    profile : Profile
        The EBB profile (``[ebb]`` geometry, pen, travel speed).
    job : pencilbot.driver.gcode.job.Job
    resumed : Journal
        The stopped job: its ``ebb_moves`` (start and end steps and file line of each move that
        may have been running).
    operator : pencilbot.driver.position.Operator
    why : str
        Why the position was lost (said in the prompt).

    Returns
    -------
    (tuple of int, int)
        The stop point (motor steps from home), where the raised pen is brought back to, and
        the job line index to go on from.

    Raises
    ------
    PlotError
        Nothing known of the moves in flight, or the jog puts the stop on none of them.
    """
    moves = np.array(resumed.options.get("ebb_moves") or [], dtype=np.int64).reshape(-1, 5)
    if not len(moves):
        raise PlotError(
            "the position is lost and the stop recorded no move in flight to find it on; nothing was "
            f"drawn. Restart from a line: pencilbot draw {job.source} --start-line {resumed.next_line}"
        )
    setup = profile.ebb
    _hold_here(link, profile)
    certain = job.index_of(int(moves[0, 4]))
    to_mm = MM_PER_INCH if job.state_after(max(certain - 1, 0)).inches else 1.0
    mark = mark_before(job, certain, to_mm)
    jogged, sent = [0.0, 0.0], [0, 0]
    rate = min(profile.motion.travel_speed * setup.steps_per_mm, JOG_RATE)

    def jog(dx: float, dy: float) -> None:
        jogged[0] += dx
        jogged[1] += dy
        target = np.rint(setup.to_motor(np.array([jogged]))[0]).astype(np.int64)
        a, b = int(target[0]) - sent[0], int(target[1]) - sent[1]
        if a or b:
            ms = max(math.ceil(1000 * max(abs(a), abs(b)) / rate), 1)
            link.command(f"SM,{ms},{a},{b}", wait=link.timeout + ms / 1000)
            sent[0], sent[1] = sent[0] + a, sent[1] + b

    operator.jog_to_mark(
        f"{why}. Jog the raised pen from where it stopped (do not move it by hand) until it stands exactly over "
        f"{mark.text} (close enough: within {FINE_JOG_STEP / 2:g} mm of it in X and in Y), then confirm",
        mark,
        jog,
    )
    link.wait_idle(60)
    counted = np.array(link.steps(), dtype=np.float64)  # the jog, from the stop point
    stop = setup.to_motor(np.array([mark.xy]))[0] - counted
    found = _on_moves(stop, moves, setup, rezero_tolerance())
    if found is None:
        x, y = setup.to_machine(stop[None])[0]
        raise PlotError(
            f"by the jog the pen had stopped at X{x:.3f} Y{y:.3f}, on none of the moves the job was making "
            "(was the carriage moved by hand?); nothing was drawn. Look at the sheet and restart from a "
            f"line: pencilbot draw {job.source} --start-line {resumed.next_line}"
        )
    here, line = found
    link.origin = here  # the counters were 0 at the stop point
    _back_to(link, profile, here)
    return here, job.index_of(line)


def _hold_here(link, profile) -> None:
    """The motors on where the carriage stands (the counters 0 there), the pen set up and raised."""
    mode = profile.ebb.microstep_mode
    link.command(f"EM,{mode},{mode}")
    link.origin = (0, 0)
    link.power_lost = False
    for text in pen_commands(profile):
        link.command(text)
    link.command(profile.ebb.pen_command(True, max(int(profile.pen.up_delay * 1000), 1)))
    link.wait_idle(5)


def _back_to(link, profile, here: tuple[int, int]) -> None:
    """The raised pen back to the stop point ``here`` (motor steps)."""
    back = plan_ebb(
        profile.ebb.to_machine(np.array([here], dtype=np.float64)),
        np.array([False]),
        np.array([0]),
        profile,
        start_steps=link.steps(),
        pen_down=False,
    )
    for move in back:
        link.command(move.command, wait=link.timeout + 2 * move.seconds)
    link.wait_idle(60)


def _on_moves(
    stop: np.ndarray, moves: np.ndarray, setup, tolerance: float
) -> tuple[tuple[int, int], int] | None:
    """The first move (oldest first) whose segment passes within ``tolerance`` mm of ``stop``
    (motor steps): the nearest point of it, in whole steps, and the move's file line."""
    p = setup.to_machine(stop[None])[0]
    for a0, a1, b0, b1, line in moves.tolist():
        a, b = setup.to_machine(np.array([[a0, a1], [b0, b1]], dtype=np.float64))
        d = b - a
        t = float(np.clip(np.dot(p - a, d) / max(float(np.dot(d, d)), 1e-18), 0.0, 1.0))
        if float(np.hypot(*(a + t * d - p))) <= tolerance:
            here = np.rint(np.array([a0, a1]) + t * (np.array([b0, b1]) - np.array([a0, a1]))).astype(
                np.int64
            )
            return (int(here[0]), int(here[1])), int(line)
    return None
