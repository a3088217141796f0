"""SVG drawings read back into plans: pencilbot's own (as :mod:`pencilbot.export.svg` writes
them) in whole arrays, any other tool's through :mod:`pencilbot.export.svg_straight` or vpype's
reader. SVG's Y axis points down, the plan's up: the flip ``y_svg = page height − y`` is undone
here, on the way in.
"""

from __future__ import annotations

import io
import os
import re
import warnings
import xml.etree.ElementTree as ET

import numpy as np

from pencilbot.errors import PencilbotError, no_such_file
from pencilbot.export.svg import INKSCAPE_NS, PENCILBOT_NS, SVG_NS
from pencilbot.export.svg_checks import check_drawing, check_numbers, check_uses
from pencilbot.export.svg_size import NUMBER as _NUMBER
from pencilbot.export.svg_size import px_per_inch, svg_size
from pencilbot.export.svg_straight import read_straight
from pencilbot.fileio import read_bounded
from pencilbot.paths import Paths
from pencilbot.planning.plan import BLACK, ROLES, Layer, Page, Plan
from pencilbot.planning.style import MAX_PEN_WIDTH
from pencilbot.units import DEFAULT_PEN_WIDTH, MM_PER_INCH

#: The longest SVG read (bytes): a million paths are about 100 MB; its tree takes ten times more.
MAX_SVG_FILE = 1 << 30


def read_svg(path: str | os.PathLike, *, dpi: float | None = None, pen_width: float | None = None) -> Plan:
    """Read an SVG drawing into a :class:`Plan`: a plan written by
    :func:`~pencilbot.export.svg.write_svg`, or any other.

    A plan of pencilbot's own is read with whole-array numpy (a million strokes in about a
    second). Any other SVG (Inkscape, vpype, hatched, linedraw, …) goes through vpype's reader
    (``pip install "pencilbot[vpype]"``), which applies transforms and reads groups, shapes and
    curves. Curves are cut into segments of at most half the pen width ``w``: a chord strays
    from an arc of radius ``r`` by at most ``w² / 32 r``, under a tenth of the pen width wherever
    ``r > w / 3``. vpype drops zero-length paths (dots). The top-level groups become layers (named by ``inkscape:label``, else
    ``id``; drawing outside any group becomes a layer ``"default"``), with their stroke width as
    pen width. A plan of ours edited elsewhere keeps its page, margin, layer roles and metadata.
    Nothing is cropped: a drawing that runs off its page is read whole (the G-code writer
    checks it against the bed).

    Parameters
    ----------
    path : str or PathLike
    dpi : float, optional
        User units per inch of a file whose ``width`` and ``height`` carry no unit or are
        missing (96 reads them as CSS pixels, as Inkscape and vpype do). Without it, such a
        file is refused: nothing says how large it is meant to be.
    pen_width : float, optional
        Pen width in mm of every layer of a foreign file (default: its stroke width if it
        declares one, else :data:`~pencilbot.units.DEFAULT_PEN_WIDTH`); it also sets the
        flattening tolerance. A plan of ours keeps its own pen widths.

    Returns
    -------
    Plan
        Coordinates in mm on the page, origin bottom-left, Y up.

    Raises
    ------
    PencilbotError
        The file is missing or not SVG, has no physical size and no ``dpi``, or is foreign and
        vpype is not installed or cannot read it.
    """
    data = _read_bytes(path)
    return _read_own(data, path) or _read_any(
        _parse(data, path), path, dpi=dpi, pen_width=pen_width, size=len(data), text=data.decode("latin-1")
    )


def is_plan_svg(path: str | os.PathLike) -> bool:
    """Whether ``path`` was written by :func:`~pencilbot.export.svg.write_svg` (and is so already in drawing order).

    Only the root element is read; a file that is not SVG is no plan.
    """
    try:
        for _, root in ET.iterparse(path, events=("start",)):
            return root.tag == f"{{{SVG_NS}}}svg" and root.get(_PAGE) is not None
    except (ET.ParseError, OSError, LookupError, ValueError):  # LookupError: an unknown encoding
        pass
    return False


