"""The virtual HP 7475A's instruction set beyond vectors (:mod:`sim.hpgl.board`): the
instructions the real plotter knows, the shapes it draws as chords, and a move instruction run
pair by pair as its bytes arrive.

* The 7475A's HP-GL (HP 7475A Interfacing and Programming Manual, appendix "HP-GL instruction
  set"): :data:`KNOWN`. Any other two letters is error 1. Circles (``CI``), arcs (``AA``,
  ``AR``) and edged rectangles (``EA``, ``ER``) are drawn as the plotter draws them, chords of
  the chord angle (default 5°); instructions whose drawing is not emulated (labels, fills,
  wedges, ticks, scaling) are taken and counted in the board's ``unemulated``, so a picture
  that lacks them says so instead of passing as exact.
* Streaming (:func:`complete_pairs`): the plotter runs a ``PU``/``PD``/``PA``/``PR`` coordinate
  pair as soon as both numbers are complete (a separator after each), so an instruction longer
  than the buffer is drawn as it comes instead of waiting for its terminator forever.
"""

from __future__ import annotations

import math
import re

#: The 7475A's instructions (the vector ones PU PD PA PR are the board's own).
KNOWN = frozenset(
    [
        "AA",
        "AR",
        "CA",
        "CI",
        "CP",
        "CS",
        "DC",
        "DF",
        "DI",
        "DP",
        "DR",
        "DT",
        "EA",
        "ER",
        "EW",
        "FT",
        "IM",
        "IN",
        "IP",
        "IW",
        "LB",
        "LT",
        "OA",
        "OC",
        "OD",
        "OE",
        "OF",
        "OH",
        "OI",
        "OO",
        "OP",
        "OS",
        "OW",
        "PA",
        "PD",
        "PR",
        "PS",
        "PT",
        "PU",
        "RA",
        "RO",
        "RR",
        "SA",
        "SC",
        "SI",
        "SL",
        "SM",
        "SP",
        "SR",
        "SS",
        "TL",
        "UC",
        "VS",
        "WG",
        "XT",
        "YT",
    ]
)
#: Known, taken, and setting nothing the emulated drawing depends on.
SETTINGS = frozenset(
    [
        "CA",
        "CS",
        "DC",
        "DF",
        "DI",
        "DP",
        "DR",
        "DT",
        "IM",
        "LT",
        "PS",
        "PT",
        "FT",
        "SA",
        "SI",
        "SL",
        "SM",
        "SR",
        "SS",
        "TL",
    ]
)
#: Known, but their drawing (or coordinate mapping) is not emulated.
UNEMULATED = frozenset(["CP", "LB", "RA", "RR", "WG", "EW", "XT", "YT", "UC", "SC", "IP", "IW", "RO"])
#: How many parameters each shape takes (least, most).
SHAPE_PARAMS = {"CI": (1, 2), "AA": (3, 4), "AR": (3, 4), "EA": (2, 2), "ER": (2, 2)}

_MOVE = re.compile(rb"\s*([Pp][UuDdAaRr])")
_TOKEN = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)")
_SEP = b", \t\r\n"


def complete_pairs(data: bytes) -> tuple[str, tuple[float, ...], int] | None:
    """A move instruction at the start of ``data`` still arriving: its mnemonic, the coordinate
    pairs complete so far, and the bytes they take (mnemonic included); None if none is."""
    head = _MOVE.match(data)
    if head is None:
        return None
    at, values, cut = head.end(), [], None
    while True:
        while at < len(data) and data[at] in _SEP:
            at += 1
        token = _TOKEN.match(data, at)
        if token is None or token.end() >= len(data) or data[token.end()] not in _SEP:
            break  # not a number, or not known to be complete yet
        values.append(float(token.group()))
        at = token.end() + 1
        if len(values) % 2 == 0:
            cut = at
    if cut is None:
        return None
    return head.group(1).decode().upper(), tuple(values[: len(values) // 2 * 2]), cut


def arc_points(
    cx: float, cy: float, x: float, y: float, sweep_deg: float, chord_deg: float
) -> list[tuple[float, float]]:
    """Points after the start along an arc about (cx, cy) from (x, y) through ``sweep_deg``
    (counter-clockwise positive), in chords of ``chord_deg`` (the last one shorter)."""
    radius = math.hypot(x - cx, y - cy)
    if radius == 0 or sweep_deg == 0:
        return []
    start = math.atan2(y - cy, x - cx)
    steps = max(int(math.ceil(abs(sweep_deg) / max(chord_deg, 0.36))), 1)
    angles = [start + math.radians(sweep_deg) * k / steps for k in range(1, steps + 1)]
    return [(cx + radius * math.cos(a), cy + radius * math.sin(a)) for a in angles]


def chord(params: tuple[float, ...], index: int) -> float:
    """The chord angle parameter at ``index`` (default 5°; the 7475A takes 0.36..180)."""
    return min(max(abs(params[index]) if len(params) > index else 5.0, 0.36), 180.0)


def shape(
    mnemonic: str, params: tuple[float, ...], x: float, y: float
) -> tuple[list[tuple[float, float]], bool] | None:
    """What a shape instruction at pen position (x, y) draws: the points the pen goes through
    after (x, y) and whether the pen is down for them regardless of its state (CI, EA, ER
    lower it and put it back); None for a wrong parameter count."""
    low, high = SHAPE_PARAMS[mnemonic]
    if not low <= len(params) <= high:
        return None
    if mnemonic == "CI":
        r = params[0]
        points = arc_points(x, y, x + r, y, 360.0, chord(params, 1))
        return [(x + r, y), *points, (x, y)], True  # out along the radius pen up is drawn by the caller
    if mnemonic in ("AA", "AR"):
        cx, cy = (params[0], params[1]) if mnemonic == "AA" else (x + params[0], y + params[1])
        return arc_points(cx, cy, x, y, params[2], chord(params, 3)), False
    ox, oy = (params[0], params[1]) if mnemonic == "EA" else (x + params[0], y + params[1])
    return [(ox, y), (ox, oy), (x, oy), (x, y)], True


def draw_shape(board, m: str, p: tuple[float, ...]) -> None:
    """``board`` (:class:`sim.hpgl.board.HpglBoard`) draws a circle, arc or edged rectangle as chords."""
    drawn = shape(m, p, board.x, board.y)
    if drawn is None:
        board.error = 2
        return
    chords, lowered = drawn
    points: list[tuple[float, float] | None] = list(chords)  # None: the pen lifts there
    was = board.down
    x0, y0, x1, y1 = board.limits
    if not all(x0 <= round(x) <= x1 and y0 <= round(y) <= y1 for x, y in chords):
        board.error = 3  # beyond the hard-clip limits: not drawn
        return
    if m == "CI":  # out to the edge pen up, round it pen down, back to the centre pen up
        board._pen(False)
        board._vector(round(chords[0][0]), round(chords[0][1]))
        points = [*chords[1:-1], None, chords[-1]]
    if lowered:
        board._pen(True)
    for point in points:
        if point is None:
            board._pen(False)
            continue
        board._vector(round(point[0]), round(point[1]))
    board._pen(was)
