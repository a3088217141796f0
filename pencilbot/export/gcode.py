"""Plan → G-code for a plotter profile, in its firmware's dialect.

The program is, in order: header comments (source, profile, page placement, estimated time,
pen-down/pen-up lengths), the profile's header, pen up, then for each path a ``G0`` travel to its
first point, pen down (plus dwell), ``G1`` moves along it, pen up (plus dwell); finally ``G0``
back to machine ``X0 Y0`` and the profile's footer. No command is repeated without effect: a
point that rounds onto the previous one is dropped, a travel to where the pen already is is
dropped, and ``F`` is written only when the feed in force changes (GRBL's ``G0`` ignores ``F``, so
GRBL only ever gets the drawing feed; Marlin's ``G0`` uses ``F``, so travel and drawing alternate).
Dwells follow the firmware: GRBL ``G4 P`` in seconds, Marlin ``G4 P`` in milliseconds. Every line
is at most 80 characters (GRBL's line buffer). With ``line_numbers`` (Marlin) each command line
becomes ``N<n> <command>*<checksum>``, the checksum being the XOR of the bytes before ``*``. The
firmware's facts come from the registry (:attr:`~pencilbot.machine.profile.Profile.firmware`);
the header's time and lengths are :func:`pencilbot.planning.stats.estimate`, what ``stat`` and
``demo`` report.

Every coordinate is mapped to the machine by :class:`~pencilbot.machine.bed.Placement` and checked against the bed
before anything is written; the file is written to a temporary name and renamed, so a refused or
failed export leaves no partial file. Formatting is vectorised: every line is a row of one
NUL-padded byte matrix (digits gathered from lookup tables), and the file is that matrix, in
drawing order, without its NULs; 100 000 strokes take well under a second.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import numpy as np

from pencilbot.errors import OutOfBedError, PencilbotError
from pencilbot.export.gcode_text import INT_DIGITS, ascii_lines, gather, number_rows, number_text, text_rows
from pencilbot.fileio import write_atomic
from pencilbot.machine.bed import Placement
from pencilbot.machine.profile import MAX_LINE, Profile
from pencilbot.planning.plan import Page, Plan
from pencilbot.planning.stats import PlanStats, duration_text, estimate

#: File names G-code goes by (the first is the one export gives).
GCODE_SUFFIXES = (".gcode", ".nc", ".gc", ".ngc", ".g")

#: The comment before each pen change of a colour plan (its pen, as :func:`pens_at_pauses` reads it).
PEN_CHANGE_NOTE = "pen change {number} of {count}: {pen} {color} {width:g} mm"
_PEN_CHANGE_NOTE = re.compile(
    rb"(?m)^; pen change \d+ of \d+: (?P<pen>[A-Za-z0-9][A-Za-z0-9 _.+-]*) (?P<color>#[0-9a-f]{6}) (?P<width>[0-9.]+) mm\r?$"
)
#: The header's pen of a one-pen plan (a colour plan's header names each pen with its width), as
#: :func:`header_pen_width` reads it: what a simulator draws the file with.
PEN_WIDTH_NOTE = "pen width: {width:g} mm"
_PEN_WIDTH_NOTE = re.compile(rb"(?m)^; pen width: (?P<width>[0-9.]+) mm\r?$")
_PAUSE_LINE = re.compile(
    rb"(?mi)^[ \t]*(?:N\d+[ \t]*)?M0*0(?![\d.])"
)  # the bed check keeps |coordinate| ≤ MAX_BED mm


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


def gcode_program(plan: Plan, profile: Profile, *, source: str = "") -> bytes:
    """The G-code :func:`write_gcode` would write, as one ASCII text (what a sender streams)."""
    return _program(plan, profile, source)[0]


def gcode_lines(plan: Plan, profile: Profile, *, source: str = "") -> list[str]:
    """The G-code :func:`write_gcode` would write, as a list of lines without newlines."""
    return gcode_program(plan, profile, source=source).decode("ascii").splitlines()


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
    on_machine = np.round(placement.to_machine(points), profile.gcode.decimals) + 0.0  # no "-0"
    _check_bed(on_machine, placement, profile)

    stats = estimate(plan, profile)
    moves = _Moves.of(on_machine, paths.lengths, profile)
    changes = _pen_changes(plan, profile, placement)
    notes = [
        "\n".join([*changes.get(index, []), _comment(f"layer {layer.name}: {n} paths")])
        for index, (layer, n) in enumerate(zip(plan.layers, layer_sizes))
        if n
    ]
    head = _header_comments(plan, profile, placement, stats, source) + profile.render(profile.gcode.header)
    program = b"".join(
        [
            ascii_lines(head),
            _body(
                moves,
                profile,
                first_paths=(np.cumsum(layer_sizes) - layer_sizes)[layer_sizes > 0],
                notes=notes,
            ),
            ascii_lines(profile.render(profile.gcode.footer)),
        ]
    )
    if profile.gcode.line_numbers:
        program = b"\n".join(profile.firmware.number_lines(program.split(b"\n")[:-1])) + b"\n"
    return program, stats, placement, len(paths)


def _body(moves: _Moves, profile: Profile, *, first_paths: np.ndarray, notes: list[str]) -> bytes:
    """Pen up, every path (travel, pen down, moves, pen up), home; ``notes[i]`` comments go
    before path ``first_paths[i]``."""
    pen = profile.pen_model
    up = _pen_lines(pen.up_lines, pen.up_delay, profile)
    down = _pen_lines(pen.down_lines, pen.down_delay, profile)
    # One table of lines: the pen-up block, the pen-down block, one row per move (last: home).
    width = max([moves.width(profile)] + [len(line) + 1 for line in up + down])
    table = np.vstack([text_rows(up + down, width), moves.rows(profile, width)])
    up_ids, down_ids = np.arange(len(up)), np.arange(len(up), len(up) + len(down))
    paths, path_offsets = moves.sequence(down_ids, up_ids, first_id=len(up) + len(down))
    already_home = len(moves.xy) > 1 and not moves.xy[-2].any()  # the last path ends at X0 Y0
    go_home = np.array([] if already_home else [len(table) - 1], dtype=np.int64)
    order = np.concatenate([up_ids, paths, go_home])
    return gather(table, order, cuts=len(up) + path_offsets[first_paths], inserts=notes)


def _pen_changes(plan: Plan, profile: Profile, placement: Placement) -> dict[int, list[str]]:
    """Layer index → the lines that ask for its pen, before the first layer of each pen of a
    plan drawn with several (the first pen is asked for too: the plotter may hold any).

    The pen is up there already (every path ends with it up, the program starts with it up);
    the carriage parks where the profile says, then the profile's pen-change template (by
    default ``M0 (pen change: insert NAME)``) stops the job until the pen is in.
    """
    pens = plan.pens
    if len(pens) < 2:
        return {}
    park = profile.pen_change.park
    park_lines = []
    if park is not None:
        _check_bed(
            np.array([park]),
            placement,
            profile,
            what=f"the pen-change park position {park[0]:g}, {park[1]:g}",
        )
        feed = (
            f" F{number_text(profile.motion.travel_feed, profile.gcode.decimals)}"
            if profile.firmware.rapids_take_feed
            else ""
        )
        park_lines = [
            f"G0 X{number_text(park[0], profile.gcode.decimals)} Y{number_text(park[1], profile.gcode.decimals)}{feed}"
        ]
    changes: dict[int, list[str]] = {}
    start = 0
    for pen, layers in plan.pen_runs():
        first = next((start + i for i, layer in enumerate(layers) if len(layer.paths)), None)
        start += len(layers)
        if first is None or not pen:  # nothing drawn, or layers that name no pen (any will do)
            continue
        layer, number = plan.layers[first], len(changes) + 1
        changes[first] = [
            _comment(
                PEN_CHANGE_NOTE.format(
                    number=number, count=len(pens), pen=pen, color=layer.color, width=layer.pen_width
                )
            ),
            *park_lines,
            *profile.pen_change_lines(pen, number),
        ]
    return changes


@dataclass(frozen=True)
class PenInFile:
    """A pen a G-code file asks for: name, ink ``#rrggbb``, width mm."""

    name: str
    color: str
    width: float


