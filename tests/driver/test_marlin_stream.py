"""Marlin streaming over a real pty: numbered, checksummed lines, Resend after line noise, busy.

The virtual plotter speaks GRBL only, so the board here is a small Marlin line-protocol front
end built on :mod:`firmware_protocol.marlin` (the same framing rules the driver uses are checked
from the board's side with ``unframe_line``). It answers the way Marlin 2 does: ``start`` on
open, ``ok`` per good line, ``Error:…`` + ``Resend: N`` + ``ok`` for a corrupt or out-of-order
line, and ``echo:busy: processing`` while a slow command runs.
"""

import os
import select
import time

import pytest
from pty_board import PtyBoard

from firmware_protocol import marlin
from pencilbot.driver import draw
from pencilbot.driver.gcode.modal import clean_line
from pencilbot.errors import PlotError

PROFILE = "marlin-servo-a4"
BUSY_EVERY = 0.1  # s between a busy board's keep-alives (Marlin's default is 2 s)


class MarlinBoard(PtyBoard):
    """Marlin's serial line protocol on a pty; ``noise_on`` = frame numbers to corrupt once."""

    def __init__(self, noise_on=(), busy_seconds=0.0, slow=("G4",)):
        super().__init__()
        self.noise_on = set(noise_on)
        self.busy_seconds = busy_seconds
        self.slow = slow  # command prefixes that keep the board busy for busy_seconds
        self.answered = 0  # commands finished and answered with ok
        self.most_in_flight = 0  # most frames the host had sent before hearing back
        self.commands: list[str] = []  # executed, in order
        self.resends: list[int] = []
        self.expected = 1

    def _serve(self):
        self._say("start", "echo:Marlin 2.1.2")
        buffer = b""
        while not self._stop.is_set():
            if not select.select([self.master], [], [], 0.02)[0]:
                continue
            buffer += os.read(self.master, 4096)
            *lines, buffer = buffer.split(b"\n")
            self.most_in_flight = max(self.most_in_flight, len([ln for ln in lines if ln.strip()]))
            for raw in lines:
                self._line(raw.decode("ascii", "replace").strip())

    def _line(self, text):
        if not text:
            return
        framed = marlin.unframe_line(text)
        number = int(text[1:].split(" ", 1)[0]) if text.startswith("N") else None
        if number in self.noise_on:  # the wire flipped a bit of this frame
            self.noise_on.discard(number)
            framed = None
        if framed is None:
            self._say(f"Error:checksum mismatch, Last Line: {self.expected - 1}")
            return self._request_resend()
        number, command = framed
        if command.startswith("M110"):
            self.expected = int(command.split("N")[1]) + 1
            return self._say(self._ok(number))
        if number != self.expected:
            self._say(f"Error:Line Number is not Last Line Number+1, Last Line: {self.expected - 1}")
            return self._request_resend()
        self.expected += 1
        self._run(number, command)

    def _ok(self, number):
        return "ok"

    def _run(self, number, command):
        """Execute one good frame and answer it."""
        self.commands.append(command)
        # Busy for busy_seconds of the board's own pacing: a keep-alive every BUSY_EVERY s, as
        # Marlin's (counted, not read off the wall clock: a loaded host only stretches it).
        for _ in range(round(self.busy_seconds / BUSY_EVERY) if command.startswith(self.slow) else 0):
            self._say("echo:busy: processing")
            self._stop.wait(BUSY_EVERY)
        self.answered += 1
        self._say("ok")

    def _request_resend(self):
        self.resends.append(self.expected)
        self._say(f"Resend: {self.expected}", "ok")
        time.sleep(0.1)  # a host that took the ok for the resent line sends two frames by now


def lines_for_marlin(n=30):
    out = ["G21", "G90", "M400", "M280 P0 S50"]
    out += [f"G1 X{10 + i % 7}.5 Y{20 + i // 7}.25 F3000" for i in range(n)]
    return out + ["M400", "M280 P0 S50"]


def test_corrupted_line_is_resent_and_nothing_else_twice(tmp_path):
    lines = lines_for_marlin()
    path = tmp_path / "m.gcode"
    path.write_text("\n".join(lines) + "\n")
    with MarlinBoard(noise_on={7, 19}, busy_seconds=0.3, slow=("M400",)) as board:
        draw(path, board.path, profile=PROFILE, wake_wait=0.5)
    # One frame in flight: the ok Marlin sends after "Resend:" belongs to the corrupt frame,
    # not to the resent one, so it must not release the next frame.
    assert board.most_in_flight == 1
    assert board.resends == [7, 19]
    assert board.commands == [clean_line(line) for line in lines] + ["M400"]  # M400: wait for the end


