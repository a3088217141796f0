"""Another tool's SVG of straight lines only, read in whole arrays (no per-segment objects).

vpype's reader (svgelements) makes Python objects for every segment: about 25 µs and a
kilobyte each, so a 50 MB drawing of one path (3 million segments) took over 300 s. Most plotter
SVGs are nothing but straight polylines (``<path d="M … L …">``, ``<polyline>``, ``<polygon>``,
``<line>``) in groups without transforms; those are read here in numpy, the same lines vpype would
give (a path's repeated points dropped, a polyline's kept, a line of fewer than two points
dropped, ``Z`` and a polygon closing back to their start). Anything else in the file (a curve, a transform, a ``<use>``, a ``<style>``, text,
a viewBox that does not scale evenly) returns None, and the file is read by vpype as before.
"""

from __future__ import annotations

import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np

from pencilbot.export.svg_checks import local_name

# Elements a straight drawing may hold besides groups (and what draws nothing).
_SHAPES = {"path", "polyline", "polygon", "line"}
_QUIET = {"defs", "metadata", "title", "desc", "namedview"}
# Attributes or style properties that move, hide or restyle geometry: vpype's business.
_MOVING = ("transform", "clip-path", "mask", "filter", "display", "visibility")
_STRAIGHT_D = re.compile(r"[\sMmLlHhVvZz0-9eE.,+-]*")
_COMMANDS = b"MmLlHhVvZz"
# A command letter becomes a number no coordinate may be (svg_checks refuses numbers past 1e9):
# 1e300 + its place in _COMMANDS.
_SENTINEL = 1e300
_CMD_TEXT = {letter: f" {(_SENTINEL * (1 + i)):.0e} ".encode() for i, letter in enumerate(_COMMANDS)}
_TRANSLATE = bytes(c if c not in b",\t\r\n" else 32 for c in range(256))
_STROKE_WIDTH = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?:px)?\s*")


def read_straight(root: ET.Element, tops: list[ET.Element], loose: list[ET.Element]):
    """The lines of each layer of a straight-line SVG in user units, or None if it is not one.

    Parameters
    ----------
    root : Element
        The ``<svg>`` (its ``viewBox`` origin is taken off: coordinates start at the page corner).
    tops : list of Element
        Its drawn top-level elements in order; ``loose`` those of them that are no group.

    Returns
    -------
    list of (place, points, offsets, stroke) or None
        ``place`` as :func:`~pencilbot.export.svg_read._read_any` numbers layers (a group's place
        from 2, the loose shapes 1), ``points`` ``(N, 2)`` user units (Y down), ``offsets`` the
        paths' starts, ``stroke`` the stroke width (user units) every shape of the layer has, or
        None when they differ.
    """
    if _moves(root) or not _even_view(root) or any(local_name(el.tag) == "style" for el in root.iter()):
        return None
    origin = _view_origin(root)
    found: dict[int, list] = {}
    for place, top in enumerate(tops, start=2):
        key = 1 if top in loose else place
        shapes = found.setdefault(key, [])
        stack = [(top, _stroke(root, None))]
        while stack:
            element, inherited = stack.pop()
            name = local_name(element.tag)
            if name in _QUIET:
                continue
            if _moves(element):
                return None
            stroke = _stroke(element, inherited)
            if name == "g":
                stack.extend((child, stroke) for child in reversed(element))
                continue
            if name not in _SHAPES or len(element):
                return None
            lines = _shape_lines(element, name)
            if lines is None:
                return None
            if stroke is False:
                return None
            shapes.append((lines, stroke))
    layers = []
    for place in sorted(found, key=lambda lid: (lid == 1, lid)):
        shapes = found[place]
        pieces = [lines for lines, _ in shapes if len(lines[1]) > 1]
        if not pieces:
            continue
        points = np.concatenate([p for p, _ in pieces]) - origin
        lengths = np.concatenate([np.diff(o) for _, o in pieces])
        offsets = np.concatenate([[0], np.cumsum(lengths)])
        widths = {stroke for _, stroke in shapes}
        layers.append((place, points, offsets, widths.pop() if len(widths) == 1 else None))
    return layers


