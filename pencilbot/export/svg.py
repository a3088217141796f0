"""Plans as SVG: physical size in mm, one Inkscape layer per plan layer, and reading them back.

The file is what vpype, Inkscape, saxi and AxiDraw expect of a plotter drawing: ``width`` and
``height`` in mm with a matching ``viewBox`` (1 user unit = 1 mm), each layer a top-level
``<g inkscape:groupmode="layer" inkscape:label=NAME id="layerN">`` whose stroke width is the pen
width (its ``pencilbot:role`` says what it draws), each path a ``<path d="M … L …">`` of straight
segments. SVG's Y axis points down, the plan's up: the flip ``y_svg = page height − y`` happens here, on the way out and on the way in.
Page name, margin and the plan's ``meta`` ride along in a ``pencilbot`` namespace that other
tools ignore.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET

import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.fileio import write_atomic
from pencilbot.paths import DEFAULT_PEN_WIDTH, Paths
from pencilbot.planning.plan import ROLES, Layer, Page, Plan
from pencilbot.units import MM_PER_INCH

SVG_NS = "http://www.w3.org/2000/svg"
INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"
PENCILBOT_NS = "https://pencilbot.invalid/plan"  # a name only; never fetched
DECIMALS = 3  # µm: far below any pen's width
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_PATH_TOKEN = re.compile(r"[A-Za-z]|" + _NUMBER.pattern)


def write_svg(plan: Plan, path: str | os.PathLike) -> None:
    """Write ``plan`` as an SVG file at ``path`` (atomically: temporary file, then rename)."""
    write_atomic(path, svg_text(plan).encode("utf-8"))


def svg_text(plan: Plan) -> str:
    """The SVG document for ``plan`` as a string."""
    page = plan.page
    w, h = _fmt(page.width), _fmt(page.height)
    out = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<svg xmlns="{SVG_NS}" xmlns:inkscape="{INKSCAPE_NS}" xmlns:pencilbot="{PENCILBOT_NS}"'
        f' width="{w}mm" height="{h}mm" viewBox="0 0 {w} {h}"'
        f' pencilbot:page="{_escape(page.name)}" pencilbot:margin="{_fmt(page.margin)}">',
        "<metadata>",
        *(f'<pencilbot:meta name="{_escape(k)}">{_escape(v)}</pencilbot:meta>' for k, v in plan.meta.items()),
        "</metadata>",
    ]
    for number, layer in enumerate(plan.layers, start=1):
        out.append(
            f'<g inkscape:groupmode="layer" inkscape:label="{_escape(layer.name)}" id="layer{number}"'
            f' pencilbot:role="{layer.role}" fill="none" stroke="black" stroke-width="{_fmt(layer.pen_width)}"'
            ' stroke-linecap="round" stroke-linejoin="round">'
        )
        out.extend(f'<path d="{d}"/>' for d in _path_data(layer.paths, page.height))
        out.append("</g>")
    out.append("</svg>\n")
    return "\n".join(out)


def read_svg(path: str | os.PathLike) -> Plan:
    """Read a plan SVG (as written by :func:`write_svg`) back into a :class:`Plan`.

    Straight-line SVGs from other tools load too when their size is in mm (or has a viewBox)
    and their drawing is in ``path`` (M/L/H/V/Z), ``polyline``, ``polygon`` or ``line`` elements;
    top-level groups become layers. Curves and ``transform`` attributes are refused with a hint
    to flatten them first.
    """
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError:
        raise PencilbotError(f"plan file {path} does not exist; check the path") from None
    except (ET.ParseError, OSError) as exc:
        raise PencilbotError(f"cannot read {path} as SVG ({exc}); is it a plan written by pencilbot?") from None
    if root.tag != f"{{{SVG_NS}}}svg":
        raise PencilbotError(f"{path} is not an SVG file (root element {root.tag!r})")
    width, height, scale = _page_size(root, path)
    moved = next((el for el in root.iter() if el.get("transform")), None)
    if moved is not None:
        # Coordinates under a transform are not where they read; drawing them as read would put
        # the pen somewhere else on the paper without a word.
        raise PencilbotError(
            f"{path}: <{moved.tag.rsplit('}', 1)[-1]}> has transform={moved.get('transform')!r}, "
            "which is not applied; bake transforms into the coordinates first (e.g. vpype read … write)"
        )
    margin = root.get(f"{{{PENCILBOT_NS}}}margin", "0")
    if not re.fullmatch(_NUMBER.pattern, margin.strip()):
        raise PencilbotError(f"{path}: pencilbot:margin {margin!r} is not a number of mm; fix or remove it")
    page = Page(
        width=width,
        height=height,
        margin=float(margin),
        name=root.get(f"{{{PENCILBOT_NS}}}page", "custom"),
    )
    meta = {m.get("name", ""): m.text or "" for m in root.iter(f"{{{PENCILBOT_NS}}}meta")}
    layers = []
    loose = []  # drawing outside any group: one extra layer
    for child in root:
        if child.tag == f"{{{SVG_NS}}}g":
            name = child.get(f"{{{INKSCAPE_NS}}}label") or child.get("id") or f"layer{len(layers) + 1}"
            stroke = _NUMBER.match(_stroke_width(child) or "")
            pen = float(stroke[0]) * scale if stroke else DEFAULT_PEN_WIDTH
            role = child.get(f"{{{PENCILBOT_NS}}}role")
            paths = [p for el in child.iter() for p in _element_paths(el, path)]
            layers.append(Layer(name, [_to_page(p, scale, height) for p in paths], pen_width=pen,
                                role=role if role in ROLES else "other"))
        else:
            loose.extend(_element_paths(child, path))
    if loose:
        layers.append(Layer("default", [_to_page(p, scale, height) for p in loose]))
    return Plan(page=page, layers=layers, meta=meta)


def _path_data(paths: Paths, page_height: float) -> list[str]:
    """``M x y L x y …`` strings with Y flipped to SVG's downward axis."""
    lengths = paths.lengths.tolist()
    pts = paths.points
    xs = [_fmt(v) for v in pts[:, 0].tolist()]
    ys = [_fmt(v) for v in (page_height - pts[:, 1]).tolist()]
    coords = [f"{x} {y}" for x, y in zip(xs, ys)]
    out, at = [], 0
    for n in lengths:
        if n == 1:  # a dot: a zero-length segment, which round caps draw as a disc
            out.append(f"M {coords[at]} L {coords[at]}")
        else:
            out.append(f"M {coords[at]} L " + " ".join(coords[at + 1 : at + n]))
        at += n
    return out


