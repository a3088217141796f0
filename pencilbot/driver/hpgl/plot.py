"""Streaming to a plotter that acknowledges nothing (HP-GL): poll its free buffer bytes.

The firmware module says how (``flow = "polled"``): ``free_query`` asks how many bytes of the
input buffer are free (HP-GL ``ESC.B``, answered at once), ``sync_command`` is answered only
once everything before it has run (HP-GL ``OA;``, with the pen position), ``abort_bytes``
discard the buffer (``ESC.K``). The sender never writes more than the board said is free, so
the buffer cannot overflow, whatever the wire does.

What ran: the buffer holds the bytes not yet started, so ``sent − (size − free)`` bytes have
run or are running. A stop polls once more, aborts, lifts the pen and asks the position; the
first instruction at or after that floor whose end is that position is the last one drawn, and
the job resumes after it — exactly once. If no instruction there ends where the pen is (the
plotter was power-cycled, or the link was lost mid-job and the position does not match), the
resume is refused until the user chooses ``--start-line``.

A reset the positions cannot show (the pen homed where the program would have put it, e.g. its
park at home after everything was sent) is caught by the status byte (``OS;``): its
initialised bit is read once after the plotter's power-up and after each ``IN`` has run
(clearing it), and set at the next read (a pen change, the end) means the plotter lost its place.

Pauses: the pause key stops at once as a stop does (abort, lift, locate), waits for the person
(the terminal's prompt, or the pause key again) and goes on from the very instruction; a pen the
carousel lacks (a plan with more pens than ``[paper] carousel``) waits until everything before
it has run (a sync point), puts the pen away and asks for the pen to be put in its slot.
"""

from __future__ import annotations

import threading
import time
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import serial

from pencilbot.driver import journal as journal_mod
from pencilbot.driver import stop_signals
from pencilbot.driver.hpgl.link import (
    POLL_PAUSE,
    Answers,
    Lost,
    Moved,
    Silent,
    Stopped,
    check_initialised,
    check_point,
    drain,
    poll_free,
    read_status,
)
from pencilbot.driver.port import DEFAULT_TIMEOUT, open_port
from pencilbot.driver.progress import Progress
from pencilbot.driver.result import DrawResult
from pencilbot.errors import PlotError, RefusedError
from pencilbot.machine.motion import axis_scale, move_times


