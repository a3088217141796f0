"""Drawing a job on an EBB board (AxiDraw, NextDraw, iDraw): plan on the host, send step commands.

The job's pen-down and pen-up moves (any G-code: pencilbot's own or another tool's; its modal
state read by :mod:`pencilbot.driver.gcode.modal` with the profile's pen) become ``LM`` and ``SP``
commands (:mod:`pencilbot.machine.ebb_motion`), and its ``G4`` dwells ``SM,ms,0,0`` delays, sent
one at a time: the board answers a motion command once it is in its FIFO, so with one command
running, the FIFO full (one deep at boot; :data:`FIFO_DEPTH` set with ``CU,4`` on firmware 3.x,
within what ``QU,2`` allows) and one being parsed the motors never starve.

What ran is read back, not guessed: a stop (Ctrl-C, SIGTERM, a refused command, a pause key)
sends ``ES`` (stop now, flush the FIFO), lifts the pen, and reads the step counters (``QS``); the
command whose segment holds that position is where the job stopped, and the journal keeps the
position. A resume trusts the board only if its counters still read that position and ``QG``
reports no loss of power; otherwise it refuses until the carriage is put back home.
Both reply syntaxes are read (a board left in "future syntax", ``CU,10,1``, is recognised from
its ``QG`` reply).
"""

from __future__ import annotations

import shlex
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from pencilbot.driver import stop_signals
from pencilbot.driver.ebb.link import LOW_SUPPLY, EbbFault, EbbLink, check_supply, greet, version_at_least
from pencilbot.driver.ebb.moves import job_dwells, plan_from, rows
from pencilbot.driver.faults import Interrupted
from pencilbot.driver.port import DEFAULT_TIMEOUT, LineReader, PortLost, open_port
from pencilbot.driver.progress import Progress
from pencilbot.driver.result import DrawResult
from pencilbot.errors import PlotError
from pencilbot.firmware.base import DEFAULT_BAUD
from pencilbot.firmware.ebb import MICROSTEPS
from pencilbot.machine.ebb_motion import EbbMove, pen_commands

POWER_THRESHOLD = LOW_SUPPLY  # CU,60 units of 29.5 mV: QG bit 6 once the supply drops below 7.4 V
#: Commands the motion FIFO holds on firmware 3.x (CU,4): 16 moves of the 4 ms minimum keep the
#: motors busy through a 64 ms stall of the host or the USB link.
FIFO_DEPTH = 16
POWER_CHECK = 0.5  # s of motion sent between QG queries while streaming (one extra round trip each)


@dataclass
class _Stop:
    index: int  # job line to resume from
    steps: tuple[int, int]
    xy: tuple[float, float]


def draw_ebb(
    job,
    profile,
    port: str,
    journal,
    *,
    start: int = 0,
    resumed=None,
    baud: int = DEFAULT_BAUD,
    progress: str = "quiet",
    timeout: float = DEFAULT_TIMEOUT,
    operator=None,
    keys=None,
    announce=None,
):
    """Draw ``job`` (from job line ``start``) on the EBB board at ``port``; see the module text.
    ``announce(banner, job)`` is told what the board said it is (``V``) before anything moves.

    Returns
    -------
    pencilbot.driver.result.DrawResult

    Raises
    ------
    PlotError
        Any fault, with where the job stopped and how to resume it.
    """
    t0 = time.monotonic()
    xy, down, rows_line = rows(job)
    reader = LineReader(open_port(port, baudrate=baud))
    link = EbbLink(reader, timeout)
    try:
        try:
            here, pen_down, found = _wake(link, profile, job, resumed, operator)
        except EbbFault:
            if link.replies:
                raise
            raise PlotError(link.not_an_ebb(port, profile.name)) from None
        start = start if found is None else found
        if announce is not None:
            announce(f"banner '{link.version}'", job)
        dwells = job_dwells(job)
        work = plan_from(job, xy, down, rows_line, profile, start, here, pen_down, dwells)
        total = sum(item.seconds for item in work if isinstance(item, EbbMove))
        bar = Progress(progress, len(job) - start, total)
        if journal is not None:
            journal.status, journal.message = "running", ""
            journal.save()
        run = _Sending(work)

        def replan(index: int, steps) -> deque:
            return plan_from(job, xy, down, rows_line, profile, index, steps, None, dwells)

        with stop_signals.caught(stop_signals.RaiseOnce()):  # caught through the stop: it is not cut short
            try:
                _send_all(link, run, job, profile, replan, bar, start, operator, keys, timeout)
            except (Interrupted, EbbFault, PortLost) as exc:
                unsent = _next_line(run.work, len(job))
                message = _stop(link, exc, run.sent, run.acked, job, profile, journal, port, unsent)
                bar.close("stopped", message)
                raise PlotError(message) from None
        bar.update(len(job) - start, total, "Idle")
        bar.close("done")
        if journal is not None:
            journal.path.unlink(missing_ok=True)
        return DrawResult(lines_sent=len(job) - start, seconds=time.monotonic() - t0)
    finally:
        try:
            reader.port.close()
        except Exception:  # noqa: BLE001 - a vanished port may fail to close
            pass


