"""What the virtual GRBL machine drew: its pen-down strokes and pen-up moves, where the carriage
really went (machine mm), kept as one growing point array each.
"""

from __future__ import annotations

from array import array
from typing import TYPE_CHECKING

import numpy as np

from pencilbot.paths import Paths

if TYPE_CHECKING:
    from pencilbot.machine.profile import Profile


class StrokeRecorder:
    """The recorder part of :class:`sim.gcode.machine.Machine`, kept apart: mixed into it, these
    methods read its ``pauses`` (``M0`` pauses reached) and ``profile`` (the bed's view), and
    record each stretch the carriage moved (:meth:`_record`), or many at once in whole arrays
    (:meth:`record_moves`: :mod:`sim.bulk`'s path). The virtual EBB records its drawing with it
    too (:class:`sim.ebb.plotter.EbbDrawing`).
    """

    #: The host's: ``M0`` pauses reached so far, and its profile (the bed's view).
    pauses: int
    profile: Profile

    def __init__(self) -> None:
        self._strokes = Polylines()  # finished pen-down polylines, machine mm
        self._travel = Polylines()  # pen-up moves, same frame
        self._stroke_pauses: list[int] = []  # for each stroke, the pauses reached before it began
        self._stroke: list[tuple[float, float]] = []
        self._stroke_pause = 0

    def _record(self, start, end, pen_down: bool) -> None:
        """A stretch the carriage really moved (mm, machine frame of a homed machine)."""
        start, end = (start[0], start[1]), (end[0], end[1])
        if pen_down:
            if not self._stroke or self._stroke[-1] != start:
                self.close_stroke()
                self._stroke.append(start)
                self._stroke_pause = self.pauses
            self._stroke.append(end)
        else:
            self.close_stroke()
            self._travel.add((start, end))

    def close_stroke(self) -> None:
        """The pen has left the paper: the polyline being drawn is finished."""
        if len(self._stroke) >= 2:
            self._strokes.add(self._stroke)
            self._stroke_pauses.append(self._stroke_pause)
        self._stroke = []

    def record_moves(self, moves: np.ndarray, closed_before: np.ndarray) -> None:
        """Many completed moves at once, ``(start x, y, end x, y, pen down)`` rows, as :meth:`_record`
        takes them one by one (``closed_before``: a lift in place came before the move; the
        simulator's whole-array path, :mod:`sim.bulk`, with no slip)."""
        start, end, pen = moves[:, 0:2], moves[:, 2:4], moves[:, 4] != 0
        up = ~pen
        # A pen-down move goes on with the stroke being drawn when the move before it was pen-down,
        # no lift came between and it starts where that one ended; else it starts a new stroke.
        follows = np.zeros(len(moves), bool)
        follows[1:] = pen[:-1] & (start[1:] == end[:-1]).all(axis=1)
        head = self._stroke
        follows[0] = bool(head) and head[-1] == (float(start[0, 0]), float(start[0, 1]))
        follows &= pen & ~closed_before
        if up.any():
            self._travel.extend(
                np.stack([start[up], end[up]], axis=1).reshape(-1, 2), np.arange(2, 2 * up.sum() + 1, 2)
            )
        down = np.flatnonzero(pen)
        if not len(down):
            if up.any() or closed_before.any():
                self.close_stroke()
            return
        if not follows[down[0]]:
            self.close_stroke()
            head = []
        new = ~follows[down]
        # Points: a new stroke's start, then every move's end.
        slots = np.cumsum(1 + new) - 1
        points = np.empty((len(head) + slots[-1] + 1, 2))
        if head:
            points[: len(head)] = head
        points[len(head) + slots] = end[down]
        firsts = len(head) + slots[new] - 1
        points[firsts] = start[down[new]]
        bounds = np.append(firsts if not len(head) else np.concatenate([[0], firsts]), len(points))
        tail_closed = up[down[-1] + 1 :].any() or closed_before[down[-1] + 1 :].any()
        done = len(bounds) - 1 if tail_closed else len(bounds) - 2  # strokes finished
        if done:
            self._strokes.extend(points[: bounds[done]], bounds[1 : done + 1])
            self._stroke_pauses.extend([self.pauses] * done)
        self._stroke = [] if tail_closed else list(map(tuple, points[bounds[-2] :].tolist()))
        self._stroke_pause = self.pauses

    @property
    def strokes(self) -> list[np.ndarray]:
        """Pen-down polylines drawn so far (machine mm), the one still being drawn last."""
        return list(self.drawn())

    @property
    def travel(self) -> list[np.ndarray]:
        """Pen-up moves so far (machine mm), each a (2, 2) array."""
        return list(self._travel.paths())

    def drawn(self) -> Paths:
        """:attr:`strokes` as one :class:`~pencilbot.paths.Paths` (no array per stroke)."""
        return self._strokes.paths(self._stroke if len(self._stroke) >= 2 else None)

    @property
    def stroke_pauses(self) -> list[int]:
        """For each of :attr:`strokes`, how many ``M0`` pauses the program had passed when it
        began: a colour job's pen changes are pauses, so this says which pen drew it."""
        if len(self._stroke) >= 2:
            return self._stroke_pauses + [self._stroke_pause]
        return list(self._stroke_pauses)

    def bed_strokes(self) -> Paths:
        """Pen-down polylines in bed mm (bottom-left origin, Y up) for :mod:`pencilbot.render`."""
        return self._bed_view(self.drawn())

    def bed_travel(self) -> Paths:
        """Pen-up moves in bed mm, as :meth:`bed_strokes`."""
        return self._bed_view(self._travel.paths())

    def _bed_view(self, paths: Paths) -> Paths:
        return Paths(self.profile.bed.to_view(paths.points), paths.offsets) if len(paths) else paths


class Polylines:
    """Polylines appended one by one into a single growing (N, 2) float64 point array.

    A million-line job draws hundreds of thousands of strokes and moves: as one array they cost
    16 bytes a point and 8 a polyline, where an array per polyline cost about 130 bytes more.
    """

    def __init__(self) -> None:
        self._points = np.empty((1024, 2))
        self._size = 0
        self._ends = array("q")

    def __len__(self) -> int:
        return len(self._ends)

    def add(self, points) -> None:
        """Append one polyline (a sequence of (x, y), at least one point)."""
        points = np.asarray(points, dtype=np.float64)
        end = self._size + len(points)
        if end > len(self._points):  # grow by doubling: appends stay amortised O(1)
            grown = np.empty((max(end, 2 * len(self._points)), 2))
            grown[: self._size] = self._points[: self._size]
            self._points = grown
        self._points[self._size : end] = points
        self._size = end
        self._ends.append(end)

    def extend(self, points: np.ndarray, ends: np.ndarray) -> None:
        """Append many polylines at once: ``points`` (M, 2) and each one's end in it (K,)."""
        end = self._size + len(points)
        if end > len(self._points):
            grown = np.empty((max(end, 2 * len(self._points)), 2))
            grown[: self._size] = self._points[: self._size]
            self._points = grown
        self._points[self._size : end] = points
        self._ends.extend((np.asarray(ends, dtype=np.int64) + self._size).tolist())
        self._size = end

    def paths(self, last=None) -> Paths:
        """Every polyline (a copy), and ``last`` (points, if given) after them."""
        points, ends = self._points[: self._size], np.array(self._ends, dtype=np.int64)
        if last is not None:
            points = np.concatenate([points, np.asarray(last, dtype=np.float64)])
            ends = np.append(ends, len(points))
        return Paths(points.copy(), np.concatenate([[0], ends]))
