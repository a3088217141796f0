"""Follow a G-code job's modal state (units, distance mode, feed, position, pen), whole arrays at once.

The driver needs it for two things: to rebuild the machine state when a job resumes in the middle,
and to estimate how long each line takes for the progress ETA. It understands the subset of
G-code that plotters are sent (G0 G1 G2 G3 G4 G20 G21 G90 G91, F X Y Z I J R S P, M3 M4 M5 M280);
other words pass through without changing the tracked state, and axis words on
``G4 G10 G28 G53 G92`` lines are not moves. Arcs (G2/G3 in the XY plane, as other tools write
them) are followed to their end point; their centre words are kept per line (``i``, ``j``, ``r``
columns, with the positions in mm, ``x_mm`` and ``y_mm``) for whoever needs the curve between
(:mod:`pencilbot.driver.gcode.bed_check`).

:func:`track` reads a block of cleaned lines (see :func:`clean_line`) in one pass of numpy: the
words' numbers are parsed from their digits, each modal value is carried forward from the last
line that set it, and positions are running sums between absolute assignments. So a job of a
million lines is tracked in well under a second, and a state in the middle of it is recomputed
on demand from the nearest checkpoint (:mod:`pencilbot.driver.gcode.job`) instead of being stored per
line. A malformed word (``X1.2.3``, ``G``) changes nothing, as the board will refuse it anyway.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from pencilbot.driver.gcode import coords
from pencilbot.driver.gcode.coords import Frames
from pencilbot.driver.gcode.words import codes, coordinate_codes, first_value, read_words
from pencilbot.machine.pen import PenModel
from pencilbot.units import MM_PER_INCH

_COMMENT = re.compile(r"\([^)]*\)|;.*")


def _bits(codes: dict[int, int]) -> np.ndarray:
    table = np.full(max(codes) + 1, -1, dtype=np.int64)
    table[list(codes)] = list(codes.values())
    return table


# The G and M codes the tracker reads, each a bit of a per-line mask.
G0, G1, G4, G20, G21, G90, G91, NOT_A_MOVE, G2, G3 = (1 << b for b in range(10))
_G_BITS = _bits({0: 0, 1: 1, 4: 2, 20: 3, 21: 4, 90: 5, 91: 6, 10: 7, 28: 7, 30: 7, 53: 7, 92: 7, 2: 8, 3: 9})
M3, M4, M5, M280 = (1 << b for b in range(4))
_M_BITS = _bits({3: 0, 4: 1, 5: 2, 280: 3})


def clean_line(raw: str) -> str:
    """The part of a G-code line a controller acts on: comments and whitespace removed.

    Parameters
    ----------
    raw : str
        One line as read from a file.

    Returns
    -------
    str
        Upper-case text without ``( … )`` / ``;`` comments and spaces; ``""`` if nothing is left.
    """
    return "".join(_COMMENT.sub("", raw).split()).upper()


@dataclass(frozen=True)
class ModalState:
    """Machine state after some lines of a job, in the job's own units (mm or inch)."""

    inches: bool = False
    relative: bool = False
    feed: float | None = None
    motion: int = 0  # 0 = G0, 1 = G1 (modal): the last straight motion
    arc: int = 0  # 2 = G2, 3 = G3 when the modal motion is an arc, else 0 (then ``motion`` is in force)
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    spindle_on: bool = False
    s: float = 0.0
    servo: float | None = None
    pen_down: bool = False
    frames: Frames = Frames()  # the coordinate systems (G54–G59, G92, G28/G30) the job set up
    #: Work X, Y, Z in mm, as the board keeps them (``x`` … are the numbers as written, which a
    #: G20/G21 switch reads anew); None: ``x`` … in the state's units.
    mm: tuple[float, float, float] | None = field(default=None, compare=False)

    def position_mm(self) -> np.ndarray:
        """Work X, Y, Z in mm."""
        if self.mm is not None:
            return np.array(self.mm, dtype=float)
        return np.array([self.x, self.y, self.z]) * (MM_PER_INCH if self.inches else 1.0)