@dataclass
class _Sending:
    """How far a run got: the work still to send (its head next), the moves sent, the last one
    the board took, the motion seconds sent and those at the last power check."""

    work: deque
    sent: list[EbbMove] = field(default_factory=list)
    acked: int = -1
    done_seconds: float = 0.0
    checked: float = (
        0.0  # motion seconds sent at the last QG: by the plan, not the clock (the same every run)
    )


def _send_all(
    link: EbbLink, run: _Sending, job, profile, replan, bar, start, operator, keys, timeout
) -> None:
    """Send every move one at a time (the board answers once it is in its FIFO), pausing at the
    program's pauses and the pause key, the supply checked now and then; until the board is idle."""
    sent = run.sent
    while run.work:
        item = run.work[0]  # taken off once sent (or paused at): a stop knows what was next
        if not isinstance(item, EbbMove):  # a program pause (pen change) before job line item
            if sent:
                link.wait_idle(timeout + 60)
                _pause(link, operator, bar, job.pauses[item] or "program pause (M0)")
            run.work.popleft()
            continue
        if link.watch_power and run.done_seconds > run.checked + POWER_CHECK:
            run.checked = run.done_seconds
            link.status()
            if link.power_lost:
                raise EbbFault("the board's supply dropped (QG power-lost bit): the motors may have slipped")
        if keys is not None and _keys_say_pause(keys):
            stop = _hold(link, sent, run.acked, profile, operator, keys, bar, _next_line(run.work, len(job)))
            run.work = replan(stop.index, stop.steps)
            continue
        run.work.popleft()
        sent.append(item)
        link.command(item.command, wait=timeout + 2 * _in_flight_seconds(sent, link))
        run.acked = len(sent) - 1
        run.done_seconds += item.seconds
        bar.update(item.line + 1 - start, run.done_seconds, "Run")
    link.wait_idle(timeout + 2 * _in_flight_seconds(sent, link) + 5)
    if link.power_lost:  # seen while waiting for the last moves
        raise EbbFault("the board's supply dropped (QG power-lost bit): the motors may have slipped")


def _oldest_in_flight(acked: int, link: EbbLink) -> int:
    """The oldest command that may not have finished: the board answers a motion command once
    it is in the FIFO, so when ``acked`` was answered the FIFO's ``fifo_depth`` commands before
    it had moved on to the motors, and all but the last of those had run."""
    return max(acked - link.fifo_depth, 0)


def _in_flight_seconds(sent: list[EbbMove], link: EbbLink) -> float:
    """How long the commands that may still be queued keep the board busy, s: the one running,
    the FIFO's and the one being parsed."""
    return sum(m.seconds for m in sent[-(link.fifo_depth + 2) :])


def _keys_say_pause(keys) -> bool:
    """The terminal's keys: the stop key stops (as Ctrl-C), the pause key asks for a hold."""
    requests = keys.poll()
    if "stop" in requests:
        raise Interrupted("the stop key")
    return "pause" in requests


def _hold(link: EbbLink, sent: list[EbbMove], acked: int, profile, operator, keys, bar, unsent: int) -> _Stop:
    """The pause key: stop at once (ES), lift the pen, find where from the step counters, and
    wait for the operator (or the pause key again); the job goes on from that very point."""
    link.stop_now(wait=link.timeout + 2 * _in_flight_seconds(sent, link))
    link.command(profile.ebb.pen_command(True, max(int(profile.pen.up_delay * 1000), 1)))
    link.wait_idle(5)
    stop = _locate(link.steps(), sent, acked, profile, link, unsent)
    if stop is None:
        raise EbbFault("after the pause the step counters are on none of the moves sent")
    bar.show_state("paused: the pause key")
    if operator is not None:
        operator.pause("paused: the pause key")
    else:
        while not _keys_say_pause(keys):
            time.sleep(0.05)
    return stop


