"""Pen paths as data: every point of every path in one array, and where each path starts.

A :class:`Paths` is the one container of polylines in pencilbot: plans, the time estimate, the
G-code writer, the SVG writer, the rasteriser and the virtual plotter's record of what it drew
all hold their paths this way. ``points`` is ``(N, 2)`` float64 (mm, unless a caller says
otherwise); path ``i`` is ``points[offsets[i]:offsets[i + 1]]``. Every path has at least one
point (a one-point path is a dot), so an empty path never has to be filtered out again
downstream. The arrays are read-only: a ``Paths`` is a value, safe to share between frozen
plans.

100 000 strokes are two arrays, not 100 000 objects; indexing a path gives a view.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import overload

import numpy as np


class Paths:
    """Polylines as ``points`` and ``offsets`` (see the module docstring).

    Parameters
    ----------
    points : (N, 2) array_like of float
        All points, path after path.
    offsets : (P + 1,) array_like of int
        ``offsets[0] == 0``, ``offsets[-1] == N``, strictly increasing (no empty path).

    The arrays are not copied when they already have the right types: a caller that hands its
    own arrays over must not change them afterwards.

    Raises
    ------
    ValueError
        The arrays do not describe non-empty paths.
    """

    __slots__ = ("offsets", "points")
    points: np.ndarray
    offsets: np.ndarray

    def __init__(self, points, offsets) -> None:
        pts = np.array(points, dtype=np.float64, copy=None).reshape(-1, 2)
        off = np.array(offsets, dtype=np.int64, copy=None).reshape(-1)
        if off.size == 0 or off[0] != 0 or off[-1] != len(pts) or np.any(np.diff(off) <= 0):
            raise ValueError(
                f"offsets must run from 0 to {len(pts)} in strictly increasing steps (no empty path)"
            )
        pts, off = pts.view(), off.view()  # read-only views: the caller's arrays keep their flags
        pts.flags.writeable = off.flags.writeable = False
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "offsets", off)

    def __setattr__(self, name, value):
        raise AttributeError("Paths is immutable")

    def __reduce__(self):
        return Paths, (self.points, self.offsets)

    @classmethod
    def of(cls, paths: Paths | Iterable) -> Paths:
        """Paths from a :class:`Paths` (returned as is) or an iterable of ``(k, 2)`` point arrays.

        Paths without points are dropped.
        """
        if isinstance(paths, Paths):
            return paths
        arrays = [a for a in (np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in paths) if len(a)]
        if not arrays:
            return cls.empty()
        lengths = np.fromiter(map(len, arrays), dtype=np.int64, count=len(arrays))
        return cls(np.concatenate(arrays), np.concatenate([[0], np.cumsum(lengths)]))

    @classmethod
    def empty(cls) -> Paths:
        """No paths at all."""
        return cls(np.zeros((0, 2)), np.zeros(1, dtype=np.int64))

    @classmethod
    def concat(cls, parts: Iterable[Paths]) -> Paths:
        """The paths of ``parts`` one after the other."""
        parts = [p for p in parts if len(p)]
        if not parts:
            return cls.empty()
        if len(parts) == 1:
            return parts[0]
        starts = np.cumsum([0] + [len(p.points) for p in parts[:-1]])
        offsets = np.concatenate([[0]] + [p.offsets[1:] + s for p, s in zip(parts, starts)])
        return cls(np.concatenate([p.points for p in parts]), offsets)

    def __len__(self) -> int:
        return len(self.offsets) - 1

    @overload
    def __getitem__(self, index: int) -> np.ndarray: ...

    @overload
    def __getitem__(self, index: slice) -> Paths: ...

    def __getitem__(self, index: int | slice) -> np.ndarray | Paths:
        """Path ``index`` (negative counts from the end) as a read-only ``(k, 2)`` view, or the
        paths of a slice as :class:`Paths`."""
        count = len(self)
        if isinstance(index, slice):
            start, stop, step = index.indices(count)
            if step != 1:
                return self.take(np.arange(start, stop, step))
            if start >= stop:
                return Paths.empty()
            first, end = self.offsets[start], self.offsets[stop]
            return Paths(self.points[first:end], self.offsets[start : stop + 1] - first)
        if not -count <= index < count:
            raise IndexError(f"path {index} of {count}")
        index %= count
        return self.points[self.offsets[index] : self.offsets[index + 1]]

    def __iter__(self) -> Iterator[np.ndarray]:
        points, bounds = self.points, self.offsets.tolist()
        return (points[a:b] for a, b in zip(bounds[:-1], bounds[1:]))

    def __eq__(self, other) -> bool:
        if not isinstance(other, Paths):
            return NotImplemented
        return np.array_equal(self.offsets, other.offsets) and np.array_equal(self.points, other.points)

    __hash__ = None  # type: ignore[assignment]  # equal by value, but mutable-looking: no hash

    def __repr__(self) -> str:
        return f"Paths({len(self)} paths, {len(self.points)} points)"

    @property
    def lengths(self) -> np.ndarray:
        """Points per path, ``(P,)`` int64."""
        return np.diff(self.offsets)

    @property
    def firsts(self) -> np.ndarray:
        """First point of every path, ``(P, 2)``."""
        return self.points[self.offsets[:-1]]

    @property
    def lasts(self) -> np.ndarray:
        """Last point of every path, ``(P, 2)``."""
        return self.points[self.offsets[1:] - 1]

    def drawn_lengths(self) -> np.ndarray:
        """Length of every path along its points, ``(P,)`` float64 (mm; 0 for a dot)."""
        counts = self.lengths - 1
        drawn = np.zeros(len(self))
        if not counts.any():
            return drawn
        segments = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
        segments = np.delete(segments, self.offsets[1:-1] - 1)  # the gaps between paths
        has = counts > 0
        drawn[has] = np.add.reduceat(segments, (np.cumsum(counts) - counts)[has])
        return drawn

    def take(self, order, reverse=None) -> Paths:
        """The paths ``order`` (indices, in that order); those where ``reverse`` (per taken path,
        bool) is true run last point first."""
        order = np.asarray(order, np.int64).reshape(-1)
        if order.size == 0:
            return Paths.empty()
        sizes = self.lengths[order]
        ramp = ramps(sizes)
        index = np.repeat(self.offsets[order], sizes)
        if reverse is None:
            index += ramp
        else:
            index += np.where(
                np.repeat(np.asarray(reverse, bool), sizes), np.repeat(sizes - 1, sizes) - ramp, ramp
            )
        return Paths(self.points[index], np.concatenate([[0], np.cumsum(sizes)]))

    def owners(self) -> np.ndarray:
        """Index of the path each point belongs to, ``(N,)`` int64."""
        return np.repeat(np.arange(len(self)), self.lengths)

    def with_points(self, points: np.ndarray) -> Paths:
        """The same paths through other points (e.g. mapped to another frame), ``(N, 2)``."""
        return Paths(points, self.offsets)


def ramps(sizes) -> np.ndarray:
    """0, 1, …, s − 1 for every s in ``sizes``, back to back: ``(Σ sizes,)`` intp (the place of
    each point in its path, when ``sizes`` are path lengths)."""
    sizes = np.asarray(sizes, np.intp)
    return np.arange(int(sizes.sum())) - np.repeat(np.cumsum(sizes) - sizes, sizes)