class Track:
    """The modal state after each line of a block, as arrays (see :func:`track`).

    ``track[i]`` is the :class:`ModalState` after line ``first + i`` of the job (indexing is by
    job line, so a window of a job reads like the job); ``seconds`` is each line's duration.
    Besides the state's columns: ``x_mm``/``y_mm`` (work position in mm), ``mx``/``my`` (machine
    position in mm, NaN where it rests on an offset the file never set), ``vx``/``vy`` (the
    point a ``G28``/``G30`` passes through, else NaN) and ``frame`` (an index into ``frames``).
    """

    FIELDS = (
        "inches",
        "relative",
        "feed",
        "motion",
        "arc",
        "x",
        "y",
        "z",
        "spindle_on",
        "s",
        "servo",
        "pen_down",
    )

    def __init__(
        self,
        first: int,
        columns: dict[str, np.ndarray],
        seconds: np.ndarray,
        frames: Sequence[Frames] = (Frames(),),
    ) -> None:
        self.first = first
        self.columns = columns
        self.seconds = seconds
        self.frames = frames

    def __len__(self) -> int:
        return len(self.seconds)

    def __getitem__(self, index: int) -> ModalState:
        i = index - self.first
        if not 0 <= i < len(self):
            raise IndexError(
                f"line {index} is not in this track (lines {self.first}..{self.first + len(self) - 1})"
            )
        c = {name: self.columns[name][i].item() for name in self.FIELDS}
        c["feed"] = None if np.isnan(c["feed"]) else c["feed"]
        c["servo"] = None if np.isnan(c["servo"]) else c["servo"]
        x, y, z = (float(self.columns[name][i]) for name in ("x_mm", "y_mm", "z_mm"))
        return ModalState(**c, frames=self.frames[int(self.columns["frame"][i])], mm=(x, y, z))

    @property
    def last(self) -> ModalState:
        """The state after the block's last line."""
        return self[self.first + len(self) - 1]


