"""Foreign drawings for bench/optimize.py: ten kinds a plotter user brings, each made
deterministically from data that ships with the packages the bench already needs (sources and
licences in bench/drawings/README.md), each in the order its kind of tool writes it.

Every function returns ``(page, layers)``: a :class:`~pencilbot.planning.plan.Page` and a list of
(name, list of (k, 2) mm arrays) in page mm, Y up.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from skimage import data, feature, measure, transform

from pencilbot.imaging.io import image_from_array
from pencilbot.planning.build import make_plan
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.plan import Page
from pencilbot.planning.style import load_style, with_overrides

A4 = Page(210.0, 297.0, 15.0, "A4")


def _sample(name: str) -> Path:
    """A file of matplotlib's sample data (the ``bench`` extra installs matplotlib)."""
    from matplotlib import cbook

    return Path(cbook.get_sample_data(name, asfileobj=False))


def _fit(grey: np.ndarray) -> Layout:
    return Layout.fit(grey.shape, page_size("A4", "auto", grey.shape, 15.0))


def _shuffled(layers, seed: int = 0):
    """Every layer's paths in a random order, about half reversed (a drawing whose order was lost)."""
    rng = np.random.default_rng(seed)
    out = []
    for name, paths in layers:
        order = rng.permutation(len(paths))
        out.append((name, [paths[i][::-1] if rng.random() < 0.5 else paths[i] for i in order]))
    return out


def _plan_layers(rgb: np.ndarray, source: str, **style) -> tuple[Page, list]:
    chosen = with_overrides(load_style("default"), style) if style else None
    plan = make_plan(image_from_array(rgb, source=source), style=chosen)
    return plan.page, [(layer.name, list(layer.paths)) for layer in plan.layers]


def portrait_lines_shuffled():
    """A line-drawing portrait (Grace Hopper, outline only), its order lost: the issue's loser."""
    from PIL import Image

    rgb = np.asarray(Image.open(_sample("grace_hopper.jpg")).convert("RGB"))
    page, layers = _plan_layers(rgb, "grace_hopper", hatch=False)
    return page, _shuffled(layers, 1)


def photo_shuffled():
    """pencilbot's own plan of skimage's coffee (hatching and edges), its order lost."""
    page, layers = _plan_layers(data.coffee(), "coffee")
    return page, _shuffled(layers, 0)


def hatching():
    """Three levels of diagonal hatching over coffee's dark parts (hatched's method), scan order."""
    grey = data.coffee().mean(axis=2) / 255.0
    layout, (h, w) = _fit(grey), grey.shape
    lines, pitch = [], 1.0 / layout.mm_per_px
    corners = np.array([[0, 0], [w, 0], [0, h], [w, h]], float)
    for threshold, angle, spacing in ((0.75, 45, pitch), (0.5, 135, pitch), (0.25, 45, pitch / 2)):
        dark = grey < threshold
        direction = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])
        normal = np.array([-direction[1], direction[0]])
        t = np.arange((corners @ direction).min(), (corners @ direction).max(), 0.5)
        for offset in np.arange((corners @ normal).min(), (corners @ normal).max(), spacing):
            xy = offset * normal + t[:, None] * direction
            inside = (xy[:, 0] >= 0) & (xy[:, 0] < w) & (xy[:, 1] >= 0) & (xy[:, 1] < h)
            on = np.zeros(len(t), bool)
            on[inside] = dark[xy[inside, 1].astype(int), xy[inside, 0].astype(int)]
            edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(np.int8), [0]])))
            lines += [layout.px_to_mm(xy[[a, b]]) for a, b in zip(edges[::2], edges[1::2] - 1) if b > a]
    return layout.page, [("hatching", lines)]


def _contour_pieces(grey, levels, layout, piece: int = 30):
    pieces = []
    for level in levels:
        for contour in measure.find_contours(grey, level):
            xy = contour[:, ::-1]
            pieces += [
                layout.px_to_mm(xy[s : s + piece])
                for s in range(0, len(xy) - 1, piece - 1)
                if len(xy[s : s + piece]) > 1
            ]
    return pieces


def contours():
    """Iso-contours of coffee at 8 levels (linedraw's method), cut in pieces, in traced order."""
    grey = data.coffee().mean(axis=2) / 255.0
    layout = _fit(grey)
    return layout.page, [("contours", _contour_pieces(grey, np.linspace(0.15, 0.85, 8), layout))]


