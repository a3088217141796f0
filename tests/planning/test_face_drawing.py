"""Faces drawn with care (issue 23): denser, finer hatching in a face, a small face in dithered runs;
nothing of it without faces."""

from __future__ import annotations

import numpy as np
import pytest
from skimage import data

from pencilbot.imaging.faces import face_mask, find_faces
from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.pencil import sketch
from pencilbot.paths import Paths
from pencilbot.planning.build import DITHER_FACE, at_plot_resolution, mostly_in, plan_from_sketch
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.shading import FACE_TONE
from pencilbot.planning.style import Style

FAST = Style(order_rounds=2)


@pytest.fixture(scope="module")
def astronaut():
    image = image_from_array(data.astronaut()[::2, ::2].copy(), source="astronaut")
    # On A4 her face is about 35 mm: hatched, not dithered.
    page = page_size("A4", "portrait", image.shape, 10.0)
    drawing = sketch(at_plot_resolution(image, page, FAST.pen_width))
    on = plan_from_sketch(drawing, page, FAST)
    off = plan_from_sketch(drawing, page, Style(order_rounds=2, faces=False))
    return drawing, page, on, off


def _inside(paths, layout, box):
    """Points of ``paths`` whose image pixel lies in ``box`` (x0, y0, x1, y1), and their count."""
    pts = layout.mm_to_px(np.concatenate(list(paths)))
    x0, y0, x1, y1 = box
    return int(np.sum((pts[:, 0] >= x0) & (pts[:, 0] <= x1) & (pts[:, 1] >= y0) & (pts[:, 1] <= y1)))


def test_the_metadata_says_which_faces(astronaut):
    _, _, on, off = astronaut
    x, y, size = (float(v) for v in on.meta["faces"].split(","))
    assert 75 <= x <= 100 and 20 <= y <= 45 and 40 <= size <= 60  # her face, at half size
    assert off.meta["faces"] == "off"


def test_a_face_gets_finer_hatching_than_without(astronaut):
    drawing, page, on, off = astronaut
    layout = Layout.fit(drawing.gray.shape, page)
    x, y, size = (float(v) for v in on.meta["faces"].split(","))
    core = (x + 0.2 * size, y + 0.2 * size, x + 0.8 * size, y + 0.8 * size)

    def hatch_paths(plan):
        return [p for layer in plan.layers if layer.role == "hatch" for p in layer.paths]

    def dash_ends_in_face(plan):
        # (Points, not paths: neighbouring short dashes are zig-zagged into one path.)
        return sum(_inside([p], layout, core) for p in hatch_paths(plan))

    # Shorter dashes on closer lines: more dash ends in the face ...
    assert dash_ends_in_face(on) > 1.3 * dash_ends_in_face(off)
    # ... and far from the face the hatching is no finer: its strokes are as long. (A portrait's
    # tone is one curve for the whole sheet, so the suit and the wall may be shaded a little more.)
    far = (0, drawing.gray.shape[0] * 0.75, drawing.gray.shape[1], drawing.gray.shape[0])

    def far_lengths(plan):
        return np.array([np.linalg.norm(np.diff(p, axis=0), axis=1).sum()
                         for p in hatch_paths(plan) if _inside([p], layout, far) == len(p)])

    assert np.median(far_lengths(on)) == pytest.approx(np.median(far_lengths(off)), rel=0.25)
    assert far_lengths(on).sum() >= 0.95 * far_lengths(off).sum()


def test_without_faces_the_plan_is_the_plan_of_a_faceless_picture(astronaut):
    # faces = false plans exactly what a picture without a face would: same layers, same points.
    _drawing, page, on, off = astronaut
    coffee = image_from_array(data.coffee()[::3, ::3].copy())
    coffee_drawing = sketch(at_plot_resolution(coffee, page, FAST.pen_width))
    plain = plan_from_sketch(coffee_drawing, page, FAST)
    no_faces = plan_from_sketch(coffee_drawing, page, Style(order_rounds=2, faces=False))
    assert plain.meta["faces"] == "none" and no_faces.meta["faces"] == "off"
    assert [layer.name for layer in plain.layers] == [layer.name for layer in no_faces.layers]
    for a, b in zip(plain.layers, no_faces.layers, strict=True):
        assert np.array_equal(a.paths.points, b.paths.points) and np.array_equal(a.paths.offsets, b.paths.offsets)
    # And on the astronaut, with a face, the two differ.
    assert not all(np.array_equal(a.paths.points, b.paths.points) for a, b in zip(on.layers, off.layers))


def test_in_a_face_only_dark_features_keep_their_contours():
    from pencilbot.imaging.faces import Face, face_mask
    from pencilbot.planning.build import features_only

    page = page_size("A5", "portrait", (200, 200), 10.0)
    layout = Layout.fit((200, 200), page)
    photo = np.tile(np.linspace(0.2, 0.4, 200, dtype=np.float32)[:, None], (1, 200))  # light skin, shaded downwards
    photo[100:103, 60:140] = 0.8  # a dark line: a mouth
    faces = [Face(40, 40, 120, 1.0)]
    mask = face_mask(photo.shape, faces)

    def stroke(row, c0=70, c1=130):
        return layout.px_to_mm(np.array([[c0, row], [(c0 + c1) / 2, row], [c1, row]], float))

    mouth, cheek, outside = stroke(101), stroke(60), stroke(10, 5, 40)
    kept = features_only(Paths.of([mouth, cheek, outside]), layout, photo, mask, faces)
    # outside: as light and as even as the cheek, but no face: kept; a contour on even, light
    # skin goes to the hatching
    assert kept == Paths.of([mouth, outside])


def test_a_small_face_is_drawn_in_dithered_runs_a_larger_one_hatched(astronaut):
    drawing, page, on, _ = astronaut
    layout = Layout.fit(drawing.gray.shape, page)
    size = float(on.meta["faces"].split(",")[2])
    assert size * layout.mm_per_px > DITHER_FACE and FACE_TONE not in [layer.name for layer in on.layers]

    image = image_from_array(data.astronaut()[::2, ::2].copy(), source="astronaut")
    small_page = page_size("100x100", "portrait", image.shape, 10.0)
    small = sketch(at_plot_resolution(image, small_page, FAST.pen_width))
    plan = plan_from_sketch(small, small_page, FAST)
    layout = Layout.fit(small.gray.shape, small_page)
    faces = find_faces(small.gray)
    assert len(faces) == 1 and faces[0].size * layout.mm_per_px <= DITHER_FACE
    mask = face_mask(small.gray.shape, faces)
    layers = {layer.name: layer for layer in plan.layers}
    # The face's runs lie in the face; its contours are gone (the runs draw its features).
    runs = layers[FACE_TONE].paths
    assert len(runs) and mostly_in(runs, layout, mask).all()
    assert not mostly_in(layers["edges"].paths, layout, mask).any()
    # The hatching leaves the face to the runs: none of its points well inside.
    hatching = Paths.concat(layer.paths for layer in plan.layers if layer.role == "hatch" and layer.name != FACE_TONE)
    px = np.rint(layout.mm_to_px(hatching.points)).astype(int)
    assert not np.any(mask[px[:, 1].clip(0, mask.shape[0] - 1), px[:, 0].clip(0, mask.shape[1] - 1)] > 0.9)