def track(
    block: bytes | bytearray | Sequence[str],
    pen: PenModel,
    *,
    start: ModalState = ModalState(),
    first: int = 0,
    travel_feed: float = 6000.0,
    dwell_units: float = 1.0,
) -> Track:
    """The modal state after every line of ``block``, starting from ``start``.

    Parameters
    ----------
    block : bytes or sequence of str
        Cleaned lines: ``b"G1X1Y2\\n…"`` (each line ending in ``\\n``, none empty), or a list of
        cleaned strings.
    pen : PenModel
        Tells which values mean pen down.
    start : ModalState
        State before the first line.
    first : int
        Job index of the first line (what :class:`Track` indexes by).
    travel_feed : float
        Rapid (G0) speed in mm/min, for the durations.
    dwell_units : float
        ``G4 P`` units per second (the firmware's: 1 or 1000).

    Returns
    -------
    Track
        States and durations; a duration is distance over feed for moves (acceleration ignored:
        the progress ETA is rescaled by the observed pace), the dwell for ``G4``.
    """
    if not isinstance(block, (bytes, bytearray)):
        block = "".join(f"{line}\n" for line in block).encode("ascii", errors="replace")
    words = read_words(block)
    lines = words.lines
    jog = words.jog
    g_jog = codes(words, "G", lines, _G_BITS)
    g = np.where(jog, 0, g_jog)  # a jog's G20/G21/G90/G91 last for its line only
    m = codes(words, "M", lines, _M_BITS)
    word = {letter: first_value(words, letter, lines) for letter in "FIJLPRSXYZ"}
    columns = {}
    columns["inches"] = _carry((g & (G20 | G21)) != 0, (g & G20) != 0, start.inches)
    relative = columns["relative"] = _carry((g & (G90 | G91)) != 0, (g & G91) != 0, start.relative)
    # What a jog line moves by: its own units and distance mode, else the job's.
    inches_here = np.where(jog & ((g_jog & (G20 | G21)) != 0), (g_jog & G20) != 0, columns["inches"])
    relative = np.where(jog & ((g_jog & (G90 | G91)) != 0), (g_jog & G91) != 0, relative)
    columns["feed"] = _carry(
        ~np.isnan(word["F"]) & ~jog, word["F"], np.nan if start.feed is None else start.feed
    )
    columns["motion"] = _carry((g & (G0 | G1)) != 0, ((g & G1) != 0).astype(np.int64), start.motion)
    arc_code = np.where((g & G2) != 0, 2, np.where((g & G3) != 0, 3, 0))
    columns["arc"] = _carry((g & (G0 | G1 | G2 | G3)) != 0, arc_code, start.arc)
    servo = (m & M280) != 0
    has_s = ~np.isnan(word["S"])
    columns["s"] = _carry(has_s & ~servo, word["S"], start.s)
    columns["spindle_on"] = _carry((m & (M3 | M4 | M5)) != 0, (m & M5) == 0, start.spindle_on)
    columns["servo"] = _carry(has_s & servo, word["S"], np.nan if start.servo is None else start.servo)
    moves = (g_jog & (NOT_A_MOVE | G4)) == 0
    unit = np.where(columns["inches"], MM_PER_INCH, 1.0)  # mm per unit of the job's words
    scale = np.where(inches_here, MM_PER_INCH, 1.0)  # and of each line's own (a jog's may differ)
    as_written = {a: np.where(jog, word[a] * scale / unit, word[a]) for a in "XYZ"}  # in the job's units
    on_machine, frames = _positions(columns, words, word, moves, relative, scale, unit, as_written, start)
    columns["pen_down"] = _pen_down(columns, pen)
    for letter in "IJR":  # an arc's centre, per line (not modal)
        columns[letter.lower()] = word[letter]

    start_machine = start.position_mm() + start.frames.offset()
    seconds = _durations(
        columns, word, on_machine, start_machine, g, jog, has_s, scale, unit, travel_feed, dwell_units
    )
    return Track(first, columns, seconds, frames)


def _positions(columns, words, word, moves, relative, scale, unit, as_written, start: ModalState):
    """``x``/``y``/``z`` as the words are written, in mm (``x_mm``…), on the machine (``mx``,
    ``my``, through the coordinate systems) and a ``G28``/``G30``'s via point, into ``columns``;
    the machine positions and the coordinate states."""
    lines = words.lines
    for axis in "xyz":
        columns[axis] = _position(as_written[axis.upper()], moves, relative, getattr(start, axis))
    # Also in mm, as the board keeps them: a G20/G21 in the middle of a file changes how later
    # words read, not where the pen is (``x``/``y`` above take the numbers as written); the
    # start state carries its own millimetres across a checkpoint.
    start_mm = start.position_mm()
    mm = {
        axis: _position(word[axis.upper()] * scale, moves, relative, start_mm[i])
        for i, axis in enumerate("xyz")
    }
    # Where the carriage goes: work coordinates plus the work offset, which lines that set up
    # coordinate systems (G10, G53, G54-G59, G92, G28/G30; rare) change, followed one by one.
    start_machine = start_mm + start.frames.offset()
    code, select = coordinate_codes(words, lines)
    if (code > 0).any() or (select >= 0).any():
        word_mm = np.column_stack([word[a.upper()] * scale for a in "xyz"])
        on_machine, frame, frames, via = coords.machine_positions(
            word_mm, moves, relative, code, select, word["L"], word["P"], start.frames, start_machine
        )
        work = on_machine - np.array([f.offset() for f in frames])[frame]
        event = (code > 0) | (select >= 0)
        before = np.vstack([start_mm, work[:-1]])
        for i, axis in enumerate("xyz"):
            mm[axis] = work[:, i]
            # In the job's units as the words are written (see above): an event line moves it by
            # what it changed.
            written = np.where(event, (work[:, i] - before[:, i]) / unit, as_written[axis.upper()])
            columns[axis] = _position(written, moves | event, relative | event, getattr(start, axis))
    else:
        on_machine = np.column_stack([mm[a] for a in "xyz"]) + start.frames.offset()
        frame, frames, via = np.zeros(lines, np.int64), [start.frames], np.full((lines, 3), np.nan)
    columns["x_mm"], columns["y_mm"], columns["z_mm"] = mm["x"], mm["y"], mm["z"]
    columns["mx"], columns["my"] = on_machine[:, 0], on_machine[:, 1]
    columns["vx"], columns["vy"] = via[:, 0], via[:, 1]
    columns["frame"] = frame
    return on_machine, frames


