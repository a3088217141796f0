"""The coordinate systems a G-code file can use, followed as GRBL 1.1 runs them.

A file's X and Y are work coordinates: machine position minus the work offset, which is the
selected coordinate system (``G54``–``G59``, stored on the board) plus the ``G92`` offset. A file
may change them as it goes: ``G10 L2 Pn`` sets a system's offset, ``G10 L20 Pn`` the offset that
makes the current position read the given values, ``G92`` the offset that does the same without
touching the stored systems, ``G92.1`` clears it, ``G53`` moves in machine coordinates for one
block, and ``G28``/``G30`` go (through a named point) to a position stored with ``G28.1`` /
``G30.1``. pencilbot's own files use none of them; the bed check (:mod:`pencilbot.driver.gcode.bed_check`)
must still see where such a file really sends the carriage.

What the board holds before the job is unknown: ``G54`` is taken as zero (machine coordinates,
as pencilbot writes), anything else the file did not set is unknown (NaN), and a move that
depends on it has no machine position to check: the bed check refuses it by name.

Lines that touch the coordinate systems are rare, so they are followed one by one between runs
of ordinary moves that stay whole arrays (:func:`machine_positions`); the semantics match the
virtual plotter's parser (:mod:`sim.gcode.parser`), which follows GRBL 1.1h's ``gc_execute_line``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Non-modal codes in tenths: the lines followed one by one.
G10, G28, G28_1, G30, G30_1, G53, G92, G92_1 = 100, 280, 281, 300, 301, 530, 920, 921
CODES = (G10, G28, G28_1, G30, G30_1, G53, G92, G92_1)
_SYSTEMS = 6  # G54..G59; then the G28 and G30 positions
_HOME = {G28: 6, G30: 7, G28_1: 6, G30_1: 7}
_Axes = tuple[float | None, float | None, float | None]


@dataclass(frozen=True)
class Frames:
    """The coordinate state a job has set up (mm; ``None``: held by the board, unknown here).

    Attributes
    ----------
    select : int
        The active system: 0 for ``G54`` … 5 for ``G59``.
    data : tuple of 8 (x, y, z)
        Offsets of ``G54``–``G59``, then the ``G28`` and ``G30`` positions (machine mm).
    g92 : (x, y, z)
        The ``G92`` offset.
    """

    select: int = 0
    data: tuple[_Axes, ...] = ((0.0, 0.0, 0.0),) + ((None, None, None),) * 7
    g92: _Axes = (0.0, 0.0, 0.0)

    def offset(self) -> np.ndarray:
        """The work offset (machine minus work position) X, Y, Z in mm; NaN where unknown."""
        return _array(self.data[self.select]) + _array(self.g92)

    @property
    def plain(self) -> bool:
        """Whether work coordinates are machine coordinates (``G54`` at zero, no ``G92``), as a
        board starts and as a resume sets it up."""
        return self.select == 0 and not np.any(self.offset())  # NaN counts as not plain


def _array(axes: _Axes) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in axes], dtype=float)


def _axes(values: np.ndarray) -> _Axes:
    # To a nanometre: the same offset reached by another sum of the same words is the same state.
    x, y, z = (None if math.isnan(v) else round(float(v), 9) + 0.0 for v in values)
    return x, y, z


def machine_positions(
    words: np.ndarray,
    moves: np.ndarray,
    relative: np.ndarray,
    code: np.ndarray,
    select: np.ndarray,
    l_word: np.ndarray,
    p_word: np.ndarray,
    start: Frames,
    start_machine: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, list[Frames], np.ndarray]:
    """Machine X, Y, Z after each line of a block that touches the coordinate systems.

    Parameters
    ----------
    words : (n, 3) float array
        Each line's X, Y, Z words in mm (NaN: none).
    moves : (n,) bool array
        Lines whose axis words are a motion's (not a ``G4``/``G10``/``G28``/``G53``/``G92`` line's).
    relative : (n,) bool array
        ``G91`` in force on each line.
    code : (n,) int array
        Each line's non-modal code in tenths (:data:`CODES`), 0 for none.
    select : (n,) int array
        The coordinate system each line selects (0 = ``G54``), −1 for none.
    l_word, p_word : (n,) float arrays
        ``L`` and ``P`` words (NaN: none), for ``G10``.
    start : Frames
        The coordinate state before the block.
    start_machine : (3,) float array
        Machine position before the block (mm).

    Returns
    -------
    on_machine : (n, 3) float array
        Machine position after each line, mm (NaN where it depends on an offset the file never set).
    frame : (n,) int array
        Index into ``frames`` of the coordinate state after each line.
    frames : list of Frames
        The states, ``start`` first.
    via : (n, 3) float array
        The point a ``G28``/``G30`` line passes through on its way home (NaN on other lines).
    """
    n = len(code)
    events = np.flatnonzero((code > 0) | (select >= 0))
    ordinary = np.ones(n, dtype=bool)
    ordinary[events] = False
    given = ~np.isnan(words) & (moves & ordinary)[:, None]
    absolute = given & ~relative[:, None]
    step = np.where(given & relative[:, None], words, 0.0)
    summed = np.cumsum(step, axis=0)
    index = np.arange(n)[:, None]
    last_absolute = np.maximum.accumulate(np.where(absolute, index, -1), axis=0)
    frames, frame = [start], np.zeros(n, dtype=np.int64)
    after = np.full((n, 3), np.nan)  # machine position after each event line
    via = np.full((n, 3), np.nan)
    here, state, previous = np.asarray(start_machine, dtype=float), start, -1
    for e in events.tolist():
        here = _run_to(e - 1, previous, here, state.offset(), words, summed, last_absolute)
        state, here, via[e] = _event(
            state,
            here,
            words[e],
            int(code[e]),
            int(select[e]),
            l_word[e],
            p_word[e],
            bool(relative[e]),
            bool(moves[e]),
        )
        after[e] = here
        if state != frames[-1]:
            frames.append(state)
        frame[e] = len(frames) - 1
        previous = e
    frame = np.maximum.accumulate(np.where(np.isin(index[:, 0], events), frame, 0))
    on_machine = _between_events(words, summed, absolute, ~ordinary, after, frames, frame, start_machine)
    return on_machine, frame, frames, via


def _between_events(words, summed, absolute, is_event, after, frames, frame, start_machine) -> np.ndarray:
    """Machine X, Y, Z after every line: an event line's own, and between events the ordinary
    lines', whose absolute words are work coordinates in the frame in force."""
    index = np.arange(len(words))[:, None]
    offsets = np.array([f.offset() for f in frames])[frame]
    assign = absolute | is_event[:, None]
    value = np.where(is_event[:, None], after, words + offsets)
    at = np.maximum.accumulate(np.where(assign, index, -1), axis=0)
    pick = np.maximum(at, 0)
    cols = np.arange(3)[None, :]
    return np.where(
        at >= 0, value[pick, cols] + (summed - summed[pick, cols]), start_machine[None, :] + summed
    )


