"""Host-side motion for EBB machines: pen-up / pen-down polylines → ``LM`` and ``SP`` commands.

The board runs whatever step commands it is given, so the host plans the motion, with the one
motion model that also estimates plot time (:mod:`pencilbot.machine.motion`): junction speeds by
junction deviation over each run of moves between pen changes, acceleration and rate limited
per axis the way the estimate limits them, a trapezoid on every move. Each trapezoid becomes up
to three ``LM`` commands (accelerate, cruise, decelerate), each a constant acceleration on both
motors, so the board's steps follow the plan exactly. No command lasts less than the board's
shortest gap-free move (``[ebb] min_move_ms``): a short phase is merged with its neighbour in the
same move, and a move too short even for that is run at the speed that makes it last that long.

Positions are whole motor steps: every move ends on the step nearest its planned end (the error
never accumulates), so a drawn vertex is within one step (1/80 mm on an AxiDraw at 16×) of the
plan's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pencilbot.firmware.ebb import protocol  # the EBB grammar, as the registry holds it
from pencilbot.machine.motion import axis_scale, path_speeds, peak_speed

#: Slowest speed a move starts or ends at, mm/s: an LM axis decelerating to a standstill could
#: stall a fraction of a step short of its target (its rate reaching 0 first).
FLOOR_SPEED = 2.0


@dataclass(frozen=True)
class EbbMove:
    """One command for the board, with what it does.

    Attributes
    ----------
    command : str
        The command text (``LM,...``, ``SP,...``, ``SC,...``).
    line : int
        Index of the job line this command carries out (its move or its pen change).
    start, end : tuple of int
        Motor step positions before and after it.
    seconds : float
        How long it keeps the motion queue busy.
    down : bool
        The pen is down while it runs.
    """

    command: str
    line: int
    start: tuple[int, int]
    end: tuple[int, int]
    seconds: float
    down: bool


def pen_commands(profile) -> list[str]:
    """Set-up: servo positions and rates of the profile, and the pen raised at once."""
    setup, pen = profile.ebb, profile.pen
    return [
        f"SC,4,{setup.servo_position(pen.up)}",
        f"SC,5,{setup.servo_position(pen.down)}",
        f"SC,11,{setup.servo_rate_up}",
        f"SC,12,{setup.servo_rate_down}",
        f"SC,8,{setup.servo_channels}",  # the PWM period the rates assume (3 ms per channel)
    ]


def plan_ebb(
    xy: np.ndarray,
    down: np.ndarray,
    lines: np.ndarray,
    profile,
    *,
    start_steps: tuple[int, int] = (0, 0),
    pen_down: bool | None = False,
) -> list[EbbMove]:
    """The EBB commands that move through ``xy`` with the pen as ``down`` says.

    Parameters
    ----------
    xy : (N, 2) array
        Machine positions (mm) after each job line.
    down : (N,) bool array
        Whether the pen is down after each line.
    lines : (N,) int array
        The job line index of each row.
    profile : Profile
        An EBB profile (motion, pen, ``[ebb]``).
    start_steps : tuple of int
        Motor positions where the carriage stands now.
    pen_down : bool or None
        The pen's state now (None: unknown; the first row's state is then commanded).

    Returns
    -------
    list of EbbMove
    """
    setup, pen = profile.ebb, profile.pen
    moves: list[EbbMove] = []
    here = (int(start_steps[0]), int(start_steps[1]))
    xy, down = np.asarray(xy, dtype=np.float64).reshape(-1, 2), np.asarray(down, dtype=bool)
    if not len(xy):
        return moves
    before = np.vstack([setup.to_machine(np.array([here], dtype=np.float64)), xy[:-1]])
    moved = np.flatnonzero(np.any(np.abs(xy - before) > 1e-9, axis=1))
    was = np.concatenate([[(not down[0]) if pen_down is None else pen_down], down[:-1]])
    changes = np.flatnonzero(down != was)  # the pen changes before the row's move
    edges = [0, *changes.tolist(), len(xy)]
    state = pen_down
    for first, stop in zip(edges[:-1], edges[1:]):
        if first in changes:
            state = bool(down[first])
            delay = pen.down_delay if state else pen.up_delay
            ms = max(int(round(delay * 1000)), 1)
            moves.append(
                EbbMove(setup.pen_command(not state, ms), int(lines[first]), here, here, ms / 1000.0, state)
            )
        rows = moved[(moved >= first) & (moved < stop)]
        if len(rows):
            points = np.vstack([setup.to_machine(np.array([here], dtype=np.float64)), xy[rows]])
            here = _plan_run(points, np.asarray(lines)[rows], bool(state), here, profile, moves)
    return moves


def _plan_run(
    points: np.ndarray, lines: np.ndarray, drawing: bool, here: tuple[int, int], profile, moves: list[EbbMove]
) -> tuple[int, int]:
    """Plan one run of moves without a pen change (vertices ``points``, the first where the pen
    stands); append its commands to ``moves``; return the motor position at its end."""
    setup, motion = profile.ebb, profile.motion
    vectors = np.diff(points, axis=0)
    lengths = np.hypot(vectors[:, 0], vectors[:, 1])
    units = np.column_stack([vectors / np.maximum(lengths, 1e-300)[:, None], np.zeros(len(lengths))])
    scale = axis_scale(units)
    accel = motion.acceleration * scale
    nominal = motion.draw_speed if drawing else motion.travel_speed
    nominal = np.minimum(nominal, _motor_limit(units, setup))
    speeds = path_speeds(
        lengths, units, np.ones(len(lengths) - 1, bool), nominal, accel, motion.junction_deviation
    )
    min_t = setup.min_move_ms / 1000.0
    goals = np.rint(setup.to_motor(points)).astype(np.int64).tolist()
    starts, vec = points.tolist(), vectors.tolist()
    for k, (length_k, v_in, v_out, top, acc) in enumerate(
        zip(lengths.tolist(), speeds[:-1].tolist(), speeds[1:].tolist(), nominal.tolist(), accel.tolist())
    ):
        pieces = _pieces(length_k, v_in, v_out, top, acc, min_t)
        along = 0.0
        for n, (length, v0, v1) in enumerate(pieces):
            along += length
            if n == len(pieces) - 1:
                end = tuple(goals[k + 1])
            else:
                f = along / length_k
                m = setup.motor_of(starts[k][0] + vec[k][0] * f, starts[k][1] + vec[k][1] * f)
                end = (round(m[0]), round(m[1]))
            steps = (end[0] - here[0], end[1] - here[1])
            if steps == (0, 0):
                continue
            moves.append(_lm(steps, length, v0, v1, int(lines[k]), here, end, drawing))
            here = end
    return here


def _motor_limit(units: np.ndarray, setup) -> np.ndarray:
    """Fastest speed (mm/s) along each unit vector that keeps both motors under 25 kHz."""
    motor = np.abs(setup.to_motor(units[:, :2]))
    return protocol.MAX_STEP_RATE * 0.999 / np.maximum(motor.max(axis=1), 1e-12)


def _pieces(
    length: float, v_in: float, v_out: float, nominal: float, accel: float, min_t: float
) -> list[tuple[float, float, float]]:
    """The trapezoid of one move as (length, start speed, end speed) pieces of constant
    acceleration, none shorter than ``min_t`` seconds where the move allows."""
    v_in, v_out = max(v_in, FLOOR_SPEED), max(v_out, FLOOR_SPEED)
    peak = max(peak_speed(length, accel, v_in, v_out, nominal), v_in, v_out)
    d_acc = max((peak * peak - v_in * v_in) / (2 * accel), 0.0)
    d_dec = max((peak * peak - v_out * v_out) / (2 * accel), 0.0)
    cruise = max(length - d_acc - d_dec, 0.0)
    if d_acc + d_dec > length:  # rounding: scale the ramps into the move
        d_acc, d_dec = d_acc * length / (d_acc + d_dec), d_dec * length / (d_acc + d_dec)
    raw = [
        (d, a, b) for d, a, b in ((d_acc, v_in, peak), (cruise, peak, peak), (d_dec, peak, v_out)) if d > 1e-9
    ]
    merged: list[list[float]] = []
    for d, a, b in raw:
        if merged and (_seconds(*merged[-1]) < min_t or _seconds(d, a, b) < min_t):
            merged[-1] = [merged[-1][0] + d, merged[-1][1], b]
        else:
            merged.append([d, a, b])
    if len(merged) > 1 and _seconds(*merged[-1]) < min_t:
        last = merged.pop()
        merged[-1] = [merged[-1][0] + last[0], merged[-1][1], last[2]]
    pieces = [(p[0], p[1], p[2]) for p in merged] or [(length, v_in, v_out)]
    if len(pieces) == 1 and _seconds(*pieces[0]) < min_t:
        slow = length / min_t
        pieces = [(length, slow, slow)]
    return pieces


def _seconds(length: float, v0: float, v1: float) -> float:
    return 2.0 * length / (v0 + v1)


def _lm(
    steps: tuple[int, int],
    length: float,
    v0: float,
    v1: float,
    line: int,
    start: tuple[int, int],
    end: tuple[int, int],
    drawing: bool,
) -> EbbMove:
    """One LM command: both motors at constant acceleration from ``v0`` to ``v1`` (mm/s along
    the path) over ``length`` mm, ``steps`` motor steps."""
    seconds = _seconds(length, v0, v1)
    ticks = max(seconds / protocol.TICK, 1.0)
    args = []
    for n in steps:
        if n == 0:
            args += [0, 0, 0]
            continue
        r0 = protocol.lm_rate(abs(n) * v0 / length)
        r1 = protocol.lm_rate(abs(n) * v1 / length)
        # The rate that covers n steps in the planned ticks: fixes rounding of v0/v1, so both
        # motors end together.
        mean = abs(n) * protocol.ACCUMULATOR / ticks
        r0, r1 = _rescale(r0, r1, mean)
        args += [r0, int(n), int(round((r1 - r0) / ticks))]
    text = "LM," + ",".join(str(a) for a in args)
    return EbbMove(text, line, (int(start[0]), int(start[1])), (int(end[0]), int(end[1])), seconds, drawing)


def _rescale(r0: int, r1: int, mean: float) -> tuple[int, int]:
    """Start and end rates with the given mean, in the ratio of ``r0 : r1``."""
    total = r0 + r1
    if total <= 0:
        return int(round(mean)), int(round(mean))
    f = 2 * mean / total
    r0, r1 = int(round(r0 * f)), int(round(r1 * f))
    cap = protocol.ACCUMULATOR - 1
    return min(max(r0, 1), cap), min(max(r1, 1), cap)
