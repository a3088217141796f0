"""Plan → G-code in a plotter profile's dialect.

The program is, in order: header comments (source, profile, page placement, estimated time,
pen-down/pen-up lengths), the profile's header, pen up, then for each path a ``G0`` travel to its
first point, pen down (plus dwell), ``G1`` moves along it, pen up (plus dwell); finally ``G0``
back to machine ``X0 Y0`` and the profile's footer. No command is repeated without effect: a
point that rounds onto the previous one is dropped, a travel to where the pen already is is
dropped, and ``F`` is written only when the feed in force changes (GRBL's ``G0`` ignores ``F``, so
GRBL only ever gets the drawing feed; Marlin's ``G0`` uses ``F``, so travel and drawing alternate).
Dwells follow the dialect: GRBL ``G4 P`` in seconds, Marlin ``G4 P`` in milliseconds. Every line
is at most 80 characters (GRBL's line buffer). With ``line_numbers`` (Marlin) each command line
becomes ``N<n> <command>*<checksum>``, the checksum being the XOR of the bytes before ``*``.

Every coordinate is mapped to the machine by :class:`Placement` and checked against the bed
before anything is written; the file is written to a temporary name and renamed, so a refused or
failed export leaves no partial file. Formatting is vectorised: every line is a row of one
NUL-padded byte matrix (digits gathered from lookup tables), and the file is that matrix, in
drawing order, without its NULs; 100 000 strokes take well under a second.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from pencilbot.errors import OutOfBedError, PencilbotError
from pencilbot.fileio import write_atomic
from pencilbot.gcode.profiles import MAX_BED, MAX_LINE, Bed, Profile
from pencilbot.planning.motion import PlanStats, duration_text, estimate
from pencilbot.planning.plan import Page, Plan

_INT_DIGITS = len(str(MAX_BED))  # the bed check keeps |coordinate| ≤ MAX_BED mm


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
    page : Page
        The sheet, in plan coordinates (mm, origin bottom-left, Y up).
    bed : Bed
        The profile's bed.
    rotated : bool
        Whether the sheet lies turned a quarter turn.
    """

    page: Page
    bed: Bed
    rotated: bool

    @classmethod
    def on_bed(cls, page: Page, bed: Bed) -> Placement:
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
        bx = (-self.bed.width, 0.0) if self.bed.invert_x else (0.0, self.bed.width)
        by = (-self.bed.height, 0.0) if self.bed.invert_y else (0.0, self.bed.height)
        return bx, by


@dataclass(frozen=True)
class GcodeSummary:
    """What :func:`write_gcode` wrote: file, size, paths, and the plan's motion statistics."""

    path: str
    lines: int
    bytes: int
    paths: int  # paths drawn
    stats: PlanStats
    placement: Placement


def write_gcode(plan: Plan, profile: Profile, path: str | Path, *, source: str = "") -> GcodeSummary:
    """Write ``plan`` as G-code for ``profile`` to ``path`` (atomically).

    Parameters
    ----------
    plan : Plan
        Paths in page mm (origin bottom-left, Y up), drawn in order.
    profile : Profile
        The plotter: dialect, bed, feeds, pen commands, format.
    path : str or Path
        Output file; replaced only once the whole program is written.
    source : str, optional
        Where the plan came from, stated in the header comments.

    Returns
    -------
    GcodeSummary

    Raises
    ------
    OutOfBedError
        A coordinate falls outside the bed; nothing is written.
    PencilbotError
        The plan holds NaN/inf coordinates, or the file cannot be written.
    """
    program, stats, placement, paths = _program(plan, profile, source)
    target = Path(path)
    write_atomic(target, program)
    return GcodeSummary(
        path=str(target),
        lines=program.count(b"\n"),
        bytes=len(program),
        paths=paths,
        stats=stats,
        placement=placement,
    )


def gcode_lines(plan: Plan, profile: Profile, *, source: str = "") -> list[str]:
    """The G-code :func:`write_gcode` would write, as a list of lines without newlines."""
    return _program(plan, profile, source)[0].decode("ascii").splitlines()


# --- building the program ----------------------------------------------------------------------


