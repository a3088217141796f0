"""Where the pen is after a stop: proven by the board, or re-established with the user.

A GRBL board's position is only a count of steps. It is true after a feed hold brought the
machine to rest; it is lost when the board resets in motion (``ALARM:3``: the carriage coasts on
past the count), after a limit alarm, and when the board powers up (a power cut, or the DTR
line of the port resetting an Arduino as the port opens): the count starts at 0, 0 wherever the
carriage stands. A resume trusts the board only when what it reports agrees with what the stop
proved (see :func:`pencilbot.driver.plot.draw`); otherwise the origin is re-established:

* homing (``$H``) where the profile has switches, when the stop point itself is known;
* a guided re-zero: the user jogs the (raised) pen from where it stopped to a mark the driver
  names. The jog's length, counted by the board, says where the pen stood when the job
  stopped (and so which line it was drawing), and ``G10 L20 P0`` makes the mark read its own
  coordinates again;
* without someone at the machine, a refusal that says what to do.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from pencilbot.errors import PlotError
from pencilbot.firmware.base import ERROR
from pencilbot.units import DEFAULT_PEN_WIDTH

#: mm within which two positions the board reported (to 1 µm) are the same place.
NEAR = 0.0015
_SEARCH = 4096  # job lines tracked at a time when looking for the first stroke
#: mm: the smallest step the jog keys move (:mod:`pencilbot.driver.keys`), so the closest a
#: person can bring the pen to a mark: within half of it in X and in Y.
FINE_JOG_STEP = 0.1


def rezero_tolerance(pen_width: float = DEFAULT_PEN_WIDTH, step: float = FINE_JOG_STEP) -> float:
    """How far (mm) from the true stop point a hand re-zero may put it and still find it.

    A person jogging in ``step`` mm steps gets the pen within half a step of the mark in X and
    in Y (at most ``step·√2/2`` away: 3/4 of a step covers it), never more than half the pen's
    width (``pen_width`` mm): an error that large would show as a gap or a doubled stretch.
    The stop point is then taken on the job's path, and the origin set again from it.
    """
    return max(min(0.75 * step, pen_width / 2), 1e-3)  # no finer than the board reports


def coast_limit(motion) -> float:
    """mm a carriage can run on after its motors stop dead (a reset or alarm in motion): from
    the top speed (both axes at their rate) at the machine's acceleration, v²/2a."""
    speed = motion.axis_rate / 60.0 * 2**0.5
    return speed * speed / (2.0 * motion.acceleration * 2**0.5)


def near(a, b, tolerance: float = NEAR) -> bool:
    """Whether positions ``a`` and ``b`` (X, Y in mm) agree."""
    return a is not None and b is not None and abs(a[0] - b[0]) <= tolerance and abs(a[1] - b[1]) <= tolerance


def pen_down_in(status, pen) -> bool | None:
    """Whether a status report shows the pen down: from the spindle value (a servo or spindle
    pen) or Z (a Z pen); None when the report cannot tell."""
    if status is None:
        return None
    if pen.kind == "spindle" and status.spindle is not None:
        return pen.is_down(status.spindle)
    if pen.kind == "z" and status.wpos is not None and len(status.wpos) > 2:
        return pen.is_down(status.wpos[2])  # pen heights are work Z
    return None


class Operator(Protocol):
    """Someone at the machine (the terminal of ``draw``, or ``simulate`` playing the part).

    ``jog_step`` (optional attribute, mm): the finest step its jogs move, so how close to a mark
    it can bring the pen (:func:`rezero_tolerance`); :data:`FINE_JOG_STEP` when not given.
    """

    def pause(self, prompt: str) -> None:
        """Show ``prompt`` (a program pause: ``pen change: insert …``) and return to go on."""

    def jog_to_mark(self, prompt: str, mark: Mark, jog: Callable[[float, float], None]) -> None:
        """Show ``prompt``; let the user move the pen with ``jog(dx, dy)`` (mm) until it stands
        over ``mark``, then return. Raise :class:`~pencilbot.errors.PlotError` to give up."""


