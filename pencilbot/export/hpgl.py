"""Plan → HP-GL for an HP-GL plotter profile (HP 7475A and kin), and HP-GL files → plans.

The program: ``IN;`` (initialise), ``VS`` (the profile's pen-down speed, cm/s), then for each pen
of the plan ``SP n`` (carousel slot ``n`` in load order: a colour plan is drawn without a
pause, the plotter fetches each pen itself; pens beyond the profile's ``[paper] carousel`` keep
their numbers, and ``draw`` pauses for each to be put in a slot by hand), and for each path a pen-up move to its first point
and one ``PD x,y;`` per further point; finally ``PU0,0;`` (home, as the estimate counts it) and
``SP0;`` (the pen back in the carousel). One instruction a line, in absolute plotter units
(0.025 mm, rounded); a point that rounds onto the previous one is dropped. Every coordinate is
placed by :class:`~pencilbot.machine.bed.Placement` and checked against the bed (the plotter's
hard-clip limits) before the file is written, atomically.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pencilbot.errors import OutOfBedError, PencilbotError
from pencilbot.fileio import read_bounded, write_atomic
from pencilbot.firmware.hpgl import HPGL, HPGL_SUFFIXES, MAX_HPGL_FILE
from pencilbot.machine.bed import Placement
from pencilbot.machine.profile import Profile
from pencilbot.planning.plan import Layer, Page, Plan
from pencilbot.planning.stats import PlanStats, estimate

__all__ = ["HPGL_SUFFIXES", "HpglSummary", "hpgl_plan", "hpgl_program", "write_hpgl"]


@dataclass(frozen=True)
class SheetPlacement(Placement):
    """A :class:`Placement` for a plotter whose limits lie inside the sheet: machine (0, 0) is
    ``offset`` mm (the profile's ``[paper] offset``) from the sheet's bottom-left corner."""

    offset: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def of(cls, page, profile: Profile) -> SheetPlacement:
        return cls(page, profile.bed, Placement.on_bed(page, profile.bed).rotated, profile.paper.offset)

    def to_machine(self, points: np.ndarray) -> np.ndarray:
        return super().to_machine(points) - np.asarray(self.offset)

    def to_page(self, on_machine: np.ndarray) -> np.ndarray:
        return super().to_page(np.asarray(on_machine, dtype=np.float64)[:, :2] + np.asarray(self.offset))

    def describe(self) -> str:
        x, y = self.offset
        if not (x or y):
            return super().describe()
        return f"{super().describe()}, its corner {x:g} mm left of and {y:g} mm below the plotter's origin"


@dataclass(frozen=True)
class HpglSummary:
    """What :func:`write_hpgl` wrote: file, size, paths, the plan's motion statistics."""

    path: str
    instructions: int
    bytes: int
    paths: int
    stats: PlanStats
    placement: Placement


def write_hpgl(plan: Plan, profile: Profile, path: str | Path) -> HpglSummary:
    """Write ``plan`` as HP-GL for ``profile`` to ``path`` (atomically).

    Raises
    ------
    OutOfBedError
        A coordinate falls outside the plotter's limits; nothing is written.
    PencilbotError
        Not an HP-GL profile, or NaN coordinates.
    """
    program, placement = _program(plan, profile)
    target = Path(path)
    write_atomic(target, program)
    return HpglSummary(
        str(target), program.count(b";"), len(program), len(plan.paths()), estimate(plan, profile), placement
    )


def hpgl_program(plan: Plan, profile: Profile) -> bytes:
    """The HP-GL :func:`write_hpgl` would write, as bytes."""
    return _program(plan, profile)[0]


def _program(plan: Plan, profile: Profile) -> tuple[bytes, Placement]:
    if profile.firmware.program_language != HPGL.program_language:
        raise PencilbotError(
            f"profile {profile.name} is for {profile.firmware.title}, not an HP-GL plotter; "
            "give an HP-GL profile (e.g. --profile hp7475a) or write .gcode"
        )
    pens = plan.pens  # more than the carousel holds: SP 7, 8, ... (draw pauses for each)
    placement = SheetPlacement.of(plan.page, profile)
    unit = profile.paper.unit_mm
    out = [b"IN;\n", f"VS{profile.motion.draw_feed / 600:g};\n".encode()]
    for pen, layers in plan.pen_runs():
        slot = pens.index(pen) + 1 if pen in pens else 1
        points = [layer.paths for layer in layers if len(layer.paths)]
        if not points:
            continue
        out.append(b"SP%d;\n" % slot)
        for paths in points:
            if not np.isfinite(paths.points).all():
                raise PencilbotError(
                    "the plan has coordinates that are not numbers (NaN or infinity); "
                    "make the plan again from the picture"
                )
            on_machine = placement.to_machine(paths.points)
            _check_bed(on_machine, placement, profile)
            units = np.rint(on_machine / unit).astype(np.int64)
            out.append(_paths_text(units, paths.offsets))
    out.append(b"PU0,0;\nSP0;\n")
    return b"".join(out), placement


def _paths_text(units: np.ndarray, offsets: np.ndarray) -> bytes:
    """``PU x,y;`` then ``PD x,y;`` per point of each path; repeated points dropped."""
    lines = []
    for start, end in zip(offsets[:-1], offsets[1:]):
        xy = units[start:end]
        keep = np.ones(len(xy), bool)
        keep[1:] = np.any(xy[1:] != xy[:-1], axis=1)
        xy = xy[keep].tolist()
        lines.append(f"PU{xy[0][0]},{xy[0][1]};\n")
        lines.append("".join(f"PD{x},{y};\n" for x, y in xy[1:]) if len(xy) > 1 else "PD;\nPU;\n")
    return "".join(lines).encode("ascii")


def _check_bed(on_machine: np.ndarray, placement: Placement, profile: Profile) -> None:
    if not len(on_machine) or not profile.bed.outside(on_machine).any():
        return
    low, high = on_machine.min(axis=0), on_machine.max(axis=0)
    (x0, x1), (y0, y1) = placement.machine_range()
    raise OutOfBedError(
        f"the drawing does not fit the limits of plotter profile {profile.name}: it spans X {low[0]:g} .. "
        f"{high[0]:g} and Y {low[1]:g} .. {high[1]:g} mm, the plotter allows X {x0:g} .. {x1:g} and "
        f"Y {y0:g} .. {y1:g} mm; use a smaller page or a profile with a larger sheet"
    )


def hpgl_plan(path: Path, profile: Profile) -> Plan:
    """What the HP-GL file ``path`` draws (ours, vpype's, another tool's), as a plan on a page
    the size of the bed: one layer per carousel pen, in the order the pens come.

    Raises
    ------
    PencilbotError
        The file cannot be read, is not HP-GL this reader knows, or draws nothing.
    """
    try:
        data = read_bounded(path, "HP-GL file", MAX_HPGL_FILE)
    except OSError as exc:
        raise PencilbotError(f"cannot read HP-GL file {path} ({exc.strerror or exc})") from None
    try:
        program = HPGL.program(data)
    except ValueError as exc:
        raise PencilbotError(f"{path}: {exc}") from None
    drawn, pens = program.drawn()
    if not len(drawn):
        raise PencilbotError(f"{path}: the pen never goes down (no PD move); is it an HP-GL drawing?")
    bed = Page(profile.bed.width, profile.bed.height, margin=0.0, name="bed")
    placement = Placement.on_bed(bed, profile.bed)
    mm = drawn.with_points(placement.to_page(drawn.points * profile.paper.unit_mm))
    layers = []
    change = np.flatnonzero(np.diff(pens, prepend=-1) != 0).tolist() + [len(pens)]
    for a, b in zip(change[:-1], change[1:]):
        layers.append(Layer(f"{path.stem} pen {pens[a]}", mm[a:b]))
    return Plan(bed, tuple(layers))
