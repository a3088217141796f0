"""SVG drawings as other tools write them, made in code (tests/conftest.py puts this folder on
the import path): Inkscape, vpype, hatched (svgwrite) and linedraw, each with the structure and
quirks of the real thing, and the coordinates each one's geometry should read back as."""

from __future__ import annotations

import math

import numpy as np

SVG_NS = "http://www.w3.org/2000/svg"

# -- Inkscape 1.x: mm document, layers with transforms, shapes, curves --------------------------

#: What the Inkscape drawing holds, in page mm with Y up (page 120 x 90 mm).
INKSCAPE_PAGE = (120.0, 90.0)
INKSCAPE_RECT = [
    (15.0, 80.0),
    (45.0, 80.0),
    (45.0, 60.0),
    (15.0, 60.0),
    (15.0, 80.0),
]  # after translate(10,5)
INKSCAPE_CIRCLE = ((70.0, 60.0), 8.0)  # centre after translate, radius
INKSCAPE_BEZIER_ENDS = ((10.0, 30.0), (50.0, 30.0))
INKSCAPE_ROTATED_LINE = ((90.0, 40.0), (90.0, 20.0))  # "M 90,50 H 110" rotated 90° about (90, 50)


def inkscape_svg() -> str:
    """An Inkscape 1.x file: mm page, a sodipodi:namedview, layers (one translated), a rect, a
    circle and an ellipse-free circle as styled shapes, a cubic Bézier in relative commands, a
    group rotated inside a layer, a hidden helper layer, and text (no pen path)."""
    return f"""<?xml version="1.0" encoding="UTF-8" standalone="no"?>
<!-- Created with Inkscape (http://www.inkscape.org/) -->
<svg width="120mm" height="90mm" viewBox="0 0 120 90" version="1.1" id="svg1"
   inkscape:version="1.3.2 (091e20ef0f, 2023-11-25)" sodipodi:docname="drawing.svg"
   xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
   xmlns:sodipodi="http://sodipodi.sourceforge.net/DTD/sodipodi-0.dtd"
   xmlns="{SVG_NS}" xmlns:svg="{SVG_NS}">
  <sodipodi:namedview id="namedview1" pagecolor="#ffffff" bordercolor="#000000" inkscape:document-units="mm"/>
  <defs id="defs1"/>
  <g inkscape:label="Shapes" inkscape:groupmode="layer" id="layer1" transform="translate(10,5)">
    <rect style="fill:none;stroke:#000000;stroke-width:0.3;stroke-linecap:round" id="rect1"
       width="30" height="20" x="5" y="5"/>
    <circle style="fill:none;stroke:#000000;stroke-width:0.3" id="path1" cx="60" cy="25" r="8"/>
  </g>
  <g inkscape:label="Curves" inkscape:groupmode="layer" id="layer2">
    <path style="fill:none;stroke:#000000;stroke-width:0.3" d="m 10,60 c 10,-15 30,15 40,0" id="path2"/>
    <g id="g1" transform="rotate(90,90,50)">
      <path style="fill:none;stroke:#000000;stroke-width:0.3" d="M 90,50 H 110" id="path3"/>
    </g>
    <text xml:space="preserve" style="font-size:4px;fill:#000000" x="60" y="80" id="text1">label</text>
  </g>
  <g inkscape:label="Helpers" inkscape:groupmode="layer" id="layer3" style="display:none">
    <path style="fill:none;stroke:#ff0000;stroke-width:0.3" d="M 0,0 L 120,90" id="path4"/>
  </g>
</svg>
"""


# -- vpype 1.x: what `vpype … write` writes -----------------------------------------------------