def _read_bytes(path) -> bytes:
    try:
        return read_bounded(path, "SVG file", MAX_SVG_FILE)
    except FileNotFoundError:
        raise PencilbotError(no_such_file(path, "the path of an .svg file")) from None
    except OSError as exc:
        raise PencilbotError(
            f"cannot read {path} ({exc.strerror}); check the path and its permissions"
        ) from None


def _parse(data: bytes, path) -> ET.Element:
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise PencilbotError(f"cannot read {path} as SVG ({exc}); is it an SVG drawing?") from None
    except (LookupError, ValueError) as exc:  # expat knows a handful of encodings; Python's codecs the rest
        raise PencilbotError(
            f"cannot read {path}: its XML declaration names an encoding that cannot be read ({exc}); "
            'save it as UTF-8 (encoding="UTF-8")'
        ) from None
    if root.tag != f"{{{SVG_NS}}}svg":
        raise PencilbotError(f"{path} is not an SVG file (root element {root.tag!r})")
    return root


# --- pencilbot's own plans, whole arrays at a time ---------------------------------------------

_PAGE, _MARGIN, _ROLE, _PEN = (f"{{{PENCILBOT_NS}}}{name}" for name in ("page", "margin", "role", "pen"))
_GROUP_TAG = re.compile(rb"<g [^>]*>|</g>")
_LABEL = f"{{{INKSCAPE_NS}}}label"
_OWN_TEXT = b"0123456789.- L\n"  # all a layer's path data holds besides its element tags
_NUMBER_BYTES = bytes(c if c in b"0123456789.-na" else 32 for c in range(256))
#: Attributes that move or hide what a group holds: a layer with one is read as any SVG is.
_MOVES = {"transform", "style", "display", "visibility", "clip-path", "mask", "filter"}


def _read_own(data: bytes, path="the SVG") -> Plan | None:
    """The plan, if ``data`` is a file just as :func:`~pencilbot.export.svg.write_svg` writes it; else None.

    Each layer's path data is cut out of the file and the rest (root, metadata, pen and layer
    tags) parsed as XML; a layer's coordinates are then one ``np.fromstring`` over its cut, with
    a NaN where each path starts. A layer is a group that holds no group: at the top, or inside a
    pen's group (a colour plan). Anything else (an edited file, a curve) gives None, and the file
    is read as any SVG is. What is read passes the checks another tool's SVG does (numbers
    finite and of a drawable size, pen widths a pen has), raising :class:`PencilbotError`.
    """
    if f'xmlns:pencilbot="{PENCILBOT_NS}"'.encode() not in data[:4096]:
        return None
    skeleton, cuts, at = [], [], 0
    tags = list(_GROUP_TAG.finditer(data))
    for tag, after in zip(tags, tags[1:] + [None]):
        if tag[0] == b"</g>" or tag[0].endswith(b"/>"):
            continue
        if after is None or after[0] != b"</g>":  # a pen's group: its layers follow
            continue
        skeleton.append(data[at : tag.end()])
        cuts.append(data[tag.end() : after.start()])
        at = after.start()
    skeleton.append(data[at:])
    try:
        root = ET.fromstring(b"".join(skeleton))
        width, height, scale = svg_size(root, "", None)
    except (ET.ParseError, PencilbotError, LookupError, ValueError):
        return None  # read as any SVG is: the same error, said once
    assert height is not None  # without a dpi, svg_size gives a size or raises
    g = f"{{{SVG_NS}}}g"
    tops = [child for child in root if child.tag == g]
    others = {child.tag for child in root} - {g, f"{{{SVG_NS}}}metadata"}
    leaves: list[tuple[ET.Element, ET.Element | None]] = []  # (layer group, its pen's group or None)
    for top in tops:
        if top.get(_PEN) is None:
            leaves.append((top, None))
        else:
            leaves += [(child, top) for child in top]
            if any(child.tag != g for child in top):
                return None
    moved = [
        element
        for element in (root, *tops, *(leaf for leaf, _ in leaves))
        if _MOVES.intersection(element.keys())
    ]
    origin = [float(v) for v in _NUMBER.findall(root.get("viewBox", "0 0"))[:2]]
    if (
        others
        or moved
        or origin != [0.0, 0.0]
        or len(leaves) != len(cuts)
        or any(len(leaf) for leaf, _ in leaves)
    ):
        return None
    check_numbers(root, path)
    layers: list[Layer] = []
    for number, ((group, pen), cut) in enumerate(zip(leaves, cuts), start=1):
        paths = _own_paths(cut, scale, height)
        if paths is None:
            return None
        check_drawing(paths.points, path)
        attributes = _layer_attributes(group, number, scale, pen=pen)
        attributes["pen_width"] = _checked_pen(
            attributes["pen_width"] or DEFAULT_PEN_WIDTH, attributes["name"], path, own=True
        )
        layers.append(Layer(paths=paths, **attributes))
    return Plan(page=_page(root, width, height), layers=tuple(layers), meta=_meta(root))