def _program(plan: Plan, profile: Profile, source: str) -> tuple[bytes, PlanStats, Placement, int]:
    """The whole file, the plan's motion statistics, the placement, and the paths drawn."""
    placement = Placement.on_bed(plan.page, profile.bed)
    paths = plan.paths()
    layer_sizes = np.array([len(layer.paths) for layer in plan.layers], dtype=np.int64)
    points = paths.points
    if not np.isfinite(points).all():
        raise PencilbotError(
            "the plan has coordinates that are not numbers (NaN or infinity); "
            "make the plan again from the picture"
        )
    machine = np.round(placement.to_machine(points), profile.gcode.decimals) + 0.0  # no "-0"
    _check_bed(machine, placement, profile)

    home = placement.to_page(np.zeros((1, 2)))[0]  # machine X0 Y0, where the plot starts
    stats = estimate(plan, profile.motion_settings(), start=tuple(home))
    moves = _Moves.of(machine, paths.lengths, profile)
    notes = [_comment(f"layer {layer.name}: {n} paths") for layer, n in zip(plan.layers, layer_sizes) if n]
    head = _header_comments(plan, profile, placement, stats, source) + profile.render(profile.gcode.header)
    program = b"".join([
        _text(head),
        _body(moves, profile, first_paths=(np.cumsum(layer_sizes) - layer_sizes)[layer_sizes > 0], notes=notes),
        _text(profile.render(profile.gcode.footer)),
    ])
    if profile.gcode.line_numbers:
        program = b"\n".join(_numbered(program.split(b"\n")[:-1])) + b"\n"
    return program, stats, placement, len(paths)


def _body(moves: _Moves, profile: Profile, *, first_paths: np.ndarray, notes: list[str]) -> bytes:
    """Pen up, every path (travel, pen down, moves, pen up), home; ``notes[i]`` comments go
    before path ``first_paths[i]``."""
    up = _pen_lines(profile, profile.pen.up_command, profile.pen.up_delay)
    down = _pen_lines(profile, profile.pen.down_command, profile.pen.down_delay)
    # One table of lines: the pen-up block, the pen-down block, one row per move (last: home).
    width = max([moves.width(profile)] + [len(line) + 1 for line in up + down])
    table = np.vstack([_text_rows(up + down, width), moves.rows(profile, width)])
    up_ids, down_ids = np.arange(len(up)), np.arange(len(up), len(up) + len(down))
    paths, path_offsets = moves.sequence(down_ids, up_ids, first_id=len(up) + len(down))
    already_home = len(moves.xy) > 1 and not moves.xy[-2].any()  # the last path ends at X0 Y0
    go_home = np.array([] if already_home else [len(table) - 1], dtype=np.int64)
    order = np.concatenate([up_ids, paths, go_home])
    return _gather(table, order, cuts=len(up) + path_offsets[first_paths], inserts=notes)


def _check_bed(machine: np.ndarray, placement: Placement, profile: Profile) -> None:
    if not len(machine):
        return
    low, high = machine.min(axis=0), machine.max(axis=0)
    (x0, x1), (y0, y1) = placement.machine_range()
    if low[0] >= x0 and high[0] <= x1 and low[1] >= y0 and high[1] <= y1:
        return
    page = placement.page
    raise OutOfBedError(
        f"the drawing does not fit the bed of plotter profile {profile.name}: it spans "
        f"X {low[0]:g} .. {high[0]:g} and Y {low[1]:g} .. {high[1]:g} mm in machine coordinates, "
        f"the bed allows X {x0:g} .. {x1:g} and Y {y0:g} .. {y1:g} mm "
        f"(page {page.name} {page.width:g} x {page.height:g} mm, {placement.describe()}); "
        "use a smaller page or a profile with a larger bed"
    )


