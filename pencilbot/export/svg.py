"""Plans as SVG: physical size in mm, one Inkscape layer per plan layer.

The file is what vpype, Inkscape, saxi and AxiDraw expect of a plotter drawing: ``width`` and
``height`` in mm with a matching ``viewBox`` (1 user unit = 1 mm), each layer a top-level
``<g inkscape:groupmode="layer" inkscape:label=NAME id="layerN">`` whose stroke width is the pen
width (its ``pencilbot:role`` says what it draws), each path a ``<path d="M … L …">`` of straight
segments. SVG's Y axis points down, the plan's up: the flip ``y_svg = page height − y`` happens here
on the way out, and in :mod:`pencilbot.export.svg_read` on the way in.
Page name, margin and the plan's ``meta`` ride along in a ``pencilbot`` namespace that other
tools ignore.
"""

from __future__ import annotations

import os
import re

import numpy as np

from pencilbot.export.svg_checks import check_drawing
from pencilbot.fileio import write_atomic
from pencilbot.paths import Paths
from pencilbot.planning.plan import BLACK, Layer, Plan

SVG_NS = "http://www.w3.org/2000/svg"
INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"
PENCILBOT_NS = "https://pencilbot.invalid/plan"  # a name only; never fetched
DECIMALS = 3  # µm: far below any pen's width
_SURROGATE = re.compile("[\ud800-\udfff]")


def write_svg(plan: Plan, path: str | os.PathLike) -> None:
    """Write ``plan`` as an SVG file at ``path`` (atomically: temporary file, then rename);
    a plan with a coordinate that is not finite is refused, never written as ``L inf``."""
    for layer in plan.layers:
        check_drawing(layer.paths.points, f"layer {layer.name!r}")
    # A name from a file name that is not UTF-8 (os.fsdecode's surrogates) is shown as U+FFFD.
    write_atomic(path, _SURROGATE.sub("\ufffd", svg_text(plan)).encode("utf-8"))


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
    if plan.pens:
        number = 0
        for place, (pen, layers) in enumerate(plan.pen_runs(), start=1):
            # vpype numbers a layer by the first digits of its label and takes its colour and
            # pen width from the stroke its paths inherit: "1 yellow" is vpype's layer 1.
            out.append(
                f'<g inkscape:groupmode="layer" inkscape:label="{place} {_escape(pen)}" id="pen{place}"'
                f' pencilbot:pen="{_escape(pen)}" fill="none" stroke="{_ink(layers[0].color)}"'
                f' stroke-width="{_fmt(layers[0].pen_width)}" stroke-linecap="round" stroke-linejoin="round">'
            )
            for layer in layers:
                number += 1
                out += _layer_group(
                    layer,
                    number,
                    page.height,
                    stroke=layer.color != layers[0].color or layer.pen_width != layers[0].pen_width,
                )
            out.append("</g>")
    else:
        for number, layer in enumerate(plan.layers, start=1):
            out += _layer_group(layer, number, page.height, stroke=True)
    out.append("</svg>\n")
    return "\n".join(out)


def _layer_group(layer: Layer, number: int, page_height: float, *, stroke: bool) -> list[str]:
    """A plan layer as an Inkscape layer group (with its own stroke, or inheriting its pen's)."""
    look = (
        (
            f' fill="none" stroke="{_ink(layer.color)}" stroke-width="{_fmt(layer.pen_width)}"'
            ' stroke-linecap="round" stroke-linejoin="round"'
        )
        if stroke
        else ""
    )
    return [
        f'<g inkscape:groupmode="layer" inkscape:label="{_escape(layer.name)}" id="layer{number}"'
        f' pencilbot:role="{layer.role}"{look}>',
        *(f'<path d="{d}"/>' for d in _path_data(layer.paths, page_height)),
        "</g>",
    ]


def _ink(color: str) -> str:
    return "black" if color == BLACK else color


def _path_data(paths: Paths, page_height: float) -> list[str]:
    """``M x y L x y …`` strings with Y flipped to SVG's downward axis."""
    lengths = paths.lengths.tolist()
    pts = paths.points
    coords = _numbers_text(np.column_stack([pts[:, 0], page_height - pts[:, 1]])).split("\n")
    out, at = [], 0
    for n in lengths:
        if n == 1:  # a dot: a zero-length segment, which round caps draw as a disc
            out.append(f"M {coords[at]} L {coords[at]}")
        else:
            out.append(f"M {coords[at]} L " + " ".join(coords[at + 1 : at + n]))
        at += n
    return out


_TRAILING = re.compile(r"\.?0+(?=[ \n]|$)")  # "1.500" → "1.5", "10.000" → "10"
_MINUS_ZERO = re.compile(r"(?<![\d.])-0(?=[ \n]|$)")


def _numbers_text(xy: np.ndarray) -> str:
    """``"x y"`` lines of ``(N, 2)`` numbers, each as :func:`_fmt` writes it: formatted in one
    pass, their trailing zeros cut from the whole text by a regular expression (a million points
    in about a second, not four)."""
    if not len(xy):
        return ""
    text = "\n".join(map(f"{{:.{DECIMALS}f}} {{:.{DECIMALS}f}}".format, *xy.T.tolist()))
    return _MINUS_ZERO.sub("0", _TRAILING.sub("", text))


def _fmt(value: float) -> str:
    text = f"{value:.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _escape(text: str) -> str:
    return str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")
