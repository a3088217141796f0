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
from pencilbot.planning.build import plan_from_sketch
from pencilbot.planning.features import mostly_in
from pencilbot.planning.layout import Layout, page_size
from pencilbot.planning.resolution import at_plot_resolution
from pencilbot.planning.shading import FACE_TONE
from pencilbot.planning.style import Style

FAST = Style(order_rounds=2)


@pytest.fixture(scope="module")
def astronaut():
    image = image_from_array(data.astronaut()[::2, ::2].copy(), source="astronaut")
    # On A4 her face is about 32 mm, drawn in runs.
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


def test_a_face_is_drawn_closer_to_the_photo_and_the_rest_as_without(astronaut):
    from pencilbot.planning.fidelity import plotted_darkness, region_rho

    drawing, page, on, off = astronaut
    layout = Layout.fit(drawing.gray.shape, page)
    height, width = drawing.gray.shape
    x, y, size = (float(v) for v in on.meta["faces"].split(","))
    region = (x / width, y / height, size / width, size / height)

    def rho(plan, sigma):
        ink = plotted_darkness(plan.paths(), layout.drawing_box, pen_width=plan.layers[-1].pen_width)
        return region_rho(ink, 1.0 - drawing.gray, region, sigma_mm=sigma)

    # Her face follows the photo more closely with the face's own drawing, at both scales.
    assert rho(on, 1.0) > rho(off, 1.0) + 0.03 and rho(on, 0.5) > rho(off, 0.5) + 0.07
    # Far from the face the hatching is the faceless picture's: as long strokes, as much ink.
    far = (0, drawing.gray.shape[0] * 0.75, drawing.gray.shape[1], drawing.gray.shape[0])

    def far_lengths(plan):
        return np.array(
            [
                np.linalg.norm(np.diff(p, axis=0), axis=1).sum()
                for layer in plan.layers
                if layer.role == "hatch"
                for p in layer.paths
                if _inside([p], layout, far) == len(p)
            ]
        )

    # (The dashes of a light tone shift with any change of the tone elsewhere, which family is
    # traced where: the mean stroke is the same within a fifth, the ink within a tenth. Not the
    # median: its strokes are dashes and long lines, about as many of each, and a few strokes
    # more of one kind moved it by 30 %, at the same count and ink within 1 %.)
    assert far_lengths(on).mean() == pytest.approx(far_lengths(off).mean(), rel=0.2)
    assert far_lengths(on).sum() == pytest.approx(far_lengths(off).sum(), rel=0.1)


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
        assert np.array_equal(a.paths.points, b.paths.points) and np.array_equal(
            a.paths.offsets, b.paths.offsets
        )
    # And on the astronaut, with a face, the two differ.
    assert not all(np.array_equal(a.paths.points, b.paths.points) for a, b in zip(on.layers, off.layers))


def test_in_a_face_only_dark_features_keep_their_contours():
    from pencilbot.imaging.faces import Face, face_mask
    from pencilbot.planning.features import features_only

    page = page_size("A5", "portrait", (200, 200), 10.0)
    layout = Layout.fit((200, 200), page)
    photo = np.tile(
        np.linspace(0.2, 0.4, 200, dtype=np.float32)[:, None], (1, 200)
    )  # light skin, shaded downwards
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


def test_a_face_drawn_in_runs_keeps_only_its_dark_lines_and_those_only_with_face_lines():
    from pencilbot.planning.features import outside_faces

    page = page_size("A5", "portrait", (200, 200), 10.0)
    layout = Layout.fit((200, 200), page)
    photo = np.full((200, 200), 0.3, np.float32)  # even skin
    photo[100:103, 60:140] = 0.8  # a mouth's line
    photo[60:75, 60:140] = 0.7  # a broad shadow: dark, but no line (its middle is as dark as its rim)
    mask = np.zeros((200, 200), np.float32)
    mask[40:160, 40:160] = 1.0

    def stroke(row, c0=70, c1=130):
        return layout.px_to_mm(np.array([[c0, row], [(c0 + c1) / 2, row], [c1, row]], float))

    mouth, shadow, cheek, outside = stroke(101), stroke(67), stroke(130), stroke(10, 5, 40)
    strokes = Paths.of([mouth, shadow, cheek, outside])
    assert outside_faces(strokes, layout, photo, mask, lines=False) == Paths.of([outside])
    assert outside_faces(strokes, layout, photo, mask, lines=True) == Paths.of([mouth, outside])


def test_face_lines_draws_her_eyes_and_mouth_over_the_runs(astronaut):
    drawing, page, plain, _ = astronaut
    lined = plan_from_sketch(drawing, page, Style(order_rounds=2, face_lines=True))
    layout = Layout.fit(drawing.gray.shape, page)
    faces = find_faces(drawing.rgb)
    mask = face_mask(drawing.gray.shape, faces)
    assert not mostly_in(plain.layer("edges").paths, layout, mask).any()
    edges = lined.layer("edges").paths
    inside = edges.take(np.flatnonzero(mostly_in(edges, layout, mask)))
    assert len(inside) >= 3  # her eyes, brows, mouth
    # They lie on the face's dark lines, not on its skin: darker under the pen than the face is.
    darkness = 1.0 - drawing.gray
    px = np.rint(layout.mm_to_px(inside.points)).astype(int)
    under = darkness[px[:, 1].clip(0, mask.shape[0] - 1), px[:, 0].clip(0, mask.shape[1] - 1)].mean()
    assert under > darkness[mask > 0.5].mean() + 0.1
    # The face is still drawn in runs beside them.
    assert len(lined.layer(FACE_TONE).paths) > 0


@pytest.mark.parametrize("page_name", ["100x100", "A4"])
def test_a_face_small_or_large_is_drawn_in_dithered_runs(page_name):
    image = image_from_array(data.astronaut()[::2, ::2].copy(), source="astronaut")
    page = page_size(page_name, "portrait", image.shape, 10.0)
    drawing = sketch(at_plot_resolution(image, page, FAST.pen_width))
    plan = plan_from_sketch(drawing, page, FAST)
    layout = Layout.fit(drawing.gray.shape, page)
    faces = find_faces(drawing.rgb)
    assert len(faces) == 1
    assert (faces[0].size * layout.mm_per_px < 25) == (page_name == "100x100")  # both sizes are tried
    mask = face_mask(drawing.gray.shape, faces)
    layers = {layer.name: layer for layer in plan.layers}
    # The face's runs lie in the face; its contours are gone (the runs draw its features).
    runs = layers[FACE_TONE].paths
    # (The runs' cells are sampled on their own grid, this at the nearest pixel: a run on the
    # mask's rim may read a little under ½ here.)
    assert len(runs) and mostly_in(runs, layout, np.clip(mask * 1.1, 0, 1)).all()
    assert not mostly_in(layers["edges"].paths, layout, mask).any()
    # The hatching leaves the face to the runs: none of its points well inside.
    hatching = Paths.concat(
        layer.paths for layer in plan.layers if layer.role == "hatch" and layer.name != FACE_TONE
    )
    px = np.rint(layout.mm_to_px(hatching.points)).astype(int)
    assert not np.any(mask[px[:, 1].clip(0, mask.shape[0] - 1), px[:, 0].clip(0, mask.shape[1] - 1)] > 0.9)
