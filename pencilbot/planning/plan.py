"""The plan: what the plotter will draw, as data.

A :class:`Plan` is a page plus an ordered list of :class:`Layer`. A layer is an ordered list of
paths; each path is a float64 ``(N, 2)`` array of points in **millimetres on the page**, with the
origin at the page's bottom-left corner and Y growing upward (the plotter convention; the flip
from image rows is done once, in :mod:`pencilbot.planning.layout`). Paths are drawn in list order,
pen down along each path, pen up between paths. No per-stroke objects: 100 000 strokes stay cheap.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Page:
    """A sheet of paper: size in mm (as placed on the plotter) and margins in mm."""

    width: float
    height: float
    margin: float = 15.0
    name: str = "custom"


@dataclass
class Layer:
    """One pen pass of the drawing: e.g. ``"edges"`` or ``"hatch-45"``."""

    name: str
    paths: list[np.ndarray] = field(default_factory=list)
    pen_width: float = 0.5  # mm

    def __post_init__(self) -> None:
        self.paths = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in self.paths]


@dataclass
class Plan:
    """A page and its layers, in drawing order; ``meta`` holds free-form provenance strings."""

    page: Page
    layers: list[Layer] = field(default_factory=list)
    meta: dict[str, str] = field(default_factory=dict)

    def all_paths(self) -> list[np.ndarray]:
        """Every path of every layer, in drawing order."""
        return [p for layer in self.layers for p in layer.paths]

    def to_gcode(self, profile="grbl-servo-a4", path=None, *, source: str = ""):
        """G-code for a plotter profile (a name, a TOML path or a loaded ``Profile``).

        With ``path``, writes the file atomically and returns its
        :class:`~pencilbot.gcode.writer.GcodeSummary`; without, returns the lines.
        """
        from pencilbot.gcode.profiles import Profile, load_profile
        from pencilbot.gcode.writer import gcode_lines, write_gcode

        profile = profile if isinstance(profile, Profile) else load_profile(profile)
        if path is None:
            return gcode_lines(self, profile, source=source)
        return write_gcode(self, profile, path, source=source)

    def layer(self, name: str) -> Layer:
        for layer in self.layers:
            if layer.name == name:
                return layer
        raise KeyError(name)
