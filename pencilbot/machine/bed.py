"""The bed: where machine coordinates run, and where a sheet of paper lies on it.

The one mapping between page millimetres (plan coordinates: origin at the sheet's bottom-left,
Y up) and machine millimetres is :class:`Placement`; the G-code writer, the time estimate and the
virtual plotter's picture of its bed (:meth:`Bed.to_view`) all use it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike

#: Corners where machine (0, 0) may be, seen from above.
ORIGINS = ("bottom-left", "top-left", "bottom-right", "top-right")
#: Largest bed side, mm: keeps every coordinate within five integer digits.
MAX_BED = 10_000


class Sheet(Protocol):
    """Anything with a size in mm, such as a :class:`pencilbot.planning.plan.Page`."""

    @property
    def width(self) -> float: ...

    @property
    def height(self) -> float: ...


@dataclass(frozen=True)
class Bed:
    """Drawable area: ``width`` × ``height`` mm from the ``origin`` corner (where machine (0, 0)
    is), whether machine X / Y run negative into the bed (e.g. homed at +X), and whether the
    firmware homes there and enforces the bed as soft limits."""

    width: float
    height: float
    origin: str
    invert_x: bool = False
    invert_y: bool = False
    homing: bool = False
    soft_limits: bool = False

    def machine_range(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Allowed machine ``(min, max)`` for X and for Y, mm."""
        bx = (-self.width, 0.0) if self.invert_x else (0.0, self.width)
        by = (-self.height, 0.0) if self.invert_y else (0.0, self.height)
        return bx, by

    def outside(self, machine: ArrayLike, tolerance: float = 0.0) -> np.ndarray:
        """Which machine points ``(N, 2+)`` mm lie off the bed (more than ``tolerance`` mm
        beyond its edges): a ``(N,)`` bool array. The one bed check (export and draw)."""
        xy = np.asarray(machine, dtype=np.float64)[:, :2]
        (x0, x1), (y0, y1) = self.machine_range()
        x, y = xy[:, 0], xy[:, 1]
        return ~(
            (x >= x0 - tolerance) & (x <= x1 + tolerance) & (y >= y0 - tolerance) & (y <= y1 + tolerance)
        )

    def to_view(self, machine: np.ndarray) -> np.ndarray:
        """Machine XY ``(N, 2+)`` mm → the bed seen from above: mm from its bottom-left, Y up."""
        whole_bed = Placement(page=self, bed=self, rotated=False)
        return whole_bed.to_page(np.asarray(machine, dtype=np.float64)[:, :2])


@dataclass(frozen=True)
class Placement:
    """Where the page sits on the bed, and the page mm → machine mm mapping.

    The sheet lies in the bed's ``origin`` corner (the corner machine ``(0, 0)`` is in), edges
    along the axes. It lies upright (page +y along the bed's far direction as seen from the
    front) when it fits that way; if it only fits turned a quarter turn, it lies rotated
    counter-clockwise, its top edge along the bed's left side. Machine coordinates are distances
    from the origin corner, negated on an inverted axis (a machine homed at +X runs X from 0 to
    −width).

    Attributes
    ----------
    page : Sheet
        The sheet (a :class:`pencilbot.planning.plan.Page`): its ``width`` and ``height`` in
        plan coordinates (mm, origin bottom-left, Y up).
    bed : Bed
        The profile's bed.
    rotated : bool
        Whether the sheet lies turned a quarter turn.
    """

    page: Sheet
    bed: Bed
    rotated: bool

    @classmethod
    def on_bed(cls, page: Sheet, bed: Bed) -> Placement:
        """Upright if the page fits the bed that way, else rotated if that fits, else upright."""
        upright = page.width <= bed.width and page.height <= bed.height
        turned = page.height <= bed.width and page.width <= bed.height
        return cls(page, bed, rotated=not upright and turned)

    @property
    def size(self) -> tuple[float, float]:
        """Width and height (mm) the sheet takes along the bed's X and Y."""
        w, h = self.page.width, self.page.height
        return (h, w) if self.rotated else (w, h)

    def to_machine(self, points: np.ndarray) -> np.ndarray:
        """Plan points ``(N, 2)`` (page mm, Y up) → machine coordinates ``(N, 2)`` mm."""
        x, y = np.asarray(points, dtype=np.float64).T
        if self.rotated:  # quarter turn counter-clockwise: page top edge on the bed's left side
            x, y = self.page.height - y, x
        x, y = self._from_origin_corner(x, y)
        return np.column_stack([-x if self.bed.invert_x else x, -y if self.bed.invert_y else y])

    def to_page(self, machine: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_machine`: machine mm ``(N, 2)`` → page mm, Y up."""
        x, y = np.asarray(machine, dtype=np.float64).T
        x, y = self._from_origin_corner(-x if self.bed.invert_x else x, -y if self.bed.invert_y else y)
        if self.rotated:
            x, y = y, self.page.height - x
        return np.column_stack([x, y])

    def _from_origin_corner(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # Distances from the sheet's left/bottom edges <-> from the origin corner (self-inverse).
        w, h = self.size
        vertical, horizontal = self.bed.origin.split("-")
        return (w - x if horizontal == "right" else x), (h - y if vertical == "top" else y)

    def describe(self) -> str:
        """One line for people: how to lay the sheet on the bed."""
        how = "turned 90 deg, top edge at the left," if self.rotated else "upright"
        return f"sheet {how} in the bed's {self.bed.origin} corner"

    def machine_range(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """Allowed machine ``(min, max)`` for X and for Y, mm."""
        return self.bed.machine_range()

    def home(self) -> np.ndarray:
        """Where machine ``X0 Y0`` (the pen's home, where a plot starts and ends) is on the page."""
        return self.to_page(np.zeros((1, 2)))[0]