@dataclass
class _Moves:
    """The G0/G1 rows of the program: one per kept point, plus the final return home."""

    xy: np.ndarray  # (R, 2) machine mm, rounded
    draw: np.ndarray  # (R,) bool: G1 (pen down) or G0
    feed: np.ndarray  # (R,) bool: write F on this row
    rows_per_path: np.ndarray  # (P,) travel row (0 or 1) + drawing rows
    travels: np.ndarray  # (P,) 1 if the path's travel row is kept

    @classmethod
    def of(cls, machine: np.ndarray, counts: np.ndarray, profile: Profile) -> _Moves:
        first = np.zeros(len(machine), dtype=bool)
        first[np.cumsum(counts) - counts] = True
        moved = np.ones(len(machine), dtype=bool)
        moved[1:] = (machine[1:] != machine[:-1]).any(axis=1)
        # A travel is dropped when the pen is already there (previous path ended on this point),
        # a drawing move when it rounds onto the previous point.
        keep = moved.copy()
        keep[:1] = True
        path_of_point = np.repeat(np.arange(len(counts)), counts)
        rows_per_path = np.bincount(path_of_point[keep], minlength=len(counts))
        travels = keep[first].astype(np.int64)
        xy = np.concatenate([machine[keep], [[0.0, 0.0]]])  # + home
        draw = np.concatenate([~first[keep], [False]])
        path_start = np.zeros(len(xy), dtype=bool)
        path_start[(np.cumsum(rows_per_path) - rows_per_path)[rows_per_path > 0]] = True
        feed = _feed_changes(draw, path_start, profile)
        return cls(xy, draw, feed, rows_per_path, travels)

    def sequence(self, down: np.ndarray, up: np.ndarray, first_id: int) -> tuple[np.ndarray, np.ndarray]:
        """Line ids of all paths (travel, pen down, drawing moves, pen up; move ids from
        ``first_id``) and the index where each path's lines start."""
        d, u = len(down), len(up)
        t = self.travels
        drawing = self.rows_per_path - t
        sizes = t + d + drawing + u
        start = np.cumsum(sizes) - sizes
        body = np.empty(int(sizes.sum()), dtype=np.int64)
        row_start = np.cumsum(self.rows_per_path) - self.rows_per_path
        path = np.repeat(np.arange(len(sizes)), self.rows_per_path)
        k = np.arange(len(path)) - row_start[path]  # row index within its path
        body[start[path] + np.where(k < t[path], k, k + d)] = first_id + np.arange(len(path))
        body[(start + t)[:, None] + np.arange(d)] = down
        body[(start + t + d + drawing)[:, None] + np.arange(u)] = up
        return body, start

    def width(self, profile: Profile) -> int:
        """Bytes of the longest possible move row: G word, X and Y words, F word, newline."""
        number = 1 + _INT_DIGITS + 1 + profile.gcode.decimals
        return 4 + number + 2 + number + max(map(len, self._feed_words(profile))) + 1

    def rows(self, profile: Profile, width: int) -> np.ndarray:
        """Every move row as ASCII G-code in a NUL-padded ``(R, width)`` byte matrix."""
        dec = profile.gcode.decimals
        number = 1 + _INT_DIGITS + 1 + dec
        draw = self.draw.astype(np.int64)
        out = np.zeros((len(self.xy), width), dtype=np.uint8)
        out[:, :4] = _text_rows(["G0 X", "G1 X"], 4, newline=False)[draw]
        out[:, 4 : 4 + number] = _number_rows(self.xy[:, 0], dec)
        out[:, 4 + number : 6 + number] = np.frombuffer(b" Y", np.uint8)
        out[:, 6 + number : 6 + 2 * number] = _number_rows(self.xy[:, 1], dec)
        feeds = _text_rows(self._feed_words(profile), width - 7 - 2 * number, newline=False)
        out[:, 6 + 2 * number : -1] = np.where(self.feed[:, None], feeds[draw], 0)
        out[:, -1] = ord("\n")
        return out

    @staticmethod
    def _feed_words(profile: Profile) -> list[str]:
        """``" F<travel>"`` and ``" F<draw>"``."""
        return [f" F{_number_text(v, profile.gcode.decimals)}"
                for v in (profile.motion.travel_feed, profile.motion.draw_feed)]


def _feed_changes(draw: np.ndarray, path_start: np.ndarray, profile: Profile) -> np.ndarray:
    """Rows that must carry ``F``: the first move the feed applies to, and every change.

    GRBL's G0 runs at the machine's max rate and leaves the modal F alone, so only G1 rows count;
    Marlin's G0 takes F too. If a pen template sets F itself, the feed is unknown after it.
    """
    applies = draw | (profile.dialect == "marlin")  # rows whose motion uses the modal F
    feed_value = draw[applies]
    changed = np.ones(len(feed_value), dtype=bool)
    changed[1:] = feed_value[1:] != feed_value[:-1]
    if _pen_sets_feed(profile):
        # Pen commands come before every travel (pen up) and before a path's first drawing
        # move (pen down), which is its first row or the row after its travel.
        after_travel = np.concatenate([[True], ~draw[:-1]])
        changed |= (~draw | path_start | after_travel)[applies]
    result = np.zeros(len(draw), dtype=bool)
    result[applies] = changed
    return result


def _pen_sets_feed(profile: Profile) -> bool:
    words = " ".join(profile.render(profile.pen.up_command) + profile.render(profile.pen.down_command))
    return any(w.upper().startswith("F") for w in words.split(";")[0].split())


def _pen_lines(profile: Profile, template: str, delay: float) -> list[str]:
    lines = profile.render(template)
    # GRBL dwells in seconds, Marlin in milliseconds
    p = _number_text(delay, 3) if profile.dialect == "grbl" else str(round(delay * 1000))
    if p != "0":
        lines.append(f"G4 P{p}")
    return lines


def _header_comments(plan: Plan, profile: Profile, placement: Placement, stats: PlanStats,
                     source: str) -> list[str]:
    page, bed = plan.page, profile.bed
    total = stats.total
    return [
        _comment(f"pencilbot G-code for {profile.name} ({profile.dialect})"),
        _comment(f"source: {source or plan.meta.get('source') or 'plan'}"),
        _comment(f"profile: {profile.source}"),
        _comment(f"page: {page.name} {page.width:g} x {page.height:g} mm on a {bed.width:g} x "
                 f"{bed.height:g} mm bed"),
        _comment(placement.describe()),
        _comment(f"estimated time: {duration_text(total.seconds)} ({total.seconds:.0f} s)"),
        _comment(f"pen down {total.pen_down_mm:.1f} mm, pen up {total.pen_up_mm:.1f} mm, "
                 f"{total.paths} paths, {total.lifts} lifts"),
    ]