def test_busy_keepalives_hold_off_the_timeout(tmp_path):
    # Busy for 15 keep-alives, 0.1 s apart: 1.5 s, well past the sender's timeout, never a
    # gap near it. The sender counts as silence only the time it spent listening.
    lines = ["G21", "G4 P1500", "G1 X5 Y5 F3000"]
    with MarlinBoard(busy_seconds=1.5) as board:
        draw(lines, board.path, profile=PROFILE, wake_wait=0.5, timeout=0.6)
    assert board.commands[:3] == ["G21", "G4P1500", "G1X5Y5F3000"]


def test_silent_marlin_board_is_a_plain_error():
    board = MarlinBoard()
    board._say = lambda *lines: None  # a hung board: says nothing at all
    with board, pytest.raises(PlotError, match="no answer from a Marlin board.*stopped answering"):
        draw(["G21"], board.path, profile=PROFILE, wake_wait=0.3, timeout=0.5)


def test_line_numbers_written_by_the_profile_are_replaced_by_the_session_s_own(tmp_path):
    commands = ["G21", "G90", "G1 X5 Y5 F3000"]
    numbered = [marlin.frame_line(n, c).decode().strip() for n, c in enumerate(commands, start=100)]
    with MarlinBoard() as board:
        draw(numbered, board.path, profile=PROFILE, wake_wait=0.5)
    assert board.commands == ["G21", "G90", "G1X5Y5F3000", "M400"]
    assert board.resends == []


class AdvancedOkMarlinBoard(MarlinBoard):
    """Marlin with ADVANCED_OK and a command queue of ``slots``: lines are queued as they arrive
    and run one every ``step`` seconds, each answered ``ok N<n> P<planner> B<free slots>``. A
    line arriving at a full queue is counted in ``overflows`` (real Marlin would lose it)."""

    def __init__(self, slots=4, step=0.004, noise_on=()):
        super().__init__(noise_on=noise_on)
        self.slots, self.step = slots, step
        self.queue = []  # (number, command) waiting to run
        self.overflows = 0
        self.most_queued = 0

    def _serve(self):
        self._say("start")
        buffer, next_run = b"", time.monotonic()
        while not self._stop.is_set():
            if select.select([self.master], [], [], 0.001)[0]:
                buffer += os.read(self.master, 4096)
                *lines, buffer = buffer.split(b"\n")
                for raw in lines:
                    self._line(raw.decode("ascii", "replace").strip())
            if self.queue and time.monotonic() >= next_run:
                number, command = self.queue.pop(0)
                self.commands.append(command)
                self._say(self._ok(number))
                next_run = time.monotonic() + self.step

    def _ok(self, number):
        return f"ok N{number} P15 B{self.slots - len(self.queue)}"

    def _run(self, number, command):
        """Queue the frame: it runs, and is answered, in its turn."""
        if len(self.queue) >= self.slots:
            self.overflows += 1
            return
        self.queue.append((number, command))
        self.most_queued = max(self.most_queued, len(self.queue))

    def _request_resend(self):
        self.resends.append(self.expected)
        self._say(f"Resend: {self.expected}", "ok")  # at once, as Marlin's flush_and_request_resend


@pytest.mark.parametrize("noise", [(), (9, 23, 24)])
def test_advanced_ok_counts_fill_marlin_s_queue_without_overflowing_it(tmp_path, noise):
    lines = lines_for_marlin(60)
    path = tmp_path / "m.gcode"
    path.write_text("\n".join(lines) + "\n")
    with AdvancedOkMarlinBoard(slots=4, noise_on=noise) as board:
        draw(path, board.path, profile=PROFILE, wake_wait=0.5)
    assert board.overflows == 0 and board.most_queued > 1  # several lines queued at once, never too many
    assert board.commands == [clean_line(line) for line in lines] + ["M400"]  # exactly once, in order
    assert bool(board.resends) == bool(noise)  # the noise was heard, and recovered from


class HangingMarlinBoard(MarlinBoard):
    """Stops answering (and running) after ``hang_after`` commands: a hung board."""

    def __init__(self, hang_after):
        super().__init__()
        self.hang_after = hang_after

    def _run(self, number, command):
        if self.answered < self.hang_after:
            super()._run(number, command)


def test_a_marlin_job_resumes_after_the_last_acknowledged_line(tmp_path):
    # Marlin reports no position and has no feed hold: it runs what it acknowledged, so the
    # acknowledgements are what the resume goes by (no re-zero asked for).
    lines = lines_for_marlin()
    path = tmp_path / "m.gcode"
    path.write_text("\n".join(lines) + "\n")
    with HangingMarlinBoard(hang_after=14) as board, pytest.raises(PlotError, match="stopped answering"):
        draw(path, board.path, profile=PROFILE, wake_wait=0.5, timeout=0.5)
    done = board.commands
    with MarlinBoard() as board:
        draw(path, board.path, resume=f"{path}.job.json", wake_wait=0.5, timeout=2.0)
    rest = [clean_line(line) for line in lines][len(done) :]
    assert board.commands[-len(rest) - 1 : -1] == rest and board.commands[-1] == "M400"