def _wake(
    link: EbbLink, profile, job, resumed, operator=None
) -> tuple[tuple[int, int], bool | None, int | None]:
    """Greet the board, learn its syntax, and set it up; return the motors' position, the pen
    (None: unknown) and, for a resume, the job line to go on from. A resume whose position is
    lost is re-zeroed with ``operator`` (:mod:`pencilbot.driver.ebb.rezero`), or refused."""
    version = greet(link)
    check_supply(link, version)  # a board without motor power: one line, nothing sent
    start = None
    if resumed is not None:
        link.wait_idle(120)  # a board reconnected after a lost cable may still be running its queue
        link.origin = tuple(resumed.options.get("ebb_origin") or (0, 0))  # a re-zeroed job's counters
        steps = link.steps()
        # Where the carriage may stand and the line to go on from there: the stop the board
        # reported, or (the port lost) the end of each command it may have run.
        places = [(tuple(c[:2]), int(c[2])) for c in resumed.options.get("ebb_resume") or ()]
        found = [line for where, line in places if where == steps]
        held = _motors_held(link, profile)
        if link.power_lost or not held or not found:
            why = (
                "the board's supply dropped"
                if link.power_lost
                else "its motors were switched off (a restart or power cut), so the carriage was free"
                if not held
                else f"its step counters read {steps[0]},{steps[1]}, where the job never left the pen"
            )
            if operator is not None:
                from pencilbot.driver.ebb.rezero import rezero

                steps, start = rezero(
                    link, profile, job, resumed, operator, f"the carriage's position is lost ({why})"
                )
                _configure(link, version)
                return steps, False, start
            raise PlotError(
                f"the carriage's position is lost ({why}), so resuming could draw in the wrong place; "
                f"nothing was sent. Run the resume in a terminal, without moving the carriage: it asks you to jog "
                f"the raised pen from where it stopped to a mark, and takes the stop point from that jog: "
                f"{resumed.resume or 'pencilbot draw --resume ' + shlex.quote(str(resumed.path))}. Or push the carriage "
                f"to its home corner (pen up) and draw again from a line: pencilbot draw {shlex.quote(job.source)} "
                f"--profile {shlex.quote(profile.name)} --start-line {resumed.next_line}"
            )
        pen_down, start = None, job.index_of(found[-1])
    else:
        mode = profile.ebb.microstep_mode
        link.command(f"EM,{mode},{mode}")  # counters start at 0: the carriage stands at home
        link.power_lost = False  # a dip before the job cost nothing: the job starts from home
        steps, pen_down = (0, 0), None
    for text in pen_commands(profile):
        link.command(text)
    _configure(link, version)
    return steps, pen_down, start


def _configure(link: EbbLink, version: str) -> None:
    """On firmware 3.x: have QG's bit 6 report a supply drop, and deepen the motion FIFO
    (``CU,4``, at most what ``QU,2`` says; older firmware has one place and no ``QU``)."""
    if not version_at_least(version, (3, 0)):
        link.fifo_depth = 1
        return
    link.command(f"CU,60,{POWER_THRESHOLD}")
    link.watch_power = True
    depth = max(1, min(int(link.answer("QU,2")), FIFO_DEPTH))
    link.command(f"CU,4,{depth}")  # waits for the queue to empty: before any motion
    link.fifo_depth = depth


def _motors_held(link: EbbLink, profile) -> bool:
    """Both motors are on at the profile's microstepping (QE): the counters still mean the
    carriage's position. A board that restarted has them off."""
    try:
        states = [int(v) for v in link.answer("QE").split(",")[:2]]
    except (EbbFault, ValueError):
        return False
    return states == [MICROSTEPS[profile.ebb.microstep_mode]] * 2


def _pause(link: EbbLink, operator, bar, reason: str) -> None:
    """A program pause (a pen change): the pen is up and the motion has ended; wait for the
    operator (the terminal), or for the board's PRG button without one."""
    bar.show_state(f"paused: {reason}")
    if operator is not None:
        operator.pause(f"paused: {reason}")
        return
    link.command("QB")  # forget earlier presses
    while link.answer("QB").strip() != "1":
        time.sleep(0.05)