def vpype_svg(path) -> dict:
    """Write a two-layer drawing with vpype's own writer (A5 page, named layers with pen widths
    and colours) and return what it holds: layer name → (pen width mm, lines in page mm, Y up)."""
    import vpype

    px = 96 / 25.4
    page = (148.0, 210.0)
    rng = np.random.default_rng(7)
    layers = {
        "outline": (
            0.3,
            [np.array([[10.0, 10.0], [138.0, 10.0], [138.0, 200.0], [10.0, 200.0], [10.0, 10.0]])],
        ),
        "fill": (0.8, [np.cumsum(rng.uniform(-3, 3, (6, 2)), axis=0) + [74.0, 105.0] for _ in range(5)]),
    }
    document = vpype.Document(page_size=(page[0] * px, page[1] * px))
    for lid, (name, (pen, lines)) in enumerate(layers.items(), start=1):
        # vpype works in CSS pixels with Y down.
        collection = vpype.LineCollection([(p[:, 0] + 1j * (page[1] - p[:, 1])) * px for p in lines])
        document.add(collection, lid)
        document.layers[lid].set_property("vp_name", name)
        document.layers[lid].set_property("vp_pen_width", pen * px)
        document.layers[lid].set_property("vp_color", vpype.Color("#1f77b4" if lid == 1 else "#d62728"))
    with open(path, "w", encoding="utf-8") as handle:
        vpype.write_svg(handle, document, source_string="vpype read in.svg write out.svg")
    return {"page": page, "layers": layers}


# -- hatched 0.2 (svgwrite): one path, width and height without units, and swapped -------------


def hatch_lines(width: int = 300, height: int = 200, pitch: float = 4.0) -> list[np.ndarray]:
    """Diagonal hatching of a dark disc and a darker band, in image pixels (Y down), cut into
    runs where each hatch line crosses them, in the order a scan makes them (as hatched does)."""
    lines = []
    for offset in np.arange(-height, width, pitch):
        t = np.linspace(0, height, 4 * height + 1)
        x, y = offset + t, t
        inside = ((x - 180) ** 2 + (y - 100) ** 2 < 70**2) | ((y > 20) & (y < 60) & (x > 20) & (x < 140))
        inside &= (x >= 0) & (x <= width)
        runs = np.flatnonzero(np.diff(np.concatenate([[0], inside.astype(np.int8), [0]])))
        for a, b in zip(runs[::2], runs[1::2] - 1):
            if b > a:
                lines.append(np.array([[x[a], y[a]], [x[b], y[b]]]))
    return lines


def hatched_svg(lines: list[np.ndarray], image_shape=(200, 300)) -> str:
    """The file hatched 0.2 writes (``svgwrite.Drawing(size=(w, h), profile="tiny")``): its
    ``width`` is the image's row count and ``height`` its column count (a bug of hatched's), both
    without units, and every hatch run in one ``<path>``, coordinates as Python prints floats."""
    rows, cols = image_shape
    d = " ".join("M" + " L".join(f"{float(x)!r},{float(y)!r}" for x, y in line) for line in lines)
    return (
        '<?xml version="1.0" encoding="utf-8" ?>\n'
        f'<svg baseProfile="tiny" height="{cols}" version="1.2" width="{rows}" xmlns="{SVG_NS}" '
        'xmlns:ev="http://www.w3.org/2001/xml-events" xmlns:xlink="http://www.w3.org/1999/xlink">'
        f'<defs /><path d="{d}" fill="none" stroke="black" /></svg>'
    )


# -- linedraw (LingDong-): polylines, no size at all -------------------------------------------


def contour_lines(count: int = 12, seed: int = 3) -> list[np.ndarray]:
    """Contour strokes as a tracing tool makes them: pieces of concentric wobbly rings, in
    image pixels (Y down), ring after ring, each piece in the direction it was traced."""
    rng = np.random.default_rng(seed)
    lines = []
    for ring in range(count):
        radius = 30 + 12 * ring
        start = rng.uniform(0, 2 * math.pi)
        for piece in range(6):
            t = start + np.linspace(piece, piece + 0.9, 9) * (2 * math.pi / 6)
            r = radius + rng.normal(0, 1.0, len(t))
            lines.append(np.column_stack([300 + r * np.cos(t), 300 + r * np.sin(t)]))
    return lines


def linedraw_svg(lines: list[np.ndarray]) -> str:
    """The file linedraw's ``makesvg`` writes: no width, height or viewBox, one ``<polyline>`` a
    stroke with every number comma-separated, stroke-width 2 (user units)."""
    out = f'<svg xmlns="{SVG_NS}" version="1.1">'
    for line in lines:
        points = ",".join(f"{float(x)},{float(y)}" for x, y in line)
        out += f'<polyline points="{points}" stroke="black" stroke-width="2" fill="none" />\n'
    return out + "</svg>"