def _own_paths(cut: bytes, scale: float, page_height: float) -> Paths | None:
    """One layer's ``<path d="M x y L x y …"/>`` elements as paths in page mm; None if its text
    is anything else."""
    if cut.replace(b'<path d="M ', b"").replace(b'"/>', b"").translate(None, _OWN_TEXT):
        return None
    if b"<path" not in cut:
        return Paths.empty()
    text = cut.replace(b'<path d="M', b" nan ").translate(_NUMBER_BYTES)
    try:
        with warnings.catch_warnings():  # numpy < 2 warns, and stops, at a malformed number
            warnings.simplefilter("error", DeprecationWarning)
            numbers = np.fromstring(text, sep=" ")
    except (ValueError, DeprecationWarning):
        return None
    starts = np.flatnonzero(np.isnan(numbers))
    counts = np.diff(np.append(starts, len(numbers))) - 1
    if (
        len(starts) != cut.count(b"<path")
        or (len(starts) and starts[0])
        or np.any((counts < 4) | (counts % 2 == 1))
    ):
        return None
    points = numbers[~np.isnan(numbers)].reshape(-1, 2)
    lengths = counts // 2
    # A dot is written as a zero-length segment; it reads back as the one point it is.
    firsts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    dots = (lengths == 2) & np.all(points[firsts] == points[np.minimum(firsts + 1, len(points) - 1)], axis=1)
    if dots.any():
        points = np.delete(points, firsts[dots] + 1, axis=0)
        lengths[dots] = 1
    return Paths(_to_page(points, scale, page_height), np.concatenate([[0], np.cumsum(lengths)]))


# --- any SVG: vpype's reader -------------------------------------------------------------------

#: Top-level elements that draw nothing, so are no layer.
_NOT_DRAWN = {"defs", "metadata", "style", "title", "desc", "namedview", "script"}


def _read_any(
    root: ET.Element,
    path,
    *,
    dpi: float | None,
    pen_width: float | None,
    size: int = 0,
    text: str | None = None,
) -> Plan:
    """Any SVG: checked at the door, straight lines read in whole arrays, the rest through vpype."""
    check_numbers(root, path, text)  # NaN, infinities, 1e308: one message naming the element
    check_uses(root, path, size)
    width, height, scale = svg_size(root, path, dpi)
    # vpype numbers layers by the digits of their labels (two "Layer 1"s would merge): give
    # every top-level element a label by its place, the layer attributes having been read.
    tops = [element for element in root if _local(element.tag) not in _NOT_DRAWN]
    loose = [element for element in tops if _local(element.tag) != "g"]
    groups: dict[int, tuple[dict, bool]] = {}
    for place, element in enumerate(tops, start=2):  # vpype's layer 1 holds the loose shapes
        if _local(element.tag) == "g":
            groups[place] = (_layer_attributes(element, len(groups) + 1, scale), _declares_stroke([element]))
        element.set(_LABEL, f"pencilbot-{place}")
    straight = read_straight(root, tops, loose) if height is not None else None
    if straight is None or height is None:
        return _read_vpype(root, path, dpi, pen_width, (groups, loose), width, height)
    # straight lines only: read in whole arrays, as vpype would read them
    if root.get("viewBox") is None:  # user units are CSS pixels (or --svg-dpi's), as vpype reads them
        scale = MM_PER_INCH / px_per_inch(root, dpi)
    layers: list[Layer] = []
    for place, points, offsets, stroke in straight:
        check_drawing(points * scale, path)
        layers.append(
            Layer(
                paths=Paths(_to_page(points, scale, height), offsets),
                **_pen_of(
                    *_layer_of(place, groups, loose),
                    stroke * scale if stroke else None,
                    pen_width,
                    root,
                    path=path,
                ),
            )
        )
    return Plan(page=_page(root, width, height), layers=tuple(layers), meta=_meta(root))