def header_pen_width(program: bytes) -> float | None:
    """The pen width (mm) a one-pen program's header names (:data:`PEN_WIDTH_NOTE`); None when it
    names none (another tool's file, a colour plan: see :func:`pens_at_pauses`)."""
    found = _PEN_WIDTH_NOTE.search(program, 0, 8192)  # the header: the first lines
    return float(found["width"]) if found else None


def pens_at_pauses(program: bytes) -> list[PenInFile | None]:
    """For each ``M0`` pause of a program, in order, the pen drawn after it: the pen its
    pen-change note names (see :data:`PEN_CHANGE_NOTE`), or the pen before it (None before any)
    for a pause that is no pen change. What a simulator needs to tell the pens' strokes apart.
    """
    events = sorted(
        [
            (m.start(), PenInFile(m["pen"].decode(), m["color"].decode(), float(m["width"])))
            for m in _PEN_CHANGE_NOTE.finditer(program)
        ]
        + [(m.start(), None) for m in _PAUSE_LINE.finditer(program)],
        key=lambda e: e[0],
    )
    pens, current = [], None
    for _, pen in events:
        if pen is not None:
            current = pen
        else:
            pens.append(current)
    return pens


def _check_bed(
    on_machine: np.ndarray, placement: Placement, profile: Profile, *, what: str = "the drawing"
) -> None:
    if not len(on_machine):
        return
    if not profile.bed.outside(on_machine).any():
        return
    low, high = on_machine.min(axis=0), on_machine.max(axis=0)
    (x0, x1), (y0, y1) = placement.machine_range()
    page = cast(Page, placement.page)  # G-code is written for a plan's page
    raise OutOfBedError(
        f"{what} does not fit the bed of plotter profile {profile.name}: it spans "
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
    def of(cls, on_machine: np.ndarray, counts: np.ndarray, profile: Profile) -> _Moves:
        first = np.zeros(len(on_machine), dtype=bool)
        first[np.cumsum(counts) - counts] = True
        moved = np.ones(len(on_machine), dtype=bool)
        moved[1:] = (on_machine[1:] != on_machine[:-1]).any(axis=1)
        # A travel is dropped when the pen is already there (previous path ended on this point),
        # a drawing move when it rounds onto the previous point.
        keep = moved.copy()
        keep[:1] = True
        path_of_point = np.repeat(np.arange(len(counts)), counts)
        rows_per_path = np.bincount(path_of_point[keep], minlength=len(counts))
        travels = keep[first].astype(np.int64)
        xy = np.concatenate([on_machine[keep], [[0.0, 0.0]]])  # + home
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
        number = 1 + INT_DIGITS + 1 + profile.gcode.decimals
        return 4 + number + 2 + number + max(map(len, self._feed_words(profile))) + 1

    def rows(self, profile: Profile, width: int) -> np.ndarray:
        """Every move row as ASCII G-code in a NUL-padded ``(R, width)`` byte matrix."""
        dec = profile.gcode.decimals
        number = 1 + INT_DIGITS + 1 + dec
        draw = self.draw.astype(np.int64)
        out = np.zeros((len(self.xy), width), dtype=np.uint8)
        out[:, :4] = text_rows(["G0 X", "G1 X"], 4, newline=False)[draw]
        out[:, 4 : 4 + number] = number_rows(self.xy[:, 0], dec)
        out[:, 4 + number : 6 + number] = np.frombuffer(b" Y", np.uint8)
        out[:, 6 + number : 6 + 2 * number] = number_rows(self.xy[:, 1], dec)
        feeds = text_rows(self._feed_words(profile), width - 7 - 2 * number, newline=False)
        out[:, 6 + 2 * number : -1] = np.where(self.feed[:, None], feeds[draw], 0)
        out[:, -1] = ord("\n")
        return out

    @staticmethod
    def _feed_words(profile: Profile) -> list[str]:
        """``" F<travel>"`` and ``" F<draw>"``."""
        return [
            f" F{number_text(v, profile.gcode.decimals)}"
            for v in (profile.motion.travel_feed, profile.motion.draw_feed)
        ]


def _feed_changes(draw: np.ndarray, path_start: np.ndarray, profile: Profile) -> np.ndarray:
    """Rows that must carry ``F``: the first move the feed applies to, and every change.

    GRBL's G0 runs at the machine's max rate and leaves the modal F alone, so only G1 rows count;
    Marlin's G0 takes F too. If a pen template sets F itself, the feed is unknown after it.
    """
    applies = draw | profile.firmware.rapids_take_feed  # rows whose motion uses the modal F
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
    words = " ".join(profile.pen_model.up_lines + profile.pen_model.down_lines)
    return any(w.upper().startswith("F") for w in words.split(";")[0].split())


def _pen_lines(lines: tuple[str, ...], delay: float, profile: Profile) -> list[str]:
    """A pen command and its dwell, in the firmware's units."""
    dwell = profile.firmware.dwell(delay)
    return [*lines, dwell] if dwell else list(lines)


def _header_comments(
    plan: Plan, profile: Profile, placement: Placement, stats: PlanStats, source: str
) -> list[str]:
    page, bed = plan.page, profile.bed
    total = stats.total
    pens = [
        _comment(f"pen {number} of {len(plan.pens)}: {pen} {layers[0].color} {layers[0].pen_width:g} mm")
        for number, (pen, layers) in enumerate(((p, l) for p, l in plan.pen_runs() if p), start=1)
    ]
    return [
        _comment(f"pencilbot G-code for {profile.name} ({profile.dialect})"),
        _comment(f"source: {source or plan.meta.get('source') or 'plan'}"),
        _comment(f"profile: {profile.source}"),
        _comment(
            f"page: {page.name} {page.width:g} x {page.height:g} mm on a {bed.width:g} x "
            f"{bed.height:g} mm bed"
        ),
        _comment(placement.describe()),
        _comment(f"estimated time: {duration_text(total.seconds)} ({total.seconds:.0f} s)"),
        _comment(
            f"pen down {total.pen_down_mm:.1f} mm, pen up {total.pen_up_mm:.1f} mm, "
            f"{total.paths} paths, {total.lifts} lifts"
        ),
        *(pens or [_comment(PEN_WIDTH_NOTE.format(width=plan.pen_width))]),
    ]


def _comment(text: str) -> str:
    """A ``;`` comment line: printable ASCII only, cut to the line limit."""
    clean = "".join(c if " " <= c <= "~" else "?" for c in text)
    line = f"; {clean}"
    return line if len(line) <= MAX_LINE else line[: MAX_LINE - 3] + "..."