def _comment(text: str) -> str:
    """A ``;`` comment line: printable ASCII only, cut to the line limit."""
    clean = "".join(c if " " <= c <= "~" else "?" for c in text)
    line = f"; {clean}"
    return line if len(line) <= MAX_LINE else line[: MAX_LINE - 3] + "..."


def _numbered(lines: list[bytes]) -> list[bytes]:
    """``N<n> <command>*<checksum>`` on every command line, starting with ``M110 N0``.

    Comment lines stay as they are; trailing comments go, since Marlin would read a ``*`` after
    ``;`` as comment. Same framing as :func:`firmware_protocol.marlin.frame_line`, with the XOR
    done by numpy over all lines at once (a Python loop per byte is seconds for a big plan).
    """
    lines = [b"M110 N0", *lines]
    is_command = [not line.startswith(b";") for line in lines]
    numbered = [
        b"N%d %s" % (n, line.split(b";")[0].rstrip())
        for n, line in enumerate(line for line, cmd in zip(lines, is_command) if cmd)
    ]
    lengths = np.fromiter(map(len, numbered), dtype=np.int64, count=len(numbered))
    blob = np.frombuffer(b"".join(numbered), dtype=np.uint8)
    checksums = np.bitwise_xor.reduceat(blob, np.cumsum(lengths) - lengths).tolist()
    framed = iter([b"%s*%d" % (line, cs) for line, cs in zip(numbered, checksums)])
    return [next(framed) if cmd else line for line, cmd in zip(lines, is_command)]


# --- vectorised number formatting --------------------------------------------------------------


def _number_rows(values: np.ndarray, decimals: int) -> np.ndarray:
    """``values`` (already rounded) as ASCII, up to ``decimals`` digits, trailing zeros dropped.

    A NUL-padded ``(N, 1 + 5 + 1 + decimals)`` byte matrix: sign, integer digits, point and
    fraction. Digits come from lookup tables, so formatting is two gathers, not N str() calls.
    """
    scale = 10**decimals
    n = np.rint(np.abs(values) * scale).astype(np.int64)
    whole, frac = np.divmod(n, scale)
    sign = np.where((values < 0) & (n > 0), ord("-"), 0).astype(np.uint8)
    return np.hstack([sign[:, None], _integer_table()[whole], _fraction_table(decimals)[frac]])


@cache
def _integer_table() -> np.ndarray:
    """Row i: the digits of i (0 ≤ i ≤ MAX_BED) right-aligned, NUL-padded."""
    texts = [f"{i:>{_INT_DIGITS}}".replace(" ", "\0") for i in range(MAX_BED + 1)]
    return _text_rows(texts, _INT_DIGITS, newline=False)


@cache
def _fraction_table(decimals: int) -> np.ndarray:
    """Row f: ``"." + f`` as ``decimals`` digits without trailing zeros (nothing for 0)."""
    texts = [f".{f:0{decimals}d}".rstrip("0").rstrip(".") for f in range(10**decimals)]
    return _text_rows(texts, decimals + 1, newline=False)


def _number_text(value: float, decimals: int) -> str:
    """One value the way :func:`_number_rows` writes it (feeds, dwells)."""
    return f"{value:.{decimals}f}".rstrip("0").rstrip(".") if decimals else f"{value:.0f}"


def _text_rows(texts: list[str], width: int, *, newline: bool = True) -> np.ndarray:
    """Strings (plus newline) as a NUL-padded ``(len(texts), width)`` byte matrix."""
    blob = "".join(t.ljust(width - newline, "\0") + "\n" * newline for t in texts).encode("ascii")
    return np.frombuffer(blob, dtype=np.uint8).reshape(len(texts), width).copy()


def _gather(table: np.ndarray, order: np.ndarray, *, cuts: np.ndarray, inserts: list[str]) -> bytes:
    """The rows ``table[order]`` without their NUL padding, with line ``inserts[i]`` placed
    before row ``cuts[i]`` of ``order``."""
    picked = table[order]
    blob = picked[picked != 0].tobytes()
    lengths = np.count_nonzero(table, axis=1)[order]
    offsets = np.concatenate([[0], np.cumsum(lengths)])[cuts].tolist()
    pieces, start = [], 0
    for offset, line in zip(offsets, inserts):
        pieces += [blob[start:offset], line.encode("ascii") + b"\n"]
        start = offset
    return b"".join([*pieces, blob[start:]])


def _text(lines: list[str]) -> bytes:
    return "".join(f"{line}\n" for line in lines).encode("ascii")
