"""The wire to a plotter that acknowledges nothing (HP-GL, :mod:`pencilbot.driver.hpgl.plot`): its
answers (free buffer bytes, sync points' positions; XON/XOFF noted), the free-bytes poll, and the
sync points that prove what ran and where the pen is."""

from __future__ import annotations

import time

import serial

from pencilbot.driver.port import listened

POLL_PAUSE = 0.02  # s between polls while the buffer is full, or a sync point's answer is awaited


class Lost(Exception):
    """The port went away."""


class Stopped(Exception):
    """The person asked to stop (a signal, the stop key): the sender stops the plotter."""


class Answers:
    """CR- (or LF-) terminated answers from the port; XON/XOFF bytes noted, not returned."""

    def __init__(self, port, parse_position=None):
        self.port = port
        self.partial = b""
        self.lines: list[str] = []
        self.positions: list = []
        self.parse_position = parse_position
        self.xoff = False
        #: Seconds spent in reads that found nothing: the plotter's silence as this host heard
        #: it (time the host spent elsewhere, a loaded machine's, is not the plotter's).
        self.listened = 0.0

    def write(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise Lost(str(exc)) from None

    def pump(self) -> None:
        asked = time.monotonic()
        try:
            data = self.port.read(max(self.port.in_waiting, 1))
        except (serial.SerialException, OSError) as exc:
            raise Lost(str(exc)) from None
        if not data:
            self.listened += listened(self.port, asked)
            return
        if b"\x13" in data or b"\x11" in data:
            self.xoff = data.rfind(b"\x13") > data.rfind(b"\x11")
            data = data.replace(b"\x13", b"").replace(b"\x11", b"")
        *done, self.partial = (self.partial + data).replace(b"\n", b"\r").split(b"\r")
        for line in (d.decode("ascii", errors="replace").strip() for d in done if d.strip()):
            position = self.parse_position(line) if self.parse_position else None
            if position is not None:
                self.positions.append(position)  # a sync point's answer, kept in order
            else:
                self.lines.append(line)

    def position(self, fw, timeout: float, stop=None):
        """The next sync point's answer ``(x, y, pen down)``, or None after ``timeout`` s. The
        free bytes are polled meanwhile: a plotter that stops answering is caught sooner, and a
        plotter on a poll clock (the virtual one in tests) goes on as the sender waits. ``stop``
        (an event) set meanwhile raises :class:`Stopped`. The time counted is the host's
        waiting (its reads that found nothing and its pauses), never its stalls."""
        waited = -self.listened
        while not self.positions:
            if stop is not None and stop.is_set():
                raise Stopped()
            if waited + self.listened > timeout:
                return None
            poll_free(self, fw, timeout)
            if not self.positions:
                time.sleep(POLL_PAUSE)
                waited += POLL_PAUSE
        return self.positions.pop(0)

    def wait(self, accept, timeout: float):
        """The first answer ``accept`` turns into something not None (others are dropped), or
        None once the host has listened ``timeout`` s for it in vain."""
        start = self.listened
        while True:
            while self.lines:
                value = accept(self.lines.pop(0))
                if value is not None:
                    return value
            if self.listened - start > timeout:
                return None
            self.pump()


class Silent(Exception):
    """The plotter did not answer."""


class Moved(Exception):
    """A sync point's answer is not where the program put the pen."""


def check_point(position, program, checkpoints: list[int]) -> int:
    """``position`` answers the first of the sync points ``checkpoints`` (entries after which
    each was sent) still open: it must be their end. An answer that matches a later one means
    the earlier answers were lost on the line; they are dropped with it. Returns the entry the
    answer proves ran (all before it did)."""
    ends = [
        (int(program.xy[k - 1, 0]), int(program.xy[k - 1, 1]), bool(program.down[k - 1]))
        if k
        else (0, 0, False)
        for k in checkpoints
    ]
    for j, end in enumerate(ends):
        if tuple(position) == end:
            proven = checkpoints[j]
            del checkpoints[: j + 1]
            return proven
    after, expected = checkpoints[0], ends[0]
    state = lambda p: f"{p[0]},{p[1]} pen {'down' if p[2] else 'up'}"  # noqa: E731
    raise Moved(
        f"the plotter's pen was at {state(position)} after instruction {after}, not at {state(expected)}: "
        "it lost its place (switched off and on, or reset)"
    )


def drain(
    link: Answers,
    fw,
    program,
    checkpoints: list[int],
    upto: int,
    floor: int,
    timeout: float,
    in_sent: bool | None = None,
    stop=None,
) -> None:
    """Until everything sent (entries before ``upto``) has run: a sync point is answered once
    everything before it ran (the buffer holds ≤ its size in bytes). Unanswered, and ``in_sent``
    given (an ``IN`` sent since the status was read): a reset may have taken the sync point
    with the buffer, which the status byte tells (:func:`check_initialised`). ``stop`` set
    meanwhile (a signal while the buffer's last kilobyte draws) raises :class:`Stopped`."""
    link.write(fw.sync_command)
    checkpoints.append(upto)
    while checkpoints:
        position = link.position(fw, timeout + 0.5 * (upto - floor), stop)
        if position is None:
            if in_sent is not None:
                check_initialised(link, fw, timeout, upto, in_sent)
            raise Silent()
        check_point(position, program, checkpoints)


def read_status(link: Answers, fw, timeout: float) -> int:
    """The status byte (``OS;``), asked only when nothing sent is still to run and no other
    answer is awaited (its answer is a bare number, as the free bytes' is); a lost answer is
    asked again, garbage is skipped."""
    return _ask(link, fw.status_command, fw.parse_status, timeout)


def check_initialised(link: Answers, fw, timeout: float, after: int, expected: bool) -> None:
    """Read the status byte; its initialised bit set when no ``IN`` ran since it was last read
    (``expected`` False) means the plotter was switched off and on, or reset: its buffer is gone,
    though the pen may stand where the program would have put it (at home)."""
    if read_status(link, fw, timeout) & fw.initialised_bit and not expected:
        raise Moved(
            f"the plotter says it was initialised after instruction {after} (OS bit 8) with no IN "
            "instruction sent: it lost its place (switched off and on, or reset)"
        )


def poll_free(link: Answers, fw, timeout: float) -> int:
    """Free buffer bytes; one lost answer is asked again, garbage is skipped."""
    return _ask(link, fw.free_query, fw.parse_free, timeout)


def _ask(link: Answers, query: bytes, parse, timeout: float) -> int:
    """``query``'s answer as ``parse`` reads it; a lost answer is asked once more (half the
    timeout each), garbage is skipped; two lost answers: :class:`Silent`."""
    for _ in range(2):
        link.write(query)
        answer = link.wait(parse, timeout / 2)
        if answer is not None:
            return answer
    raise Silent()