def draw_polled(
    data: bytes,
    port: str,
    plotter,
    *,
    path: Path | None,
    profile_arg: str,
    baud: int | None,
    start: int = 0,
    journal=None,
    timeout: float = DEFAULT_TIMEOUT,
    progress: str = "quiet",
    announce=None,
    source: str | None = None,
    operator=None,
    keys=None,
):
    """Stream an HP-GL program to a polled-flow plotter; see the module docstring.

    Parameters
    ----------
    data : bytes
        The program (a file's bytes).
    port : str
        Device or pyserial URL.
    plotter : Profile
        The plotter (its firmware has ``flow = "polled"``).
    path : Path or None
        The file (only a file gets a journal and a resume).
    start : int
        First instruction (0-based, of :class:`~pencilbot.firmware.hpgl.Program`) to send.
    journal : Journal, optional
        The stopped job being resumed (its proven stop position is checked first).
    operator : pencilbot.driver.position.Operator, optional
        Someone at the machine: answers the pauses (the pause key, a pen change).
    keys : pencilbot.driver.keys.KeyReader, optional
        The terminal's keys: pause / resume and stop.

    Returns
    -------
    pencilbot.driver.result.DrawResult

    Raises
    ------
    PlotError
        Any fault, with the command that resumes the job.
    """

    fw = plotter.firmware
    name = source or (str(path) if path else "the program")
    try:
        program, changes = fw.program(data).in_carousel(plotter.paper.carousel)
    except ValueError as exc:  # the file, before anything is sent: bad input, not a stopped plot
        raise RefusedError(f"{name}: {exc}") from None
    if not program.frames:
        raise RefusedError(f"{name} holds no HP-GL instructions; export a drawing first (pencilbot export)")
    _check_limits(program, plotter, fw, name)
    resuming = journal is not None
    # A resume may start past the last move: everything was sent, and the stop (a plotter that
    # lost its buffer) is found on the sheet among what was sent.
    if not 0 <= start < max(len(program) + resuming, 1):
        raise RefusedError(f"--start-line {start + 1} is outside {name} (moves 1..{len(program)})")
    baud = baud or fw.baud
    if path is not None and journal is None:
        journal = journal_mod.Journal(
            gcode=str(path.resolve()),
            sha256=journal_mod.file_sha256(path),
            port=port,
            profile=profile_arg,
            total_lines=len(program),
            path=journal_mod.journal_path(path),
        )
    if journal is not None:
        journal.port, journal.status, journal.options = port, "running", {"baud": baud, "timeout": timeout}
        journal.save()
    seconds = _seconds_after(program, plotter)
    shown = Progress(
        progress, len(program) - start, float(seconds[-1] - (seconds[start - 1] if start else 0.0))
    )
    done0 = seconds[start - 1] if start else 0.0
    stop = threading.Event()
    why: list[str] = []
    signals = ExitStack()  # closed last, in the finally: a signal during the stop is noted, not obeyed
    signals.enter_context(stop_signals.caught(_on_signal(stop, why)))
    began = time.monotonic()
    link = None
    sent = floor = start
    finished = False
    try:
        try:
            link = Answers(open_port(port, baudrate=baud, profile=profile_arg), fw.parse_position)
        except PlotError:
            raise
        size = plotter.receive_buffer
        try:
            link.port.reset_input_buffer()  # nothing from before this job
        except (serial.SerialException, OSError) as exc:
            raise Lost(str(exc)) from None
        link.write(fw.wake_bytes)
        if link.wait(lambda t: t if t.strip().lstrip("-").isdigit() else None, timeout) is None:
            raise PlotError(
                f"no answer from an HP-GL plotter on {port} (ESC.E): is it on, at {baud} bit/s, "
                "on a null-modem cable?"
            )
        link.write(fw.identify_command)
        identity = link.wait(lambda t: t if fw.is_identity(t) else None, timeout)
        link.positions.clear()
        if not resuming and not (start == 0 and len(program) and program.frames[0].startswith(b"IN")):
            read_status(
                link, fw, timeout
            )  # OI answered: idle; this clears the initialised bit of its power-up
        if announce is not None:
            announce(f"banner '{identity or 'no answer to OI;'}'", (plotter, len(program)))
        if resuming:
            _wait_empty(
                link, fw, size, timeout
            )  # a plotter plugged back in may still be drawing what it held
            lost = _check_resume_position(link, fw, program, start, journal, timeout, name, operator is None)
            pen_at = None
            if lost is not None:  # someone at the plotter shows where the drawing on the sheet ends
                from pencilbot.driver.hpgl.refind import refind

                start, pen_at = refind(link, fw, program, journal, operator, plotter, timeout, lost)
                sent = floor = start
            link.write(program.preamble(start, pen_at))
        elif start > 0:
            link.write(program.preamble(start))
        # The status byte is read after each IN has run (the preamble's, the program's): its
        # initialised bit set any other time means the plotter was reset (see check_initialised).
        after_in = {int(i) + 1 for i in np.flatnonzero([f.startswith(b"IN") for f in program.frames])}
        in_sent = resuming or start > 0
        if in_sent:
            after_in.add(start)
        sent_bytes = 0
        checkpoints: list[int] = []  # entries after which a sync point was sent, not yet answered
        base = program.offsets[start]
        floor = start
        last_save = 0.0
        paused_at = -1  # the pen change answered (not asked again)
        proven = start  # entries before it ran, by a sync point's answer (in this power-on)
        pending = sorted(changes)
        while sent < len(program):
            if in_sent and sent in after_in:  # before a stop: a resume finds the bit clear unless reset
                _settle(link, fw, program, checkpoints, sent, floor, timeout, in_sent)
                read_status(link, fw, timeout)  # set by the IN: cleared
                in_sent, floor = False, sent
                continue
            if stop.is_set():
                raise Stopped()
            if keys is not None and _keys_say_pause(keys, stop, why):
                at = _stop_here(link, fw, program, size, base, sent_bytes, floor, start, sent, timeout)
                if at is None:
                    raise Moved("after the pause key the pen stood on none of the instructions sent")
                _hold(operator, keys, stop, why, shown, "paused: the pause key")
                sent = floor = at
                base, sent_bytes = program.offsets[at], 0
                checkpoints.clear()
                continue
            if sent in changes and paused_at != sent:
                if sent_bytes:
                    drain(link, fw, program, checkpoints, sent, floor, timeout, in_sent)
                else:  # nothing of the program sent since the resume's preamble (pen up): it ran
                    link.write(fw.sync_command)
                    if link.position(fw, timeout) is None:
                        raise Silent()
                check_initialised(link, fw, timeout, sent, in_sent)
                in_sent, floor = False, sent
                link.write(fw.park_command)  # the pen back in the carousel: its slot can be filled
                if operator is None and keys is None:
                    why.append(f"a pen change ({changes[sent]}) with nobody at the terminal to do it")
                    raise Stopped()
                _hold(operator, keys, stop, why, shown, f"paused: {changes[sent]}")
                paused_at = sent
                continue
            free = poll_free(link, fw, timeout)
            used = size - free
            # Bytes of the program not started yet: the buffer's, less the sync points still in it.
            waiting = used - len(fw.sync_command) * len(checkpoints)
            floor = max(
                floor, int(np.searchsorted(program.offsets, base + sent_bytes - waiting, side="right")) - 1
            )
            if checkpoints and not link.positions and floor > checkpoints[0] + 1:
                checkpoints.pop(0)  # it ran and its answer came before this one's: lost on the line
            room = max(free - fw.reserve(size), 0) if not link.xoff else 0  # never to the brim
            end = int(np.searchsorted(program.offsets, program.offsets[sent] + room, side="right")) - 1
            later = list(pending[int(np.searchsorted(pending, sent, side="right")) :][:1])
            later += [k for k in after_in if k > sent]
            end = min([end, *later])  # a pen change waits for everything before it; the status, for an IN
            if end <= sent:
                time.sleep(POLL_PAUSE)
                continue
            chunk = b"".join(program.frames[sent:end])
            sent_bytes += len(chunk)
            if (
                not checkpoints
                and end < len(program)
                and end not in after_in
                and len(chunk) + len(fw.sync_command) <= room
            ):
                # A sync point now and then: its answer must be where the program put the pen,
                # or the plotter lost it (a power cycle clears the buffer and homes the pen).
                chunk += fw.sync_command
                checkpoints.append(end)
            link.write(chunk)
            in_sent = in_sent or any(k in after_in for k in range(sent + 1, end + 1))
            sent = end
            while link.positions and checkpoints:
                proven = check_point(link.positions.pop(0), program, checkpoints)
            if floor > start:
                shown.update(floor - start, float(seconds[floor - 1] - done0), "Run")
            if journal is not None and time.monotonic() - last_save > 0.2:
                journal.next_line, journal.sent_line, journal.acked_line = sent + 1, sent, floor
                journal.save()
                last_save = time.monotonic()
        drain(link, fw, program, checkpoints, len(program), floor, timeout, in_sent, stop)
        # A reset after everything was sent leaves the pen at home, pen up: where many programs end.
        check_initialised(link, fw, timeout, len(program), in_sent)
        if journal is not None and journal.path is not None:
            journal.path.unlink(missing_ok=True)
        shown.update(len(program) - start, float(seconds[-1] - done0), "Idle", force=True)
        shown.close("done")
        finished = True
        return DrawResult(lines_sent=len(program) - start, seconds=time.monotonic() - began)
    except Stopped:
        assert link is not None
        at = _stop_here(link, fw, program, size, base, sent_bytes, floor, start, sent, timeout)
        _stopped(
            journal,
            at,
            port,
            f"stopped by {why[0] if why else 'the operator'}",
            name,
            program,
            proven=at is not None,
            floor=floor,
        )
    except Moved as exc:
        assert link is not None  # Moved comes from reading the plotter
        try:
            link.write(fw.abort_bytes + fw.lift_command)  # draw nothing more where the pen is not
        except Lost:
            pass
        # What ran after the last sync point the plotter answered right is not known: its buffer went.
        _stopped(
            journal, None, port, str(exc), name, program, proven=False, floor=proven, sent=sent, lost=True
        )
    except Lost as exc:
        _stopped(
            journal,
            None,
            port,
            f"the port was lost ({exc})",
            name,
            program,
            proven=False,
            floor=floor,
            sent=sent,
        )
    except Silent:
        _stopped(
            journal,
            None,
            port,
            f"the plotter did not answer for {timeout:g} s",
            name,
            program,
            proven=False,
            floor=floor,
            sent=sent,
        )
    finally:
        if not finished:
            shown.close("stopped")
        signals.close()
        if link is not None:
            try:
                link.port.close()
            except Exception:  # noqa: BLE001 - a vanished port may fail to close
                pass
    raise AssertionError("unreachable")