def topographic_map():
    """A contour map of matplotlib's Jacksboro fault elevation model, 20 levels, in traced order."""
    dem = np.load(_sample("jacksboro_fault_dem.npz"))["elevation"].astype(float)
    layout = _fit(dem)
    levels = np.linspace(dem.min(), dem.max(), 22)[1:-1]
    return layout.page, [("map", _contour_pieces(dem, levels, layout, piece=1000))]


def line_drawing():
    """Canny edges of skimage's camera traced into polylines (an edge tracer's output), traced order."""
    grey = data.camera() / 255.0
    edges = feature.canny(grey, sigma=2.0).astype(float)
    layout = _fit(grey)
    return layout.page, [("edges", _contour_pieces(edges, [0.5], layout, piece=1000))]


def text():
    """A page of Hershey text from vpype's ``text`` command (futural, wrapped, justified)."""
    import vpype_cli

    words = (
        "The quick brown fox jumps over the lazy dog while plotters draw every line twice as "
        "fast when the pen travels less between strokes. "
    ) * 14
    document = vpype_cli.execute(f'text -f futural -s 5mm -w 180mm -j -p 15mm 20mm "{words}"')
    lines = [np.column_stack([line.real, line.imag]) * 25.4 / 96 for line in document.layers[1]]
    return A4, [("text", [np.column_stack([p[:, 0], A4.height - p[:, 1]]) for p in lines])]


def stippling():
    """Weighted stipples of skimage's camera: 12 000 dots, each a small hexagon, in the random
    order a rejection sampler places them."""
    grey = transform.rescale(data.camera() / 255.0, 0.5)
    layout = _fit(grey)
    rng = np.random.default_rng(7)
    h, w = grey.shape
    candidates = rng.uniform([0, 0], [w, h], (60_000, 2))
    keep = (
        rng.random(len(candidates))
        < (1 - grey[candidates[:, 1].astype(int), candidates[:, 0].astype(int)]) ** 2
    )
    centres = layout.px_to_mm(candidates[keep][:12_000])
    ring = 0.3 * np.exp(2j * np.pi * np.arange(7) / 6)
    hexagon = np.column_stack([ring.real, ring.imag])
    return layout.page, [("stipples", [c + hexagon for c in centres])]


def flow_field():
    """Generative art: 1 500 streamlines of a smooth vector field, each from a random seed, in
    the order they were grown."""
    rng = np.random.default_rng(11)
    seeds = rng.uniform([20, 20], [190, 277], (1500, 2))
    lines = []
    for seed in seeds:
        p, line = seed.copy(), [seed.copy()]
        for _ in range(rng.integers(10, 60)):
            angle = np.sin(p[0] / 23.0) * 2.0 + np.cos(p[1] / 31.0) * 2.0
            p = p + 0.8 * np.array([np.cos(angle), np.sin(angle)])
            if not (15 <= p[0] <= 195 and 15 <= p[1] <= 282):
                break
            line.append(p.copy())
        if len(line) > 1:
            lines.append(np.array(line))
    return A4, [("flow", lines)]


def random_lines():
    """Random segments as vpype's ``random`` makes them (4 000, up to 5 mm each way, over 18 x 26 cm;
    seeded here, as vpype's are not)."""
    rng = np.random.default_rng(3)
    a = rng.uniform([15, 20], [195, 280], (4000, 2))
    b = a + rng.uniform(-5, 5, a.shape)
    return A4, [("random", [np.array([p, q]) for p, q in zip(a, b)])]


def portrait_astronaut_shuffled():
    """A second line-drawing portrait (skimage's astronaut, outline only), its order lost."""
    page, layers = _plan_layers(data.astronaut(), "astronaut", hatch=False)
    return page, _shuffled(layers, 2)


DRAWINGS = {
    "portrait_lines_shuffled": portrait_lines_shuffled,
    "portrait_astronaut_shuffled": portrait_astronaut_shuffled,
    "photo_shuffled": photo_shuffled,
    "hatching": hatching,
    "contours": contours,
    "topographic_map": topographic_map,
    "line_drawing": line_drawing,
    "text": text,
    "stippling": stippling,
    "flow_field": flow_field,
    "random_lines": random_lines,
}
