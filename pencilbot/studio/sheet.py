"""The drawing on its sheet, for the page's workspace: the plan's paths by layer, the drawing
moved and scaled where the person put it (:class:`Placement`), the layers they skip, and a
plot's drawn paths in page millimetres with each path's pen colour.

Everything is page mm, origin bottom-left, Y up (as :class:`~pencilbot.planning.plan.Plan`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from pencilbot.errors import PencilbotError

#: The smallest and largest scale of the drawing on its sheet.
SCALES = (0.05, 4.0)
#: How far (mm) the drawing may be moved from its place: past the largest sheet it is off it.
MAX_SHIFT = 1200.0
_PAGE_LINE = re.compile(rb"(?m)^; page: \S+ ([0-9.]+) x ([0-9.]+) mm on a ")
_PEN_NOTE = re.compile(rb"(?m)^; pen change \d+ of \d+: .*? (#[0-9a-f]{6}) [0-9.]+ mm\r?$")


@dataclass(frozen=True)
class Placement:
    """Where the person put the drawing: ``scale`` about the centre of the sheet's drawing
    area, then moved by ``dx``, ``dy`` mm; ``skip`` names layers that are shown but not plotted."""

    scale: float = 1.0
    dx: float = 0.0
    dy: float = 0.0
    skip: tuple[str, ...] = ()

    def summary(self) -> dict:
        return {"scale": self.scale, "dx": self.dx, "dy": self.dy, "skip": list(self.skip)}


def parse_placement(body: dict, before: Placement) -> Placement:
    """The placement a request asks for (absent keys keep ``before``'s), every value checked."""
    values: dict[str, object] = {}
    for key, (low, high) in (
        ("scale", SCALES),
        ("dx", (-MAX_SHIFT, MAX_SHIFT)),
        ("dy", (-MAX_SHIFT, MAX_SHIFT)),
    ):
        if key not in body:
            continue
        value = body[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise PencilbotError(f"{key} must be a number, not {value!r}")
        if not low <= value <= high:
            raise PencilbotError(f"{key} {value:g} is outside {low:g} … {high:g}")
        values[key] = float(value)
    if "skip" in body:
        skip = body["skip"]
        if not isinstance(skip, list) or not all(isinstance(s, str) and len(s) < 200 for s in skip):
            raise PencilbotError("skip must be a list of layer names")
        values["skip"] = tuple(dict.fromkeys(skip))[:1000]
    return replace(before, **values)  # type: ignore[arg-type]


def placed(plan, where: Placement):
    """``plan`` as it goes to the plotter: scaled and moved as ``where`` says, skipped layers left out.

    Raises
    ------
    PencilbotError
        Every layer skipped: nothing would be drawn.
    """
    page = plan.page
    centre = np.array([page.width / 2, page.height / 2])
    shift = centre * (1 - where.scale) + (where.dx, where.dy)
    layers = tuple(
        replace(layer, paths=layer.paths.with_points(layer.paths.points * where.scale + shift))
        if (where.scale, where.dx, where.dy) != (1.0, 0.0, 0.0)
        else layer
        for layer in plan.layers
        if layer.name not in where.skip
    )
    if plan.layers and not layers:
        raise PencilbotError("every layer is set to skip: tick Plot for at least one")
    return replace(plan, layers=layers)


def plan_json(plan, generation: int) -> dict:
    """The plan's layers for the page to draw (2 decimals: a hundredth of a mm)."""
    return {
        "generation": generation,
        "page": {"width": plan.page.width, "height": plan.page.height, "margin": plan.page.margin},
        "layers": [
            {
                "name": layer.name,
                "pen": layer.pen,
                "color": layer.color,
                "width": layer.pen_width,
                "points": np.round(layer.paths.points, 2).ravel().tolist(),
                "offsets": layer.paths.offsets.tolist(),
            }
            for layer in plan.layers
        ],
    }


def plot_json(gcode: Path, profile: str) -> dict:
    """A plot's pen-down paths on its sheet: page mm, the file line reaching each point, and
    each path's pen colour (the pen-change notes of the G-code; black without them)."""
    from pencilbot.driver.gcode.drawn import drawn_with_lines
    from pencilbot.driver.gcode.job import load_job
    from pencilbot.machine.bed import Placement as OnBed
    from pencilbot.machine.profile import load_profile
    from pencilbot.planning.plan import Page

    plotter = load_profile(profile)
    head = gcode.read_bytes()
    size = _PAGE_LINE.search(head[:4096])
    if size is None:
        raise PencilbotError("this plot's G-code does not say its page; it cannot be shown on the sheet")
    page = Page(float(size[1]), float(size[2]))
    job = load_job(gcode, plotter)
    paths, indices = drawn_with_lines(job)
    points = OnBed.on_bed(page, plotter.bed).to_page(paths.points) if len(paths.points) else np.zeros((0, 2))
    lines = job.numbers[indices] if len(indices) else np.zeros(0, dtype=np.int64)
    notes = list(_PEN_NOTE.finditer(head))
    colors = ["#000000", *(m[1].decode() for m in notes)]
    note_lines = np.array([head.count(b"\n", 0, m.start()) + 1 for m in notes], dtype=np.int64)
    firsts = lines[paths.offsets[:-1]] if len(paths) else np.zeros(0, dtype=np.int64)
    pen_of = np.searchsorted(note_lines, firsts, side="right")
    return {
        "page": [page.width, page.height],
        "points": np.round(points, 2).ravel().tolist(),
        "offsets": paths.offsets.tolist(),
        "lines": lines.tolist(),
        "colors": [colors[i] for i in pen_of.tolist()],
    }