def _keys_say_pause(keys, stop: threading.Event, why: list[str]) -> bool:
    """The terminal's keys: the stop key stops (as Ctrl-C), the pause key asks for a pause."""
    requests = keys.poll()
    if "stop" in requests:
        if not why:
            why.append("the stop key")
        stop.set()
        raise Stopped()
    return "pause" in requests


def _hold(operator, keys, stop: threading.Event, why: list[str], shown, prompt: str) -> None:
    """Wait for the person: the operator's answer, or the pause key again (Ctrl-C stops)."""
    shown.show_state(prompt)
    if operator is not None:
        operator.pause(prompt)
    else:
        while not _keys_say_pause(keys, stop, why):
            if stop.is_set():
                raise Stopped()
            time.sleep(0.05)
    if stop.is_set():
        raise Stopped()


def _settle(link, fw, program, checkpoints, sent, floor, timeout, in_sent: bool) -> None:
    """Until everything sent has run: the open sync points checked, or (none open: the pen may
    stand anywhere, as at the start of a job) a sync point answered."""
    if checkpoints:
        drain(link, fw, program, checkpoints, sent, floor, timeout, in_sent)
        return
    link.write(fw.sync_command)
    if link.position(fw, timeout) is None:
        check_initialised(link, fw, timeout, sent, in_sent)
        raise Silent()