@dataclass(frozen=True)
class Mark:
    """A point on the paper the user can find: ``xy`` in work mm, ``text`` says what it is."""

    xy: tuple[float, float]
    text: str


def mark_before(job, limit: int, to_mm: float) -> Mark:
    """The mark for a re-zero: the start of the job's first stroke if a line before ``limit``
    (certainly run) drew it, else the work origin X0 Y0 (where the pen stood when the job began).

    ``to_mm`` converts job units to mm (25.4 for an inch job)."""
    previous = job.state_after(-1)
    for first in range(0, min(limit, len(job)), _SEARCH):
        states = job.states(first, min(first + _SEARCH, limit, len(job)))
        for i in range(first, first + len(states)):
            state = states[i]
            if state.pen_down and previous.pen_down and (state.x, state.y) != (previous.x, previous.y):
                x, y = previous.x * to_mm, previous.y * to_mm
                return Mark(
                    (x, y),
                    f"the start of the first stroke (X{x:.3f} Y{y:.3f}, drawn by file line {job.number(i)})",
                )
            previous = state
    return Mark((0.0, 0.0), "the job's origin X0 Y0 (where the pen stood when the job first started)")


def refusal(why: str, mark: Mark, resume_command: str, homing: bool) -> PlotError:
    """The message when the position is lost and nobody is at the machine to re-establish it."""
    home = " (homing alone cannot tell where the pen stopped)" if homing else ""
    return PlotError(
        f"{why}: the plotter's position cannot be trusted, so the job does not resume by itself{home}. "
        f"Run the resume in a terminal: {resume_command}. Do not move the pen first: it asks you to jog the "
        f"raised pen from where it stopped to {mark.text}, and takes both the stop point and the origin "
        "from that jog"
    )


def jog_to_mark(
    stream,
    profile,
    operator: Operator,
    mark: Mark,
    why: str,
    alarm: bool,
    count: tuple[float, float] | None = None,
) -> tuple[float, float]:
    """Guided re-zero: the user jogs the pen from where it stopped to ``mark``.

    ``count``: where the board counted the pen when the job stopped (work mm), kept although it
    could not be proven (a reset or alarm in motion). When the jog puts the stop within
    :func:`rezero_tolerance` of it, the motors did not slip: the count is exact where a hand is
    only as good as its finest step, so it gives both the stop point and the origin.

    Returns
    -------
    (float, float)
        Where the pen stood before the jog, in work mm of the restored origin (the job's frame).
    """
    fw = profile.firmware

    def setup(line: str, doing: str) -> None:
        if line and stream.command(line).kind == ERROR:
            raise PlotError(f"the plotter refused {line!r} while {doing}; check the profile")

    if alarm:
        setup(fw.unlock_command, "unlocking to jog")  # the user is at the machine and asked to move it
    for line in profile.pen_model.up_lines:
        setup(line, "raising the pen to jog")
    stream.wait_until_still()
    before = stream.machine_position()
    feed = profile.motion.travel_feed
    operator.jog_to_mark(
        f"{why}. Jog the raised pen from where it stopped (do not move it by hand) until it stands exactly "
        f"over {mark.text} (close enough: within {FINE_JOG_STEP / 2:g} mm of it in X and in Y, so finish "
        f"with the {FINE_JOG_STEP:g} mm step), then confirm",
        mark,
        lambda dx, dy: stream.jog(dx, dy, feed),
    )
    stream.wait_until_still()
    after = stream.machine_position()
    if before is None or after is None:
        raise PlotError("the plotter did not report its position during the re-zero; nothing was drawn")
    dx, dy = after[0] - before[0], after[1] - before[1]
    x, y = mark.xy
    here = x - dx, y - dy
    if count is not None and near(here, count, rezero_tolerance()):
        here = count[0], count[1]
        x, y = here[0] + dx, here[1] + dy  # where the pen is now, by the count and the jog
    setup(fw.set_origin(x, y), "setting the origin at the mark")
    return here
