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

import itertools
import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np

from pencilbot.export.svg_checks import local_name

# Elements a straight drawing may hold besides groups (and what draws nothing).
_SHAPES = {"path", "polyline", "polygon", "line"}
_QUIET = {"defs", "metadata", "title", "desc", "namedview"}
_STYLE_TAGS = ("{http://www.w3.org/2000/svg}style", "style")
# Attributes or style properties that move, hide or restyle geometry: vpype's business.
_MOVING = ("transform", "clip-path", "mask", "filter", "display", "visibility")
_MOVING_SET = frozenset(_MOVING)
_STRAIGHT_D = re.compile(r"[\sMmLlHhVvZz0-9eE.,+-]*")
_COMMANDS = b"MmLlHhVvZzX"  # X: where one path's data ends and the next one's starts
# A command letter becomes a number no coordinate may be (svg_checks refuses numbers past 1e9):
# 1e300 + its place in _COMMANDS.
_SENTINEL = 1e300
_CMD_TEXT = {letter: f" {1 + i}e300 ".encode() for i, letter in enumerate(_COMMANDS)}
_TRANSLATE = bytes(c if c not in b",\t\r\n" else 32 for c in range(256))
_STROKE_WIDTH = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?:px)?\s*")


def read_straight(root: ET.Element, tops: list[ET.Element], loose: list[ET.Element]):
    """The lines of each layer of a straight-line SVG in user units, or None if it is not one.

    The tree is walked once to collect every shape's text; all paths' data are then parsed as one
    text and all point lists as another (no work per shape beyond the walk), and the lines put
    back in document order per layer.

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
    if (
        _moves(root)
        or not _even_view(root)
        or any(next(root.iter(tag), None) is not None for tag in _STYLE_TAGS)
    ):
        return None
    shapes = _shapes(root, tops, loose)
    if shapes is None:
        return None
    keys, kinds, texts, strokes = shapes
    kinds = np.array(kinds, np.int8)
    lines = [
        _path_lines([t for t, k in zip(texts, kinds.tolist()) if k == _PATH]),
        _point_lines([t for t, k in zip(texts, kinds.tolist()) if k != _PATH], kinds[kinds != _PATH]),
    ]
    if any(found is None for found in lines):
        return None
    # Every line's shape in document order: the paths' and the point lists' numbered back.
    shape_of = [np.flatnonzero(kinds == _PATH)[lines[0][2]], np.flatnonzero(kinds != _PATH)[lines[1][2]]]
    points = np.concatenate([lines[0][0], lines[1][0]])
    counts = np.concatenate([np.diff(lines[0][1]), np.diff(lines[1][1])])
    starts = np.concatenate([lines[0][1][:-1], lines[1][1][:-1] + len(lines[0][0])])
    shape = np.concatenate(shape_of)
    key_of_shape = np.array(keys, np.int64)
    layers = []
    for place in sorted(set(keys), key=lambda lid: (lid == 1, lid)):
        chosen = np.flatnonzero(key_of_shape[shape] == place)
        chosen = chosen[np.argsort(shape[chosen], kind="stable")]
        if not len(chosen):
            continue
        take = np.repeat(starts[chosen] - np.cumsum(np.r_[0, counts[chosen][:-1]]), counts[chosen])
        take += np.arange(len(take))
        widths = {stroke for stroke, key in zip(strokes, keys) if key == place}
        layers.append(
            (
                place,
                points[take] - _view_origin(root),
                np.concatenate([[0], np.cumsum(counts[chosen])]),
                widths.pop() if len(widths) == 1 else None,
            )
        )
    return layers


_PATH, _POLYLINE, _POLYGON, _LINE = range(4)
_KINDS = {"path": _PATH, "polyline": _POLYLINE, "polygon": _POLYGON, "line": _LINE}


def _shapes(root: ET.Element, tops: list[ET.Element], loose: list[ET.Element]):
    """Every shape in document order: its layer key, kind, text (a path's data, a point list; a
    line's four numbers) and stroke width; None when anything is not a straight shape."""
    keys, kinds, texts, strokes = [], [], [], []
    names: dict[str, str] = {}  # tag → local name, worked out once per tag
    loose_ids = {id(element) for element in loose}
    for place, top in enumerate(tops, start=2):
        key = 1 if id(top) in loose_ids else place
        stack = [(top, _stroke(root, None))]
        while stack:
            element, inherited = stack.pop()
            name = names.get(element.tag) or names.setdefault(element.tag, local_name(element.tag))
            if name in _QUIET:
                continue
            attrib = element.attrib
            styled = "style" in attrib
            if (styled or not _MOVING_SET.isdisjoint(attrib)) and _moves(element):
                return None
            stroke = (
                _stroke(element, inherited)
                if (styled or "stroke-width" in attrib)
                else (1.0 if inherited is None else inherited)
            )
            if name == "g":
                bare = _bare_paths(element) if stroke is not False else None
                if bare is not None:  # the common case, a million paths in one group: at once
                    keys += [key] * len(bare)
                    kinds += [_PATH] * len(bare)
                    texts += bare
                    strokes += [stroke] * len(bare)
                    continue
                stack.extend(zip(reversed(element), itertools.repeat(stroke)))
                continue
            if name not in _SHAPES or len(element) or stroke is False:
                return None
            if name == "path":
                text = element.get("d", "")
            elif name == "line":
                text = " ".join(element.get(k, "0").replace(",", "_") for k in ("x1", "y1", "x2", "y2"))
            else:
                text = element.get("points", "")
            keys.append(key)
            kinds.append(_KINDS[name])
            texts.append(text)
            strokes.append(stroke)
    return keys, kinds, texts, strokes


#: What makes a shape more than its data: its own style or stroke width, or what moves it.
_DRESSED = _MOVING_SET | {"style", "stroke-width"}


def _bare_paths(group: ET.Element) -> list[str] | None:
    """The data of ``group``'s shapes when every one is a bare ``<path>`` (nothing inside, none of
    :data:`_DRESSED`): each then draws with the group's stroke, in document order. Else None."""
    children = list(group)
    if not children or any(local_name(tag) != "path" for tag in {c.tag for c in children}):
        return None
    if any(len(c) or not _DRESSED.isdisjoint(c.attrib) for c in children):
        return None
    return [c.get("d", "") for c in children]


def _point_lines(texts: list[str], kinds: np.ndarray):
    """Polylines', polygons' and lines' points, all parsed as one text: ``(points, offsets,
    shape)`` (``shape``: which of ``texts`` each line came from), or None when one is malformed."""
    if not texts:
        return np.zeros((0, 2)), np.zeros(1, np.int64), np.zeros(0, np.int64)
    sentinel = f" {_SENTINEL:.0e} "
    try:
        values = _numbers((sentinel + sentinel.join(texts)).encode("ascii"))
    except UnicodeEncodeError:
        return None
    if values is None:
        return None
    is_cut = values >= _SENTINEL
    if np.count_nonzero(is_cut) != len(texts):  # a number in the text as large as the sentinel
        return None
    cuts = np.flatnonzero(is_cut)
    counts = np.diff(np.append(cuts, len(values))) - 1
    if (counts % 2).any() or ((kinds == _LINE) & (counts != 4)).any():
        return None
    points = values[~is_cut].reshape(-1, 2)
    lengths = counts // 2
    offsets = np.concatenate([[0], np.cumsum(lengths)])
    # A polygon closes back to its start unless its last point is its first.
    first, last = offsets[:-1], offsets[1:] - 1
    closes = np.flatnonzero((kinds == _POLYGON) & (lengths > 0))
    closes = closes[(points[last[closes]] != points[first[closes]]).any(axis=1)]
    if len(closes):
        points = np.insert(points, offsets[closes + 1], points[first[closes]], axis=0)
        lengths[closes] += 1
        offsets = np.concatenate([[0], np.cumsum(lengths)])
    # A line drops a repeated point (as a path does); a polyline keeps its points as they are.
    line = kinds == _LINE
    if line.any():
        points, offsets = _tidy(points, offsets, keep=np.repeat(~line, lengths))
        lengths = np.diff(offsets)
    # Lines of fewer than two points draw nothing.
    shape = np.arange(len(texts))
    kept = lengths >= 2
    points = points[np.repeat(kept, lengths)]
    return points, np.concatenate([[0], np.cumsum(lengths[kept])]), shape[kept]


def _path_lines(ds: list[str]):
    """Paths' lines from ``M L H V Z`` commands (either case), all paths' data parsed as one text:
    ``(points, offsets, shape)`` (``shape``: which of ``ds`` each line came from); None for
    anything else (curves, arcs), or relative moves after a ``Z`` in one path."""
    if not ds:
        return np.zeros((0, 2)), np.zeros(1, np.int64), np.zeros(0, np.int64)
    joined = "".join(ds)
    if not _STRAIGHT_D.fullmatch(joined) or not joined.isascii():
        return None
    # Each path's data starts with a cut ("X"), a command with no numbers that ends the last one.
    text = b"X" + "X".join(ds).encode("ascii")
    for letter, number in _CMD_TEXT.items():
        text = text.replace(bytes([letter]), number)
    if b"-" in text:
        text = re.sub(rb"(?<=[\d.])-", b" -", text)  # "1-2" is two numbers
    values = _numbers(text)
    if values is None:
        return None
    is_cmd = values >= _SENTINEL
    codes = np.rint(values[is_cmd] / _SENTINEL).astype(np.int64) - 1  # index into _COMMANDS
    letters = np.frombuffer(_COMMANDS, np.uint8)[codes]
    starts = np.flatnonzero(is_cmd)
    counts = np.diff(np.append(starts, len(values))) - 1
    cut = letters == ord("X")
    element = np.cumsum(cut) - 1  # which path each command belongs to
    pair = np.isin(letters, np.frombuffer(b"MmLl", np.uint8))
    single = np.isin(letters, np.frombuffer(b"HhVv", np.uint8))
    close = ~pair & ~single & ~cut
    relative = letters >= ord("a")
    if (
        (pair & ((counts < 2) | (counts % 2 == 1))).any()
        or (single & (counts < 1)).any()
        or ((close | cut) & (counts > 0)).any()
    ):
        return None
    # A path starts with a move (or is empty: its cut is followed by the next cut or the end).
    after_cut = np.flatnonzero(cut) + 1
    opening = letters[np.minimum(after_cut, len(letters) - 1)] & ~np.uint8(32)
    if ((after_cut < len(letters)) & (opening != ord("M")) & (opening != ord("X"))).any():
        return None
    per = len(ds)
    if (
        np.bincount(element[close], minlength=per).astype(bool)
        & np.bincount(element[relative], minlength=per).astype(bool)
    ).any():
        return None  # relative moves after a Z start from the subpath's start: vpype's business
    first_move = np.zeros(len(letters), bool)  # a path's first move is absolute, whatever its case
    first_move[after_cut[after_cut < len(letters)]] = True
    # One entry per point: where it sits among the values, and its command.
    seg = np.cumsum(is_cmd) - 1
    offset = np.arange(len(values)) - starts[seg] - 1
    at_point = (~is_cmd & pair[seg] & (offset % 2 == 0)) | (~is_cmd & single[seg]) | (is_cmd & close[seg])
    where = np.flatnonzero(at_point)
    command = letters[seg[where]]
    upper = command & ~np.uint8(32)
    moves = (upper == ord("M")) & (offset[where] == 0)
    rel = (command >= ord("a")) & ~(first_move[seg[where]] & (offset[where] == 0))
    nxt = np.minimum(where + 1, len(values) - 1)
    x_given = (upper == ord("M")) | (upper == ord("L")) | (upper == ord("H"))
    y_given = (upper == ord("M")) | (upper == ord("L")) | (upper == ord("V"))
    x_value = values[where]
    y_value = np.where(upper == ord("V"), values[where], values[nxt])
    if close.any():  # absolute in such a path: a Z sets the point to its subpath's start
        start_of = np.maximum.accumulate(np.where(moves, np.arange(len(where)), 0))
        is_z = upper == ord("Z")
        x_value = np.where(is_z, x_value[start_of], x_value)
        y_value = np.where(is_z, y_value[start_of], y_value)
        x_given, y_given = x_given | is_z, y_given | is_z
    xs = _follow(x_value, x_given & ~rel, np.where(x_given & rel, x_value, 0.0))
    ys = _follow(y_value, y_given & ~rel, np.where(y_given & rel, y_value, 0.0))
    points = np.column_stack([xs, ys])
    subpaths = np.flatnonzero(moves)
    points, offsets, kept = _tidy(points, np.append(subpaths, len(points)), with_kept=True)
    return points, offsets, element[seg[where[subpaths]]][kept]


def _follow(value: np.ndarray, absolute: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """A coordinate along a path: set where ``absolute``, else the last one plus ``delta``
    (a running sum restarted at each absolute value), from 0."""
    index = np.arange(len(value))
    last = np.maximum.accumulate(np.where(absolute, index, -1))
    total = np.cumsum(delta)
    base = np.where(last >= 0, value[np.maximum(last, 0)], 0.0)
    return base + total - np.where(last >= 0, total[np.maximum(last, 0)], 0.0)


def _tidy(
    points: np.ndarray, offsets: np.ndarray, *, keep: np.ndarray | None = None, with_kept: bool = False
):
    """vpype's lines: a point equal to the one before it dropped (except where ``keep``), paths of
    fewer than two gone; with ``with_kept`` also which of the paths are left."""
    if not len(points):
        empty = (points.reshape(0, 2), np.zeros(1, np.int64))
        return (*empty, np.zeros(0, np.int64)) if with_kept else empty
    path_of = np.repeat(np.arange(len(offsets) - 1), np.diff(offsets))
    same = np.zeros(len(points), bool)
    same[1:] = (points[1:] == points[:-1]).all(axis=1) & (path_of[1:] == path_of[:-1])
    if keep is not None:
        same &= ~keep
    points, path_of = points[~same], path_of[~same]
    counts = np.bincount(path_of, minlength=len(offsets) - 1)
    if keep is not None:  # the caller drops short lines itself, knowing which shape each is
        return points, np.concatenate([[0], np.cumsum(counts)])
    left = np.flatnonzero(counts >= 2)
    points = points[np.repeat(counts >= 2, counts)]
    offsets = np.concatenate([[0], np.cumsum(counts[left])])
    return (points, offsets, left) if with_kept else (points, offsets)


def _numbers(text: bytes) -> np.ndarray | None:
    """Every number of ``text`` (separated by spaces or commas), or None if it holds anything
    else (``1+2``, ``0.5.5``: vpype reads those)."""
    text = text.translate(_TRANSLATE)
    a = np.frombuffer(text, np.uint8)
    if not len(a):
        return np.zeros(0)
    quick = _decimals(a)
    if quick is not None:
        return quick
    filled = a != 32
    expected = int(filled[0]) + int(np.count_nonzero(filled[1:] & ~filled[:-1]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a malformed number ends the parse early: counted below
        try:
            values = np.fromstring(text, dtype=np.float64, sep=" ")  # C speed, one pass
        except ValueError:
            return None
    return values if len(values) == expected else None


_WORDS = [word.strip() for word in (f" {_SENTINEL:.0e} ".encode(), *_CMD_TEXT.values())]
_WORD_KEYS = [int(np.frombuffer(w.ljust(8), np.uint64)[0]) for w in _WORDS]  # a word's 8 bytes
_WORD_VALUES = np.array([float(w) for w in _WORDS])
_TENS = 10.0 ** np.arange(16)  # exact in float64


def _decimals(a: np.ndarray) -> np.ndarray | None:
    """The numbers of ``a`` (bytes; spaces between numbers) when each is a plain decimal of at
    most 15 digits (``-12.5``) or one of the commands' sentinels, else None. Such a decimal is
    m / 10^f with m and 10^f exact in float64: one correctly rounded division, so the very
    number strtod gives, at a fifth of its cost. Bytes are read a column of all numbers at a time.
    """
    filled = np.zeros(len(a) + 2, np.int8)
    filled[1:-1] = a != 32
    edge = np.diff(filled)
    starts, length = np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)
    length -= starts
    if not len(starts) or (width := max(8, int(length.max()))) > 17:
        return None  # (fromstring decides)
    grid = np.lib.stride_tricks.sliding_window_view(np.r_[a, np.full(width, 32, np.uint8)], width)[starts]
    grid[np.arange(width) >= length[:, None]] = 32
    key = np.ascontiguousarray(grid[:, :8]).view(np.uint64).ravel()
    word = np.full(len(key), -1, np.int8)
    for i, k in enumerate(_WORD_KEYS):
        word[key == k] = i
    mantissa, (digits, fraction) = np.zeros(len(key), np.int64), np.zeros((2, len(key)), np.int8)
    dot, bad = np.zeros((2, len(key)), bool)
    for j in range(width):
        column = grid[:, j]
        digit = column - np.uint8(48)  # a digit's value; anything else wraps past 9
        is_digit = digit < 10
        mantissa = np.where(is_digit, mantissa * 10 + digit, mantissa)
        digits += is_digit
        fraction += is_digit & dot
        is_dot = column == 46
        bad |= is_dot & dot
        dot |= is_dot
        other = ~is_digit & ~is_dot & (column != 32)
        bad |= other & ((column != 45) & (column != 43)) if j == 0 else other
    if ((word < 0) & (bad | (digits == 0) | (digits > 15))).any():
        return None
    values = mantissa.astype(np.float64) / _TENS[np.minimum(fraction, 15)]
    np.negative(values, out=values, where=grid[:, 0] == 45)
    values[word >= 0] = _WORD_VALUES[word[word >= 0]]
    return values


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
    style = {
        k.strip(): v.strip()
        for k, _, v in (part.partition(":") for part in element.get("style", "").split(";"))
    }
    for name in _MOVING:
        value = element.get(name, style.get(name))
        if value is not None and (name, value) not in (("display", "inline"), ("visibility", "visible")):
            return True
    return False


def _stroke(element: ET.Element, inherited):
    """The stroke width (user units) ``element`` draws with: its own, else its group's (svgelements'
    default: 1); ``False`` for one given in another unit (not read here)."""
    style = {
        k.strip(): v for k, _, v in (part.partition(":") for part in element.get("style", "").split(";"))
    }
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