def _shape_lines(element: ET.Element, name: str):
    """``(points, offsets)`` of one shape's lines, or None when it is not straight."""
    if name == "path":
        return _path_lines(element.get("d", ""))
    if name == "line":
        try:
            points = np.array([[float(element.get(k, "0")) for k in ("x1", "y1")],
                               [float(element.get(k, "0")) for k in ("x2", "y2")]])
        except ValueError:
            return None
        return _tidy(points, np.array([0, 2]))
    values = _numbers(element.get("points", "").encode())
    if values is None or len(values) % 2:
        return None
    points = values.reshape(-1, 2)
    # vpype keeps a polyline's points as they are (a repeated one too); a polygon closes unless
    # its last point is its first.
    if name == "polygon" and len(points) and not (points[-1] == points[0]).all():
        points = np.vstack([points, points[:1]])
    return (points, np.array([0, len(points)])) if len(points) >= 2 else (points.reshape(-1, 2)[:0], np.zeros(1, np.int64))


def _path_lines(d: str):
    """A path's lines from ``M L H V Z`` commands (either case) in whole arrays; None for
    anything else (curves, arcs), or relative moves after a ``Z``."""
    if not _STRAIGHT_D.fullmatch(d):
        return None
    text = d.encode("ascii")
    if not text.strip():
        return np.zeros((0, 2)), np.zeros(1, np.int64)
    for letter, number in _CMD_TEXT.items():
        text = text.replace(bytes([letter]), number)
    if b"-" in text:
        text = re.sub(rb"(?<=[\d.])-", b" -", text)  # "1-2" is two numbers
    values = _numbers(text)
    if values is None:
        return None
    is_cmd = values >= _SENTINEL
    if not len(values) or not is_cmd[0]:
        return None
    codes = np.rint(values[is_cmd] / _SENTINEL).astype(np.int64) - 1  # index into _COMMANDS
    letters = np.frombuffer(_COMMANDS, np.uint8)[codes]
    starts = np.flatnonzero(is_cmd)
    counts = np.diff(np.append(starts, len(values))) - 1
    pair = np.isin(letters, np.frombuffer(b"MmLl", np.uint8))
    single = np.isin(letters, np.frombuffer(b"HhVv", np.uint8))
    close = ~pair & ~single
    relative = letters >= ord("a")
    if (pair & ((counts < 2) | (counts % 2 == 1))).any() or (single & (counts < 1)).any() or (close & (counts > 0)).any():
        return None
    if (close.any() and relative.any()) or letters[0] & ~np.uint8(32) != ord("M"):
        return None  # relative moves after a Z start from the subpath's start: vpype's business
    # One entry per point: where it sits among the values, and its command.
    seg = np.cumsum(is_cmd) - 1
    offset = np.arange(len(values)) - starts[seg] - 1
    at_point = (~is_cmd & pair[seg] & (offset % 2 == 0)) | (~is_cmd & single[seg]) | (is_cmd & close[seg])
    where = np.flatnonzero(at_point)
    command = letters[seg[where]]
    upper = command & ~np.uint8(32)
    moves = (upper == ord("M")) & (offset[where] == 0)
    rel = command >= ord("a")
    nxt = np.minimum(where + 1, len(values) - 1)
    x_given = (upper == ord("M")) | (upper == ord("L")) | (upper == ord("H"))
    y_given = (upper == ord("M")) | (upper == ord("L")) | (upper == ord("V"))
    x_value = values[where]
    y_value = np.where(upper == ord("V"), values[where], values[nxt])
    if close.any():  # all absolute here: a Z sets the point to its subpath's start
        start_of = np.maximum.accumulate(np.where(moves, np.arange(len(where)), 0))
        is_z = upper == ord("Z")
        x_value = np.where(is_z, x_value[start_of], x_value)
        y_value = np.where(is_z, y_value[start_of], y_value)
        x_given, y_given = x_given | is_z, y_given | is_z
    xs = _follow(x_value, x_given & ~rel, np.where(x_given & rel, x_value, 0.0))
    ys = _follow(y_value, y_given & ~rel, np.where(y_given & rel, y_value, 0.0))
    points = np.column_stack([xs, ys])
    return _tidy(points, np.append(np.flatnonzero(moves), len(points)))


