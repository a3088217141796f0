"""A job ready to stream: every command line encoded once, in one buffer, with arrays beside it.

Preparing a million-line file must not cost more than streaming it. :func:`load_job` reads the
file in blocks and keeps, per command line, only its bytes in one buffer (the cleaned line and its
``\\n``, exactly what a character-counting sender writes), its offset, its line number in the
file and the cumulative motion estimate (for the progress ETA): about 45 bytes a line. The modal
state is not stored per line: a checkpoint is kept every :data:`CHECKPOINT` lines and the state
anywhere is recomputed from the nearest one (:meth:`Job.state_after`), which only a resume and a
stop need. The firmware checks the whole buffer at once before the port is opened.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pencilbot.driver import journal as journal_mod
from pencilbot.driver.gcode.bed_check import BedWatch
from pencilbot.driver.gcode.markers import without_markers
from pencilbot.driver.gcode.modal import ModalState, Track, track
from pencilbot.driver.gcode.system_lines import SystemLines, check_system_lines
from pencilbot.driver.gcode.words import MAX_DIGITS
from pencilbot.errors import PencilbotError, RefusedError, no_such_file
from pencilbot.fileio import refuse_special_input
from pencilbot.machine.profile import Profile
from pencilbot.units import MM_PER_INCH

#: Lines between stored modal states: a state is at most this many lines of tracking away.
CHECKPOINT = 4096
_READ_BLOCK = 1 << 20  # bytes read (and cleaned, and tracked) at a time
#: The longest line a G-code file may have (bytes, comments included): no sender or board takes
#: more than a few hundred; a longer one is another kind of file, refused as it is read.
MAX_FILE_LINE = _READ_BLOCK
_COMMENT = re.compile(rb"\([^)\n]*\)|;[^\n]*")
#: A program pause (M0, M1) and what its line says: ``M0 (pen change: insert red)``.
_PAUSE = re.compile(rb"(?im)^[^\n(;]*?M0*[01](?![0-9.])[^\n]*")
_PAUSE_NOTE = re.compile(rb"\(([^)\n]*)\)|;\s*([^\n]*)")
_SPACE = b" \t\r\x0b\x0c"
#: A word whose number is longer than the tracker reads (it would be skipped, and the board would
#: read ``G4 P1`` and thirty zeros as a wait of 10³⁰ s, ``X-9…9`` as a move past any bed).
_LONG_NUMBER = re.compile(rb"[A-Z][-+]?[0-9.]{%d,}" % (MAX_DIGITS + 1))


@dataclass(frozen=True, eq=False)
class Job:
    """The command lines of a G-code file, ready to stream.

    Attributes
    ----------
    source : str
        What messages call the job (the file's path).
    frames : bytearray
        Every command line, cleaned (no comments, spaces or lower case) and ended by ``\\n``
        (not copied into bytes: a job's buffer is read, never changed).
    offsets : (n + 1,) int64 array
        Where line ``i`` starts in ``frames``.
    numbers : (n,) int32 array
        The 1-based file line of each job line.
    seconds : (n,) float32 array
        Cumulative motion estimate after each line, s.
    checkpoints : tuple of ModalState
        The state before lines 0, CHECKPOINT, 2·CHECKPOINT, …
    total_lines : int
        Lines in the file, commands or not.
    pauses : dict of int to str
        Job lines that pause the program (``M0``/``M1``) and the comment beside each (the
        reason shown to the user: ``pen change: insert red``), ``""`` without one.
    off_bed : tuple or None
        The first move off the profile's bed (:class:`~pencilbot.driver.gcode.bed_check.BedWatch`).
    system : SystemLines
        The system commands (``$`` lines) the job was allowed to send, and what they do.
    """

    source: str
    frames: bytearray
    offsets: np.ndarray
    numbers: np.ndarray
    seconds: np.ndarray
    checkpoints: tuple[ModalState, ...]
    total_lines: int
    profile: Profile
    pauses: dict
    off_bed: tuple[int, float, float, str] | None = None
    system: SystemLines = SystemLines()

    def __len__(self) -> int:
        return len(self.numbers)

    def line(self, index: int) -> str:
        """Job line ``index`` as text (cleaned)."""
        return self.frames[self.offsets[index] : self.offsets[index + 1] - 1].decode("ascii")

    def size(self, index: int) -> int:
        """Bytes of line ``index`` as sent, its ``\\n`` included."""
        return int(self.offsets[index + 1] - self.offsets[index])

    def frames_between(self, first: int, stop: int) -> memoryview:
        """Lines ``first`` to ``stop − 1`` as sent, in one piece (no copy)."""
        return memoryview(self.frames)[self.offsets[first] : self.offsets[stop]]

    def index_of(self, file_line: int) -> int:
        """Index of the first job line at or after ``file_line``."""
        return int(np.searchsorted(self.numbers, file_line, side="left"))

    def number(self, index: int) -> int:
        """The file line of job line ``index``; past the end, the line after the last."""
        return int(self.numbers[index]) if index < len(self) else int(self.numbers[-1]) + 1

    def seconds_after(self, index: int) -> float:
        """Motion estimate of lines ``0 … index`` (0 for ``index < 0``)."""
        return float(self.seconds[index]) if index >= 0 else 0.0

    def states(self, first: int, stop: int) -> Track:
        """The modal states after lines ``first`` to ``stop − 1`` (recomputed from a checkpoint)."""
        base = first // CHECKPOINT * CHECKPOINT
        full = self._track(base, stop)
        keep = first - base
        columns = {name: values[keep:] for name, values in full.columns.items()}
        return Track(first, columns, full.seconds[keep:], full.frames)

    def state_after(self, index: int) -> ModalState:
        """The modal state after line ``index`` (the start state for ``index < 0``)."""
        if index < 0:
            return ModalState()
        return self.states(index, index + 1)[index]

    def _track(self, first: int, stop: int) -> Track:
        block = self.frames[self.offsets[first] : self.offsets[stop]]
        fw = self.profile.firmware
        return track(
            block,
            self.profile.pen_model,
            start=self.checkpoints[first // CHECKPOINT],
            first=first,
            travel_feed=self.profile.motion.travel_feed,
            dwell_units=fw.dwell_units,
        )


def load_job(
    gcode: str | Path | bytes | Iterable[str],
    profile: Profile,
    source: str | None = None,
    allow: frozenset[str] = frozenset(),
) -> Job:
    """Read G-code, keep its command lines, and check that the firmware can take every one.

    Parameters
    ----------
    gcode : path, bytes or iterable of str
        A G-code file, a whole program, or its lines.
    profile : Profile
        The plotter: its firmware validates the lines; its pen and feeds drive the tracking.
    source : str, optional
        What messages call the job (default: the file's path, else ``"<lines>"``).
    allow : frozenset of str
        The system commands (``$`` lines) it may send, by name (:mod:`pencilbot.driver.gcode.system_lines`).

    Raises
    ------
    PlotError
        The file cannot be read, holds no command, is binary, or a line cannot be sent (its
        line number and why).
    PencilbotError
        A system command not allowed, naming its line.
    """
    if isinstance(gcode, (str, Path)):
        path = Path(gcode)
        source = source or str(path)
        refuse_special_input(path, "G-code file")
        try:
            handle = path.open("rb")
        except FileNotFoundError:
            raise RefusedError(no_such_file(path, "the path of a .gcode file")) from None
        except OSError as exc:
            raise RefusedError(f"cannot read G-code file {path} ({exc})") from None
        with handle:
            job = _prepare(_blocks(iter(lambda: handle.read(_READ_BLOCK), b""), source), profile, source)
    elif isinstance(gcode, bytes):
        job = _prepare(_blocks(_pieces(gcode), source or "<lines>"), profile, source or "<lines>")
    else:
        program = "".join(f"{line}\n" for line in gcode).encode("utf-8", errors="replace")
        job = _prepare(_blocks(_pieces(program), source or "<lines>"), profile, source or "<lines>")
    if not len(job):
        raise RefusedError(
            f"{job.source} holds no G-code commands; export a drawing first (pencilbot export)"
        )
    return dataclasses.replace(job, system=check_system_lines(job, allow))


def read_gcode(path: str | Path) -> bytes:
    """A G-code file's bytes, read a block at a time with every line's length bounded
    (:data:`MAX_FILE_LINE`): a 300 MB file of one line is refused after its first megabytes,
    not after it has been read and split.

    Raises
    ------
    PlotError
        The file cannot be read, or a line is too long to be G-code.
    """
    return b"".join(gcode_blocks(path))


def gcode_blocks(path: str | Path) -> Iterator[bytes]:
    """:func:`read_gcode`'s file a block of whole lines at a time (about a megabyte each), for a
    reader that never holds it whole (the simulator's fast path); the same errors."""
    path = Path(path)
    refuse_special_input(path, "G-code file")
    try:
        with path.open("rb") as handle:
            yield from _blocks(iter(lambda: handle.read(_READ_BLOCK), b""), str(path))
    except FileNotFoundError:
        raise RefusedError(no_such_file(path, "the path of a .gcode file")) from None
    except OSError as exc:
        raise RefusedError(f"cannot read G-code file {path} ({exc})") from None


def program_blocks(program: bytes) -> Iterator[bytes]:
    """A program held whole (as :func:`~pencilbot.export.gcode.gcode_program` makes it) a block of
    whole lines at a time, as :func:`gcode_blocks` gives a file's."""
    return _blocks([program], "<program>")


def _blocks(chunks: Iterable[bytes], source: str = "<lines>") -> Iterator[bytes]:
    """Whole lines, about a read block at a time (a line never straddles two blocks).

    Raises
    ------
    PlotError
        A line is longer than :data:`MAX_FILE_LINE` bytes.
    """
    rest, lines = b"", 0
    for chunk in chunks:
        data, start = rest + chunk, 0
        while True:
            end = (
                data.rfind(b"\n", start, start + _READ_BLOCK) + 1
                or data.find(b"\n", start, start + MAX_FILE_LINE + 1) + 1
            )
            if end <= start:
                break  # no whole line left: wait for the next chunk
            lines += data.count(b"\n", start, end)
            yield data[start:end]
            start = end
        rest = data[start:]
        if len(rest) > MAX_FILE_LINE:
            raise RefusedError(
                f"line {lines + 1} of {source} is longer than {MAX_FILE_LINE >> 20} MB (a G-code line holds at most a "
                "few hundred characters, comments included); is it a G-code file?"
            )
    if rest:
        yield rest + b"\n"


def _pieces(program: bytes) -> Iterator[bytes]:
    """A whole program in read blocks, as a file is read."""
    view = memoryview(program)
    for start in range(0, len(program), _READ_BLOCK):
        yield bytes(view[start : start + _READ_BLOCK])


def _prepare(blocks: Iterator[bytes], profile: Profile, source: str) -> Job:
    fw = profile.firmware
    pen = profile.pen_model
    frames, offsets, numbers, seconds, checkpoints = (
        bytearray(),
        [np.zeros(1, np.int64)],
        [],
        [],
        [ModalState()],
    )
    file_lines = done = 0
    state, elapsed = ModalState(), 0.0
    bed = BedWatch(profile.bed)
    pauses = {}  # file line → note
    for raw in without_markers(blocks):
        # \r\n and a lone \r end a line as \n does (GRBL reads both as line ends).
        text = raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
        for m in _PAUSE.finditer(text):  # rare: counting the lines before each costs nothing
            note = _PAUSE_NOTE.search(m.group())
            words = (note.group(1) or note.group(2) or b"") if note else b""
            pauses[file_lines + 1 + text.count(b"\n", 0, m.start())] = words.decode(
                "utf-8", "replace"
            ).strip()
        cleaned = fw.commands(_COMMENT.sub(b"", text).translate(None, _SPACE).upper())
        a = np.frombuffer(cleaned, dtype=np.uint8)
        breaks = np.flatnonzero(a == 10)
        length = np.diff(breaks, prepend=-1) - 1
        kept = length > 0
        numbers.append((file_lines + 1 + np.flatnonzero(kept)).astype(np.int32))
        file_lines += len(breaks)
        # Empty lines go: drop each newline that ends one.
        empty_end = breaks[~kept]
        block = np.delete(a, empty_end).tobytes() if len(empty_end) else cleaned
        offsets.append(len(frames) + np.cumsum(length[kept] + 1))
        frames += block
        lines = int(kept.sum())
        if not lines:
            continue
        # Track in pieces that end on checkpoints, remembering the state at each.
        first = 0
        starts = np.concatenate([[0], np.cumsum(length[kept] + 1)])
        while first < lines:
            stop = min(lines, first + CHECKPOINT - (done + first) % CHECKPOINT)
            piece = track(
                block[starts[first] : starts[stop]],
                pen,
                start=state,
                travel_feed=profile.motion.travel_feed,
                dwell_units=fw.dwell_units,
            )
            bed.see(piece, done + first)
            cumulative = elapsed + np.cumsum(piece.seconds)
            seconds.append(cumulative.astype(np.float32))  # an ETA needs no more digits
            elapsed = float(cumulative[-1])
            state = piece.last
            if (done + stop) % CHECKPOINT == 0:
                checkpoints.append(state)
            first = stop
        done += lines
    job = Job(
        source=source,
        frames=frames,
        offsets=np.concatenate(offsets),
        numbers=np.concatenate(numbers) if numbers else np.zeros(0, np.int32),
        seconds=np.concatenate(seconds) if seconds else np.zeros(0, np.float32),
        checkpoints=tuple(checkpoints),
        total_lines=file_lines,
        profile=profile,
        pauses={},
        off_bed=bed.first,
    )
    job_numbers = job.numbers
    for file_line, pause_note in pauses.items():
        index = int(np.searchsorted(job_numbers, file_line))
        if index < len(job_numbers) and job_numbers[index] == file_line:  # a command, not a comment saying M0
            job.pauses[index] = pause_note
    _check(job)
    return job


def _check(job: Job) -> None:
    """Refuse binary files and lines the firmware cannot take, naming the file line."""
    if b"\x00" in job.frames:
        raise RefusedError(
            f"{job.source} is not G-code text (it holds NUL bytes, as binary files do); give the "
            ".gcode file that pencilbot export wrote"
        )
    refused = job.profile.firmware.check_lines(job)
    if refused is not None:
        index, reason = refused
        raise RefusedError(f"line {job.number(index)} of {job.source}: {reason}")
    if (long := _LONG_NUMBER.search(job.frames)) is not None:
        index = int(np.searchsorted(job.offsets, long.start(), side="right")) - 1
        raise PencilbotError(
            f"line {job.number(index)} of {job.source} ({job.line(index)[:40]!r}) has a number of "
            f"{len(long.group()) - 1} characters; no plotter coordinate, feed or time needs more than {MAX_DIGITS} "
            "(a board reads it as a move or a wait without end); nothing was sent. Is it G-code?"
        )


def check_journal(journal: journal_mod.Journal, job: Job) -> None:
    """Refuse a journal whose lines or stop point do not fit ``job`` (its G-code, read again)
    and the bed of ``job.profile``.

    Raises
    ------
    PlotError
        Saying what is wrong and how to go on (:func:`~pencilbot.driver.journal.damaged`).
    """
    if journal.total_lines != job.total_lines:
        raise journal_mod.damaged(
            journal, f"total_lines is {journal.total_lines}, and {job.source} has {job.total_lines} lines"
        )
    bed = job.profile.bed
    (x0, x1), (y0, y1) = bed.machine_range()
    where = f"off the bed of plotter profile {job.profile.name} (X {x0:g} .. {x1:g}, Y {y0:g} .. {y1:g} mm)"
    # (stop_mpos is the board's own count, which a restart-at-zero resume may have shifted: only
    # finite. The others are the file's coordinates, which the bed check kept on the bed.)
    points = {"stop_work": journal.stop_work}
    if journal.stop_xy is not None:  # job units, work coordinates at the line it stopped in
        state = job.state_after(job.index_of(journal.next_line) - 1)
        scale = MM_PER_INCH if state.inches else 1.0
        offset = state.frames.offset()[:2]
        points["stop_xy"] = [journal.stop_xy[0] * scale + offset[0], journal.stop_xy[1] * scale + offset[1]]
    for name, xy in points.items():
        if xy is not None and bed.outside([xy], journal_mod.STOP_SLACK)[0]:
            raise journal_mod.damaged(journal, f"{name} {getattr(journal, name)} is {where}")