def _fmt(value: float) -> str:
    text = f"{value:.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _escape(text: str) -> str:
    return (
        str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")
    )


def _page_size(root: ET.Element, path) -> tuple[float, float, float]:
    """Page width and height in mm, and mm per user unit."""
    units_to_mm = {"mm": 1.0, "cm": 10.0, "in": MM_PER_INCH, "pt": MM_PER_INCH / 72, "px": MM_PER_INCH / 96,
                   "": MM_PER_INCH / 96}
    sizes = []
    for attr in ("width", "height"):
        match = re.fullmatch(rf"\s*({_NUMBER.pattern})\s*([a-z]*)\s*", root.get(attr, ""))
        if not match or match[2] not in units_to_mm or not 0 < float(match[1]) < float("inf"):
            raise PencilbotError(
                f"{path}: the SVG's {attr} {root.get(attr)!r} has no physical size; "
                "give width and height in mm"
            )
        sizes.append(float(match[1]) * units_to_mm[match[2]])
    view = [float(v) for v in _NUMBER.findall(root.get("viewBox", ""))]
    scale = sizes[0] / view[2] if len(view) == 4 and view[2] > 0 else units_to_mm[match[2]]
    if len(view) == 4 and (view[0], view[1]) != (0.0, 0.0):
        raise PencilbotError(f"{path}: viewBox must start at 0 0 (found {view[0]:g} {view[1]:g})")
    return sizes[0], sizes[1], scale


def _stroke_width(el: ET.Element) -> str | None:
    style = dict(
        part.split(":", 1) for part in el.get("style", "").split(";") if ":" in part
    )
    value = el.get("stroke-width") or style.get("stroke-width")
    return value.strip() if value else None


def _element_paths(el: ET.Element, path) -> list[np.ndarray]:
    """Polylines (user units, SVG Y down) of one drawing element; other elements give none."""
    tag = el.tag.rsplit("}", 1)[-1]
    if tag == "path":
        return _parse_d(el.get("d", ""), path)
    if tag in ("polyline", "polygon"):
        pts = np.array([float(v) for v in _NUMBER.findall(el.get("points", ""))]).reshape(-1, 2)
        if tag == "polygon" and len(pts):
            pts = np.vstack([pts, pts[:1]])
        return [pts] if len(pts) else []
    if tag == "line":
        get = lambda k: float(el.get(k, 0))  # noqa: E731
        return [np.array([[get("x1"), get("y1")], [get("x2"), get("y2")]])]
    if tag in ("circle", "ellipse", "rect", "text"):
        raise PencilbotError(
            f"{path}: <{tag}> shapes are not read; convert them to paths first "
            "(e.g. Inkscape: Path ▸ Object to Path, or vpype read … write)"
        )
    return []


def _parse_d(d: str, path) -> list[np.ndarray]:
    """Straight-line path data: M, L, H, V, Z and their relative forms."""
    try:
        return _parse_tokens(_PATH_TOKEN.findall(d), path)
    except (IndexError, ValueError):
        raise PencilbotError(f"{path}: malformed path data {d[:60]!r}") from None


def _parse_tokens(tokens: list[str], path) -> list[np.ndarray]:
    """Polylines from path-data tokens (letters and numbers)."""
    paths, current, pos, start = [], [], np.zeros(2), np.zeros(2)
    command, i = None, 0
    while i < len(tokens):
        if tokens[i].isalpha():
            command = tokens[i]
            i += 1
            if command in "Zz":
                if current:
                    current.append(start.copy())
                    pos = start.copy()
                continue
        if command is None or command not in "MmLlHhVv":
            raise PencilbotError(
                f"{path}: path command {command!r} (curves or arcs) is not read; "
                "flatten curves to lines first (e.g. vpype read … linesimplify write)"
            )
        relative = command.islower()
        if command in "Hh":
            pos = np.array([float(tokens[i]) + (pos[0] if relative else 0.0), pos[1]])
            i += 1
        elif command in "Vv":
            pos = np.array([pos[0], float(tokens[i]) + (pos[1] if relative else 0.0)])
            i += 1
        else:
            point = np.array([float(tokens[i]), float(tokens[i + 1])])
            pos = point + pos if relative else point
            i += 2
        if command in "Mm":
            if len(current) > 0:
                paths.append(np.array(current))
            current, start = [pos.copy()], pos.copy()
            command = "l" if relative else "L"  # later pairs after M are line-tos
        else:
            current.append(pos.copy())
    if current:
        paths.append(np.array(current))
    return paths


def _to_page(pts: np.ndarray, scale: float, page_height: float) -> np.ndarray:
    """User units, Y down → page mm, Y up; a zero-length segment written for a dot reads back as one point."""
    mm = np.column_stack([pts[:, 0] * scale, page_height - pts[:, 1] * scale])
    if len(mm) == 2 and np.array_equal(mm[0], mm[1]):
        return mm[:1]
    return mm
