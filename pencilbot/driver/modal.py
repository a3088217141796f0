"""Follow a G-code job's modal state line by line (units, distance mode, feed, position, pen).

The driver needs this for two things: to rebuild the machine state when a job resumes in the
middle, and to estimate how long each line takes for the progress ETA. It understands the subset
of G-code that pencilbot writes (G0 G1 G4 G20 G21 G90 G91, F X Y Z S P, M3 M5 M280); other words
pass through without changing the tracked state.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

_WORD = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")
_COMMENT = re.compile(r"\([^)]*\)|;.*")

MM_PER_INCH = 25.4


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


def words(line: str) -> dict[str, float]:
    """Letter → value of a cleaned line (the first occurrence of each letter; G and M kept apart
    by :func:`codes`)."""
    out: dict[str, float] = {}
    for letter, value in _WORD.findall(line):
        out.setdefault(letter, float(value))
    return out


def codes(line: str, letter: str) -> set[int]:
    """All integer codes of one letter on a line, e.g. ``codes("G21G90", "G") == {21, 90}``."""
    return {int(float(v)) for lt, v in _WORD.findall(line) if lt == letter}


@dataclass(frozen=True)
class PenModel:
    """How a plotter raises and lowers its pen, enough to tell pen state from G-code.

    Parameters
    ----------
    kind : {"spindle", "z", "servo"}
        Spindle pens move with ``M3 S…`` (``M5`` = up), Z pens with the Z axis, servo pens with
        ``M280 … S<angle>``.
    up, down : float
        The S value, Z height (mm) or servo angle (degrees) for pen up and pen down.
    up_lines, down_lines : tuple of str
        The G-code lines that raise / lower the pen on this plotter (cleaned).
    """

    kind: str
    up: float
    down: float
    up_lines: tuple[str, ...]
    down_lines: tuple[str, ...]

    def is_down(self, value: float) -> bool:
        """Whether an S / Z / angle value puts the pen on the paper (closer to down than up)."""
        return abs(value - self.down) < abs(value - self.up)


@dataclass(frozen=True)
class ModalState:
    """Machine state after some lines of a job, in the job's own units (mm or inch)."""

    inches: bool = False
    relative: bool = False
    feed: float | None = None
    motion: int = 0  # 0 = G0, 1 = G1 (modal)
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    spindle_on: bool = False
    s: float = 0.0
    servo: float | None = None
    pen_down: bool = False


def advance(state: ModalState, line: str, pen: PenModel) -> ModalState:
    """The state after executing one cleaned line.

    Parameters
    ----------
    state : ModalState
        State before the line.
    line : str
        A line cleaned by :func:`clean_line`.
    pen : PenModel
        Tells which values mean pen down.
    """
    if not line or line.startswith("$"):
        return state
    w = words(line)
    g = codes(line, "G")
    m = codes(line, "M")
    changes: dict = {}
    if 20 in g or 21 in g:
        changes["inches"] = 20 in g
    if 90 in g or 91 in g:
        changes["relative"] = 91 in g
    if "F" in w:
        changes["feed"] = w["F"]
    if 0 in g or 1 in g:
        changes["motion"] = 1 if 1 in g else 0
    if "S" in w and 280 not in m:
        changes["s"] = w["S"]
    if 3 in m or 4 in m:
        changes["spindle_on"] = True
    if 5 in m:
        changes["spindle_on"] = False
    if 280 in m and "S" in w:
        changes["servo"] = w["S"]
    if not ({4, 10, 28, 53, 92} & g):  # these take axis words that are not a move
        relative = changes.get("relative", state.relative)
        for axis in "XYZ":
            if axis in w:
                base = getattr(state, axis.lower()) if relative else 0.0
                changes[axis.lower()] = base + w[axis]
    new = replace(state, **changes)
    return replace(new, pen_down=_pen_down(new, pen))


def _pen_down(state: ModalState, pen: PenModel) -> bool:
    if pen.kind == "spindle":
        return state.spindle_on and pen.is_down(state.s)
    if pen.kind == "z":  # the profile's heights are mm; an inch job's Z is not
        return pen.is_down(state.z * MM_PER_INCH if state.inches else state.z)
    return state.servo is not None and pen.is_down(state.servo)


def line_seconds(before: ModalState, after: ModalState, line: str, travel_feed: float, dialect: str) -> float:
    """Rough duration of one line: distance over feed for moves, the dwell for ``G4``.

    Acceleration is ignored: this only feeds the progress ETA, which is rescaled by the observed
    pace while the job runs.

    Parameters
    ----------
    before, after : ModalState
        State around the line.
    line : str
        The cleaned line.
    travel_feed : float
        Rapid (G0) speed in mm/min.
    dialect : {"grbl", "marlin"}
        GRBL's ``G4 P`` is seconds, Marlin's milliseconds.
    """
    g = codes(line, "G")
    if 4 in g:
        w = words(line)
        if "S" in w:
            return w["S"]
        return w.get("P", 0.0) / (1000.0 if dialect == "marlin" else 1.0)
    dist = math.dist((before.x, before.y, before.z), (after.x, after.y, after.z))
    if dist == 0.0:
        return 0.0
    scale = MM_PER_INCH if after.inches else 1.0
    feed = travel_feed if after.motion == 0 or not after.feed else after.feed * scale
    return dist * scale / feed * 60.0