def _run_to(
    line: int,
    previous: int,
    here: np.ndarray,
    offset: np.ndarray,
    words: np.ndarray,
    summed: np.ndarray,
    last_absolute: np.ndarray,
) -> np.ndarray:
    """Machine position after ordinary line ``line``, from ``here`` after event line ``previous``."""
    if line <= previous:
        return here
    out = here + summed[line] - (summed[previous] if previous >= 0 else 0.0)
    j = last_absolute[line]
    moved = j > previous
    rows = np.where(moved, j, 0)
    cols = np.arange(3)
    return np.where(moved, words[rows, cols] + offset + summed[line] - summed[rows, cols], out)


def _event(
    state: Frames,
    here: np.ndarray,
    words: np.ndarray,
    code: int,
    select: int,
    l_word: float,
    p_word: float,
    relative: bool,
    move: bool,
) -> tuple[Frames, np.ndarray, np.ndarray]:
    """One line that touches the coordinate systems: (state after, machine position after, via
    point or NaN). A line the board refuses (``G10 L3``, ``P7``) changes nothing, as there."""
    given = ~np.isnan(words)
    data = [_array(axes) for axes in state.data]
    g92 = _array(state.g92)
    chosen = select if select >= 0 else state.select
    frame = data[chosen] + g92  # the offset this block moves in (a selection applies at once)
    via = np.full(3, np.nan)
    target = here.copy()
    if code == G10:
        p = 0 if math.isnan(p_word) else math.trunc(p_word)
        l_value = -1 if math.isnan(l_word) else math.trunc(l_word)
        if 0 <= p <= _SYSTEMS and l_value in (2, 20) and given.any():
            system = p - 1 if p > 0 else chosen
            data[system] = np.where(given, words if l_value == 2 else here - g92 - words, data[system])
    elif code == G92 and given.any():
        g92 = np.where(given, here - data[chosen] - words, g92)
    elif code == G92_1:
        g92 = np.zeros(3)
    elif code in (G28_1, G30_1):
        data[_HOME[code]] = here.copy()
    elif code in (G28, G30):
        if given.any():
            via = np.where(given, here + words if relative else words + frame, here)
            target = np.where(given, data[_HOME[code]], here)
        else:
            target = data[_HOME[code]].copy()
    elif code == G53 or (code == 0 and move):
        moved = words if code == G53 else (here + words if relative else words + frame)
        target = np.where(given, moved, here)
    after = Frames(chosen, tuple(_axes(d) for d in data), _axes(g92))
    return after, target, via
