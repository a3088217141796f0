"""Where a run on a plotter that acknowledges nothing (HP-GL) stands when it stops, and whether a
resume may trust it: the last instruction drawn found from the buffer's count and the pen's
position (:func:`stop_here`), a resume's pen checked against the journal
(:func:`check_resume_position`), the journal and the one message of a stop (:func:`stopped`); the person's pause and stop
requests (:func:`keys_say_pause`, :func:`hold`, :func:`on_signal`)."""

from __future__ import annotations

import threading
import time

import numpy as np

from pencilbot.driver import journal as journal_mod
from pencilbot.driver.hpgl.link import (
    POLL_PAUSE,
    Lost,
    Silent,
    Stopped,
    check_initialised,
    drain,
    poll_free,
    read_status,
)
from pencilbot.errors import PlotError


def stop_here(link, fw, program, size, base, sent_bytes, floor, start, sent, timeout) -> int | None:
    """Abort, lift, and find the last instruction drawn (None: not found)."""
    try:
        free = poll_free(link, fw, timeout)
        floor = max(
            floor, int(np.searchsorted(program.offsets, base + sent_bytes - (size - free), side="right")) - 1
        )
        link.write(fw.abort_bytes)
        poll_free(link, fw, timeout)  # answered after anything the plotter said before the abort
        link.positions.clear()
        link.write(fw.lift_command + fw.sync_command)
        position = link.position(fw, timeout)
    except (Lost, Silent):
        return None
    if position is None:
        return None
    return locate(program, (position[0], position[1]), max(floor - 2, start - 1), sent)


def locate(program, xy, low: int, high: int) -> int | None:
    """The next instruction to send: after the first of entries ``low .. high - 1`` that ends at ``xy``."""
    low = max(low, 0)
    hits = np.flatnonzero(np.all(program.xy[low:high] == np.asarray(xy), axis=1))
    return int(low + hits[0] + 1) if len(hits) else None


def wait_empty(link, fw, size: int, timeout: float) -> None:
    """Until the plotter's buffer is empty (its free bytes the whole buffer), then forget what it
    answered meanwhile (sync points of the run that stopped)."""
    deadline = time.monotonic() + timeout + 600.0  # a full buffer of slow moves
    while poll_free(link, fw, timeout) < size:
        if time.monotonic() > deadline:
            raise Silent()
        time.sleep(POLL_PAUSE)
    link.positions.clear()


def check_resume_position(link, fw, program, start, journal, timeout, name, refuse: bool) -> str | None:
    """A resume trusts the journal only if the pen stands where the stop left it; otherwise it
    is refused (``refuse``: nobody at the terminal), or this says why the stop must be found."""
    link.write(fw.lift_command + fw.sync_command)
    position = link.position(fw, timeout)
    # Everything ran (the sync point answered): the status byte's initialised bit says whether the
    # plotter was switched off and on (or reset) since the stopped run read it.
    reset = position is not None and bool(read_status(link, fw, timeout) & fw.initialised_bit)
    expected = tuple(program.xy[start - 1]) if start > 0 else (0, 0)
    if journal.stop_work and position is not None and (position[0], position[1]) == expected and not reset:
        return None
    where = f"{position[0]},{position[1]}" if position else "unknown"
    why = (
        f"the plotter's pen is at {where} (plotter units), not where the job stopped"
        if not reset
        else f"the plotter was switched off and on (or reset) since the job stopped (its pen at {where})"
    )
    why += f"; what it drew after instruction {journal.acked_line} is not known"
    if position is None or refuse:
        raise PlotError(
            f"cannot resume {name} exactly: {why}. Run the resume in a terminal: it asks you to jog the raised pen to "
            f"where the last line on the sheet ends, and goes on from there. Or restart from an instruction you "
            f"choose: pencilbot draw {journal.gcode} --start-line N --port {journal.port} --profile {journal.profile}"
        )
    return why


def stopped(journal, at, port, why, name, program, *, proven, floor, sent=None, lost=False):
    """Write the journal and raise the message that says how to resume (``lost``: the plotter
    lost its place, so no position it reports later proves anything)."""
    if journal is not None:
        journal.status, journal.message = "stopped", why
        journal.acked_line = floor
        journal.sent_line = sent if sent is not None else journal.sent_line
        if at is not None:
            journal.next_line = at + 1
            journal.stop_work = [float(v) for v in program.xy[at - 1]] if at > 0 else [0.0, 0.0]
        else:
            # Unproven: a lost link lets the plotter finish its buffer; the resume checks the pen stands
            # at the end of what was sent, and refuses otherwise.
            journal.next_line = (sent or floor) + 1
            journal.stop_work = (
                [float(v) for v in program.xy[journal.next_line - 2]]
                if journal.next_line > 1 and not lost
                else None
            )
        # The plotter's own count is its position (HP-GL has no work offsets): the same point.
        journal.stop_mpos = None if journal.stop_work is None else list(journal.stop_work)
        how = journal_mod.save_stopped(journal)
    else:
        how = "draw a file (not a program) to be able to resume"
    state = (
        f"stopped after instruction {at} of {len(program)} (pen up)"
        if at is not None
        else (f"instructions up to {floor} ran; the pen position is not proven")
    )
    raise PlotError(f"{name}: {why}; {state}; {how}")


def keys_say_pause(keys, stop: threading.Event, why: list[str]) -> bool:
    """The terminal's keys: the stop key stops (as Ctrl-C), the pause key asks for a pause."""
    requests = keys.poll()
    if "stop" in requests:
        if not why:
            why.append("the stop key")
        stop.set()
        raise Stopped()
    return "pause" in requests


def hold(operator, keys, stop: threading.Event, why: list[str], shown, prompt: str) -> None:
    """Wait for the person: the operator's answer, or the pause key again (Ctrl-C stops)."""
    shown.show_state(prompt)
    if operator is not None:
        operator.pause(prompt)
    else:
        while not keys_say_pause(keys, stop, why):
            if stop.is_set():
                raise Stopped()
            time.sleep(0.05)
    if stop.is_set():
        raise Stopped()


def settle(link, fw, program, checkpoints, sent, floor, timeout, in_sent: bool) -> None:
    """Until everything sent has run: the open sync points checked, or (none open: the pen may
    stand anywhere, as at the start of a job) a sync point answered."""
    if checkpoints:
        drain(link, fw, program, checkpoints, sent, floor, timeout, in_sent)
        return
    link.write(fw.sync_command)
    if link.position(fw, timeout) is None:
        check_initialised(link, fw, timeout, sent, in_sent)
        raise Silent()


def on_signal(stop: threading.Event, why: list[str]):
    """A handler for :func:`~pencilbot.driver.stop_signals.caught`: the first signal says why,
    each sets ``stop`` (the stream stops at its next poll)."""

    def handler(by: str) -> None:
        if not why:
            why.append(by)
        stop.set()

    return handler