def _layer_of(place: int, groups: dict[int, tuple[dict, bool]], loose: list[ET.Element]) -> tuple[dict, bool]:
    """The layer attributes of the top-level group at ``place`` (and whether it declares a
    stroke), or of the loose shapes' layer."""
    return groups.get(place) or ({"name": "default", "role": "other"}, _declares_stroke(loose))


def _read_vpype(root: ET.Element, path, dpi, pen_width, tops, width: float, height: float | None) -> Plan:
    """Any SVG through vpype: each top-level group a layer (``tops``: the groups' attributes by
    place, the loose shapes), shapes and curves flattened."""
    groups, loose = tops
    try:
        import vpype
    except ImportError:
        raise PencilbotError(
            f"{path} was not written by pencilbot; reading other tools' SVGs needs vpype: "
            'pip install "pencilbot[vpype]"'
        ) from None
    px_to_mm = MM_PER_INCH / px_per_inch(root, dpi)  # nominally
    # vpype cuts a curve of length L into ceil(L / q) - 1 equal chords, each shorter than 2 q.
    quantization = (pen_width or DEFAULT_PEN_WIDTH) / 4 / px_to_mm
    try:
        document = vpype.read_multilayer_svg(
            io.StringIO(ET.tostring(root, encoding="unicode")), quantization=quantization, crop=False
        )
    except Exception as exc:  # noqa: BLE001 - whatever the third-party parser trips on is in the file
        raise PencilbotError(
            f"vpype cannot read {path} ({type(exc).__name__}: {exc}); check the file"
        ) from None
    if height is not None and document.page_size and document.page_size[0] > 0:
        px_to_mm = width / document.page_size[0]  # exactly: svgelements rounds its mm to px factor
    stylesheet = any(_local(el.tag) == "style" and "stroke-width" in (el.text or "") for el in root.iter())
    found: list[tuple[dict, np.ndarray, np.ndarray]] = []  # (attributes, points in mm, offsets)
    for lid in sorted(document.layers, key=lambda lid: (lid == 1, lid)):  # loose shapes last
        lines = [line for line in document.layers[lid] if len(line)]
        if not lines:
            continue
        vpype_pen = document.layers[lid].property("vp_pen_width")
        attributes = _pen_of(
            *_layer_of(lid, groups, loose),
            float(vpype_pen) * px_to_mm if vpype_pen else None,
            pen_width,
            root,
            stylesheet,
            path=path,
        )
        points = np.concatenate(lines)
        offsets = np.concatenate([[0], np.cumsum([len(line) for line in lines])])
        found.append((attributes, np.column_stack([points.real, points.imag]) * px_to_mm, offsets))
        check_drawing(found[-1][1], path)
    if height is None:  # no size at all: the page reaches to the drawing's far corner
        width, height = (
            float(v) for v in np.max([mm.max(axis=0) for _, mm, _ in found] or [[1.0, 1.0]], axis=0)
        )
    return Plan(
        page=_page(root, width, height),
        layers=tuple(
            Layer(paths=Paths(_to_page(mm, 1.0, height), offsets), **attributes)
            for attributes, mm, offsets in found
        ),
        meta=_meta(root),
    )


def _pen_of(
    attributes: dict,
    declared: bool,
    stroke: float | None,
    pen_width: float | None,
    root: ET.Element,
    stylesheet: bool = False,
    *,
    path,
) -> dict:
    """A layer's attributes with its pen width (mm): ``pen_width`` if given, else the stroke
    width all its shapes draw with (``stroke``, mm) where the file declares one (checked: see
    :func:`_checked_pen`), else the default."""
    if pen_width is None and stroke and (declared or stylesheet or _declares_stroke([root], deep=False)):
        return {**attributes, "pen_width": _checked_pen(stroke, attributes["name"], path)}
    return {**attributes, "pen_width": pen_width or DEFAULT_PEN_WIDTH}