def _stop_here(link, fw, program, size, base, sent_bytes, floor, start, sent, timeout) -> int | None:
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
    return _locate(program, (position[0], position[1]), max(floor - 2, start - 1), sent)


def _locate(program, xy, low: int, high: int) -> int | None:
    """The next instruction to send: after the first of entries ``low .. high - 1`` that ends at ``xy``."""
    low = max(low, 0)
    hits = np.flatnonzero(np.all(program.xy[low:high] == np.asarray(xy), axis=1))
    return int(low + hits[0] + 1) if len(hits) else None


def _wait_empty(link, fw, size: int, timeout: float) -> None:
    """Until the plotter's buffer is empty (its free bytes the whole buffer), then forget what it
    answered meanwhile (sync points of the run that stopped)."""
    deadline = time.monotonic() + timeout + 600.0  # a full buffer of slow moves
    while poll_free(link, fw, timeout) < size:
        if time.monotonic() > deadline:
            raise Silent()
        time.sleep(POLL_PAUSE)
    link.positions.clear()


def _check_resume_position(link, fw, program, start, journal, timeout, name, refuse: bool) -> str | None:
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


def _stopped(journal, at, port, why, name, program, *, proven, floor, sent=None, lost=False):
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


def _on_signal(stop: threading.Event, why: list[str]):
    """A handler for :func:`~pencilbot.driver.stop_signals.caught`: the first signal says why,
    each sets ``stop`` (the stream stops at its next poll)."""

    def handler(by: str) -> None:
        if not why:
            why.append(by)
        stop.set()

    return handler


def _seconds_after(program, plotter) -> np.ndarray:
    """The plot time (s) after each entry, for the progress display: each move from rest to rest
    at its speed (VS pen down, else the profile's) with the profile's acceleration, as the
    virtual plotter times it, each lift and drop its delay."""
    if not len(program):
        return np.zeros(1)
    step = np.diff(program.xy, axis=0, prepend=np.zeros((1, 2), np.int64)) * plotter.paper.unit_mm
    length = np.hypot(*step.T)
    speed = np.where(
        program.down,
        np.where(program.speed > 0, program.speed * 10.0, plotter.motion.draw_speed),
        plotter.motion.travel_speed,
    )
    moving = length > 0
    units = np.where(moving[:, None], step / np.where(moving, length, 1.0)[:, None], 1.0)
    seconds = np.where(
        moving, move_times(length, 0.0, 0.0, speed, plotter.motion.acceleration * axis_scale(units)), 0.0
    )
    pen = plotter.pen_model
    changed = np.diff(program.down.astype(np.int8), prepend=np.int8(0))
    delays = np.where(changed > 0, pen.down_delay, np.where(changed < 0, pen.up_delay, 0.0))
    return np.cumsum(seconds + delays)


def _check_limits(program, plotter, fw, name) -> None:
    """Every position within the bed (the plotter's hard-clip limits), before the port opens."""
    if not len(program):
        return
    w, h = round(plotter.bed.width / plotter.paper.unit_mm), round(plotter.bed.height / plotter.paper.unit_mm)
    bad = np.flatnonzero(
        (program.xy[:, 0] < 0) | (program.xy[:, 1] < 0) | (program.xy[:, 0] > w) | (program.xy[:, 1] > h)
    )
    if len(bad):
        k = bad[0]
        raise PlotError(
            f"{name}: instruction {program.lines[k]} goes to {program.xy[k, 0]},{program.xy[k, 1]}, beyond the limits of "
            f"{plotter.name} (0..{w} x 0..{h} plotter units); export the drawing for this sheet"
        )