def _follow(value: np.ndarray, absolute: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """A coordinate along a path: set where ``absolute``, else the last one plus ``delta``
    (a running sum restarted at each absolute value), from 0."""
    index = np.arange(len(value))
    last = np.maximum.accumulate(np.where(absolute, index, -1))
    total = np.cumsum(delta)
    base = np.where(last >= 0, value[np.maximum(last, 0)], 0.0)
    return base + total - np.where(last >= 0, total[np.maximum(last, 0)], 0.0)


def _tidy(points: np.ndarray, offsets: np.ndarray):
    """vpype's lines: a point equal to the one before it dropped, paths of fewer than two gone."""
    if not len(points):
        return points.reshape(0, 2), np.zeros(1, np.int64)
    path_of = np.repeat(np.arange(len(offsets) - 1), np.diff(offsets))
    same = np.zeros(len(points), bool)
    same[1:] = (points[1:] == points[:-1]).all(axis=1) & (path_of[1:] == path_of[:-1])
    points, path_of = points[~same], path_of[~same]
    counts = np.bincount(path_of, minlength=len(offsets) - 1)
    keep = np.repeat(counts >= 2, counts)
    counts = counts[counts >= 2]
    return points[keep], np.concatenate([[0], np.cumsum(counts)])


def _numbers(text: bytes) -> np.ndarray | None:
    """Every number of ``text`` (separated by spaces or commas), or None if it holds anything
    else (``1+2``, ``0.5.5``: vpype reads those)."""
    text = text.translate(_TRANSLATE)
    a = np.frombuffer(text, np.uint8)
    if not len(a):
        return np.zeros(0)
    filled = a != 32
    expected = int(filled[0]) + int(np.count_nonzero(filled[1:] & ~filled[:-1]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a malformed number ends the parse early: counted below
        try:
            values = np.fromstring(text, dtype=np.float64, sep=" ")  # C speed, one pass
        except ValueError:
            return None
    return values if len(values) == expected else None


def _even_view(root: ET.Element) -> bool:
    """Whether user units map to the page by one scale for both axes (vpype's default
    ``preserveAspectRatio`` then adds no offset)."""
    view = root.get("viewBox")
    if view is None:
        return True
    try:
        _, _, vw, vh = (float(v) for v in view.replace(",", " ").split())
        width, height = (_leading_number(root.get(k, "")) for k in ("width", "height"))
    except ValueError:
        return False
    return vw > 0 and vh > 0 and abs(width / vw - height / vh) <= 1e-9 * width / vw


def _view_origin(root: ET.Element) -> np.ndarray:
    view = root.get("viewBox")
    return np.array([float(v) for v in view.replace(",", " ").split()[:2]]) if view else np.zeros(2)


def _moves(element: ET.Element) -> bool:
    """Whether ``element`` transforms, clips, filters or hides what it holds (``display:inline``,
    which vpype and Inkscape write on every layer, does not)."""
    style = {k.strip(): v.strip() for k, _, v in (part.partition(":") for part in element.get("style", "").split(";"))}
    for name in _MOVING:
        value = element.get(name, style.get(name))
        if value is not None and (name, value) not in (("display", "inline"), ("visibility", "visible")):
            return True
    return False


def _stroke(element: ET.Element, inherited):
    """The stroke width (user units) ``element`` draws with: its own, else its group's (svgelements'
    default: 1); ``False`` for one given in another unit (not read here)."""
    style = {k.strip(): v for k, _, v in (part.partition(":") for part in element.get("style", "").split(";"))}
    given = style.get("stroke-width") or element.get("stroke-width")
    if given is None:
        return 1.0 if inherited is None else inherited
    match = _STROKE_WIDTH.fullmatch(given)
    return float(match[1]) if match else False


def _leading_number(text: str) -> float:
    """The number ``text`` starts with (``"210mm"``: 210); ValueError if it starts with none."""
    match = re.match(r"\s*([-+]?[\d.]+(?:[eE][-+]?\d+)?)", text)
    if match is None:
        raise ValueError(f"no number at the start of {text!r}")
    return float(match[1])