def _durations(
    columns, word, on_machine, start_machine, g, jog, has_s, scale, unit, travel_feed, dwell_units
):
    """Each line's duration (s): distance over feed for moves, a jog at its own F, the dwell for ``G4``."""
    step = np.nan_to_num(np.diff(on_machine, axis=0, prepend=start_machine[None, :]))
    distance = np.sqrt(step[:, 0] ** 2 + step[:, 1] ** 2 + step[:, 2] ** 2)  # mm
    feed = columns["feed"]
    rapid = (columns["motion"] == 0) | np.isnan(feed) | (feed == 0)
    rate = np.where(rapid, travel_feed, np.nan_to_num(feed, nan=1.0) * unit)
    rate = np.where(
        jog, np.where(np.isnan(word["F"]), travel_feed / scale, word["F"]) * scale, rate
    )  # a jog at its own F
    seconds = np.where(distance > 0, distance / np.where(rate > 0, rate, 1.0) * 60.0, 0.0)
    dwell = np.where(has_s, word["S"], np.nan_to_num(word["P"]) / dwell_units)
    seconds = np.where((g & G4) != 0, dwell, seconds)
    return seconds


# --- the numpy parts ---------------------------------------------------------------------------


def _carry(is_set: np.ndarray, value: np.ndarray, initial) -> np.ndarray:
    """The value in force after each line: the last set one, or ``initial`` before any."""
    value = np.broadcast_to(value, is_set.shape)
    index = (
        np.maximum.accumulate(np.where(is_set, np.arange(len(is_set)), -1))
        if len(is_set)
        else np.zeros(0, np.int64)
    )
    return np.where(index >= 0, value[np.maximum(index, 0)], initial)


def _position(word: np.ndarray, moves: np.ndarray, relative: np.ndarray, initial: float) -> np.ndarray:
    """An axis after each line: absolute words assign it, relative ones add to it."""
    given = ~np.isnan(word) & moves
    delta = np.where(given & relative, word, 0.0)
    summed = np.cumsum(delta)
    assigned = given & ~relative
    index = (
        np.maximum.accumulate(np.where(assigned, np.arange(len(word)), -1))
        if len(word)
        else np.zeros(0, np.int64)
    )
    at = np.maximum(index, 0)
    return np.where(index >= 0, word[at] + (summed - summed[at]), initial + summed)


def _pen_down(columns: dict[str, np.ndarray], pen: PenModel) -> np.ndarray:
    def down(value):
        return np.abs(value - pen.down) < np.abs(value - pen.up)

    if pen.kind == "spindle":
        return columns["spindle_on"] & down(columns["s"])
    if pen.kind == "z":  # the profile's heights are mm; an inch job's Z is not
        return down(np.where(columns["inches"], columns["z"] * MM_PER_INCH, columns["z"]))
    servo = columns["servo"]
    return ~np.isnan(servo) & down(np.nan_to_num(servo))


def advance(state: ModalState, line: str, pen: PenModel) -> ModalState:
    """The state after one cleaned line (for a few lines: :func:`track` does whole jobs)."""
    return track([line], pen, start=state).last if line else state


def state_before(lines: Sequence[str], index: int, pen: PenModel) -> ModalState:
    """Modal state after ``lines[:index]`` (cleaned lines), i.e. just before ``lines[index]``."""
    lines = [line for line in lines[:index] if line]
    return track(lines, pen).last if lines else ModalState()