def _stop(
    link: EbbLink, exc, sent: list[EbbMove], acked: int, job, profile, journal, port, unsent: int
) -> str:
    """Stop the board, find where, record it, and say how to go on (``unsent``: the job line of
    the first command not sent)."""
    why = f"stopped by {exc.by}" if isinstance(exc, Interrupted) else str(exc)
    number = lambda index: job.number(min(index, len(job) - 1)) if len(job) else 0  # noqa: E731
    stop, answered, held = None, False, False
    if not isinstance(exc, PortLost):
        try:
            link.stop_now(wait=link.timeout + 2 * _in_flight_seconds(sent, link))
            link.command(profile.ebb.pen_command(True, max(int(profile.pen.up_delay * 1000), 1)))
            link.wait_idle(5)
            answered = True
            held = _motors_held(link, profile) and not link.power_lost
            stop = _locate(link.steps(), sent, acked, profile, link, unsent) if held else None
        except (EbbFault, PortLost):
            answered = False
    index = sent[_oldest_in_flight(acked, link)].line if sent else 0
    if stop is not None:
        index = stop.index
        where = f"the pen stopped at X{stop.xy[0]:.3f} Y{stop.xy[1]:.3f} (pen up)"
        places = [[*stop.steps, number(stop.index)]]
    elif not answered:
        where = (
            "the board did not report where the pen stopped (the resume finds it from the step "
            "counters, or refuses)"
        )
        places = [[*m.end, number(m.line)] for m in sent[_oldest_in_flight(acked, link) :]]
    else:
        where = (
            "the pen's position is lost (the board restarted or its supply dropped: the motors let go)"
            if not held
            else "the pen's position is lost (the step counters are on none of the moves sent)"
        )
        places = []
    line = number(index)
    text = f"{why}; {where}; line {line} of {job.source} was next."
    if journal is None:
        return f"{text} Resume from line {line} of {job.source}"
    journal.next_line = line
    journal.stop_xy = list(stop.xy) if stop is not None else None
    journal.options["ebb_resume"] = places
    # The moves that may have been running: where a guided re-zero looks for the stop point.
    journal.options["ebb_moves"] = [
        [*m.start, *m.end, number(m.line)] for m in sent[_oldest_in_flight(acked, link) :]
    ]
    journal.options["ebb_origin"] = list(link.origin)
    journal.status, journal.message = "stopped", text
    journal.resume = f"pencilbot draw --resume {shlex.quote(str(journal.path))} --port {shlex.quote(port)}"
    journal.save()
    return f"{text} Resume with: {journal.resume}"


def _next_line(work: deque, end: int) -> int:
    """The job line of the first command (or pause) not sent yet; ``end`` if none is left."""
    return next((item.line if isinstance(item, EbbMove) else item for item in work), end)


def _locate(
    steps: tuple[int, int], sent: list[EbbMove], acked: int, profile, link: EbbLink, unsent: int
) -> _Stop | None:
    """The job line to resume from, given where the motors stopped: the first command still in
    flight (running, in the FIFO, being parsed) whose segment holds the position and
    that had not finished. When all that was sent ran, the line of the last command sent if
    its move is not over (``unsent``, the line of the first command not sent, is the same: a
    move is several commands, accelerate, cruise, decelerate), else the line after it."""
    pos = np.array(steps, dtype=np.float64)
    first = _oldest_in_flight(acked, link)
    for k in range(first, len(sent)):
        move = sent[k]
        a, b = np.array(move.start, float), np.array(move.end, float)
        if np.array_equal(pos, b):
            continue  # ran to its end
        if _on_segment(pos, a, b):
            return _Stop(move.line, steps, _mm(profile, steps))
    if sent and np.array_equal(pos, np.array(sent[-1].end, float)):
        line = sent[-1].line + (unsent != sent[-1].line)  # all it was sent ran: its move's end, or a part
        return _Stop(line, steps, _mm(profile, steps))
    return None  # on none of the commands in flight: the position is lost


def _on_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray, tol: float = 2.0) -> bool:
    d = b - a
    n = float(np.hypot(*d))
    if n == 0:
        return bool(np.hypot(*(p - a)) <= tol)
    along = float(np.dot(p - a, d)) / n
    across = abs(float(d[0] * (p - a)[1] - d[1] * (p - a)[0])) / n
    return -tol <= along <= n + tol and across <= tol


def _mm(profile, steps) -> tuple[float, float]:
    x, y = profile.ebb.to_machine(np.array([steps], dtype=float))[0]
    return round(float(x), 4), round(float(y), 4)