def _checked_pen(width: float, layer: str, path, *, own: bool = False) -> float:
    """A layer's stroke width (mm) as its pen width, refused when no pen draws it: negative (which
    SVG calls an error) or wider than :data:`~pencilbot.planning.style.MAX_PEN_WIDTH`.

    Raises
    ------
    PencilbotError
        Naming the layer and the width, and what to do.
    """
    if not 0 < width <= MAX_PEN_WIDTH:
        raise PencilbotError(
            f"{path}: layer {layer!r} draws with a stroke width of {width:.6g} mm, which no pen draws (a pen is "
            f"wider than 0 and at most {MAX_PEN_WIDTH:g} mm); fix its stroke-width"
            + ("" if own else ", or give the pen with --pen-width")
        )
    return width


def _declares_stroke(elements: list[ET.Element], *, deep: bool = True) -> bool:
    """Whether any of ``elements`` (or what they hold) sets a stroke width. SVG's default of one
    user unit is a matter of display, not a pen: a layer without one gets the default pen."""
    return any(_stroke_width(el) is not None for top in elements for el in (top.iter() if deep else [top]))


# --- what both readers share -------------------------------------------------------------------


def _page(root: ET.Element, width: float, height: float) -> Page:
    margin = root.get(_MARGIN, "0")
    if not re.fullmatch(_NUMBER.pattern, margin.strip()):
        raise PencilbotError(f"pencilbot:margin {margin!r} is not a number of mm; fix or remove it")
    return Page(width=width, height=height, margin=float(margin), name=root.get(_PAGE, "custom"))


def _meta(root: ET.Element) -> dict[str, str]:
    return {m.get("name", ""): m.text or "" for m in root.iter(f"{{{PENCILBOT_NS}}}meta")}


def _layer_attributes(group: ET.Element, number: int, scale: float, *, pen: ET.Element | None = None) -> dict:
    """A layer's name, role, pen width (mm, None if its group sets none), pen and ink colour
    from its group element (and the group of the pen it sits in): the one place both readers
    take layer attributes from."""
    holders = [group] if pen is None else [group, pen]
    stroke = next((m for m in (_NUMBER.match(_stroke_width(el) or "") for el in holders) if m), None)
    color = next((c for c in (_stroke_color(el) for el in holders) if c), BLACK)
    role = group.get(_ROLE)
    return {
        "name": group.get(_LABEL) or group.get("id") or f"layer{number}",
        "role": role if role in ROLES else "other",
        "pen_width": float(stroke[0]) * scale if stroke else None,
        "pen": next((el.get(_PEN) for el in holders if el.get(_PEN)), ""),
        "color": color,
    }


_HEX = re.compile(r"#([0-9a-fA-F]{6}|[0-9a-fA-F]{3})")


def _stroke_color(el: ET.Element) -> str | None:
    """The element's stroke colour as ``#rrggbb`` when it gives one in hex, else None."""
    style = {
        key.strip(): value
        for key, _, value in (part.partition(":") for part in el.get("style", "").split(";"))
    }
    found = _HEX.fullmatch((el.get("stroke") or style.get("stroke") or "").strip())
    if not found:
        return None
    digits = found[1].lower()
    return "#" + (digits if len(digits) == 6 else "".join(c * 2 for c in digits))


def _stroke_width(el: ET.Element) -> str | None:
    style = {
        key.strip(): value
        for key, _, value in (part.partition(":") for part in el.get("style", "").split(";"))
    }
    value = el.get("stroke-width") or style.get("stroke-width")
    return value.strip() if value else None


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _to_page(points: np.ndarray, scale: float, page_height: float) -> np.ndarray:
    """User units, Y down → page mm, Y up."""
    return np.column_stack([points[:, 0] * scale, page_height - points[:, 1] * scale])
