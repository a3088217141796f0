"""The plan: what the plotter will draw, as data.

A :class:`Plan` is a page plus an ordered tuple of :class:`Layer`. A layer is one pen pass:
:class:`~pencilbot.paths.Paths` in **millimetres on the page**, with the origin at the page's
bottom-left corner and Y growing upward (the plotter convention; the flip from image rows is
done once, in :mod:`pencilbot.planning.layout`), a pen width, and a role saying what the layer
draws. Paths are drawn in order, pen down along each path, pen up between paths. Plans and
layers are frozen values: a step that changes a plan makes a new one.

The plan knows nothing of G-code or the simulator: :func:`pencilbot.export_gcode` and
:func:`pencilbot.write_svg` turn it into files.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from pencilbot.paths import Paths
from pencilbot.units import DEFAULT_PEN_WIDTH

#: Blank border on every side of a page, mm, when nothing says otherwise (the default style's).
DEFAULT_MARGIN = 15.0

#: What a layer draws: ``hatch`` is tone (hatching), ``edges`` the line drawing, ``other``
#: anything else (a layer read from another tool's SVG).
ROLES = ("hatch", "edges", "other")
#: The ink of a layer that names no colour.
BLACK = "#000000"


@dataclass(frozen=True)
class Page:
    """A sheet of paper: size in mm (as placed on the plotter) and margins in mm."""

    width: float
    height: float
    margin: float = DEFAULT_MARGIN
    name: str = "custom"


@dataclass(frozen=True)
class Layer:
    """One pen pass of the drawing, e.g. ``Layer("hatch1-45", paths, role="hatch")``.

    ``paths`` may be given as any iterable of ``(k, 2)`` arrays; it is stored as
    :class:`~pencilbot.paths.Paths` (paths without points dropped). ``pen`` names the pen a
    colour plan draws the layer with (``""``: the plotter's one pen) and ``color`` is its ink,
    sRGB ``#rrggbb``.
    """

    name: str
    paths: Paths = field(default_factory=Paths.empty)
    pen_width: float = DEFAULT_PEN_WIDTH  # mm
    role: str = "other"
    pen: str = ""
    color: str = BLACK

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise ValueError(f"layer role {self.role!r} is not one of {', '.join(ROLES)}")
        object.__setattr__(self, "paths", Paths.of(self.paths))


@dataclass(frozen=True)
class Plan:
    """A page and its layers, in drawing order; ``meta`` holds free-form provenance strings."""

    page: Page
    layers: tuple[Layer, ...] = ()
    meta: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "layers", tuple(self.layers))
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))

    def __reduce__(self):  # a mapping proxy does not pickle; the plan does (worker processes)
        return Plan, (self.page, self.layers, dict(self.meta))

    def paths(self, role: str | None = None) -> Paths:
        """Every path in drawing order, or those of the layers with ``role``."""
        return Paths.concat(layer.paths for layer in self.layers if role in (None, layer.role))

    def layer(self, name: str) -> Layer:
        """The first layer called ``name`` (``KeyError`` if there is none)."""
        for layer in self.layers:
            if layer.name == name:
                return layer
        raise KeyError(name)

    def pen_runs(self) -> list[tuple[str, tuple[Layer, ...]]]:
        """The layers grouped by pen, in drawing order: ``(pen name, layers)`` for each run of
        consecutive layers that one pen draws (one run, pen ``""``, for a one-pen plan)."""
        runs: list[tuple[str, list[Layer]]] = []
        for layer in self.layers:
            if runs and runs[-1][0] == layer.pen:
                runs[-1][1].append(layer)
            else:
                runs.append((layer.pen, [layer]))
        return [(pen, tuple(layers)) for pen, layers in runs]

    @property
    def pens(self) -> tuple[str, ...]:
        """The pens a plotter is loaded with, in order (empty for a plan of the one pen)."""
        return tuple(pen for pen, _ in self.pen_runs() if pen)

    @property
    def pen_width(self) -> float:
        """The pen a plotter draws this plan with (it holds one): the widest layer's, mm."""
        return max((layer.pen_width for layer in self.layers), default=DEFAULT_PEN_WIDTH)
