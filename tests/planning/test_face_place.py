"""Each face at its place in the sheet's order of tones (planning/face_place.py): a face drawn
lighter than the sheet draws the same tones elsewhere is drawn darker, one darker is left alone."""

from __future__ import annotations

import numpy as np
import pytest

from pencilbot.paths import Paths
from pencilbot.planning.face_place import MOST, place_gains
from pencilbot.planning.layout import Layout
from pencilbot.planning.plan import Page
from pencilbot.planning.shading import FACE_TONE, shade

PEN = 0.5
SIZE = 160


def _layout() -> Layout:
    return Layout.fit((SIZE, SIZE), Page(100.0, 100.0, margin=10.0))  # 80 mm, 0.5 mm a pixel


def _photo() -> np.ndarray:
    """A ramp of darkness from left (0.05) to right (0.95), the same down every column."""
    return np.tile(np.linspace(0.05, 0.95, SIZE, dtype=np.float32), (SIZE, 1))


def _face(x0: int, x1: int, y0: int = 40, y1: int = 120) -> np.ndarray:
    face = np.zeros((SIZE, SIZE), np.float32)
    face[y0:y1, x0:x1] = 1.0
    return face


def _sheet(photo: np.ndarray, faces: np.ndarray, drawn_to: np.ndarray) -> Paths:
    """Everything the sheet draws: hatching to ``photo``, the faces' runs to ``drawn_to``."""
    layers = shade(photo, _layout(), Paths.empty(), pen_width=PEN, dithered=faces, face_darkness=drawn_to)
    assert any(layer.name == FACE_TONE and len(layer.paths) for layer in layers)
    return Paths.concat(layer.paths for layer in layers)


def _gains(factor: float, faces: np.ndarray) -> np.ndarray | None:
    photo = _photo()
    drawn_to = np.clip(photo * factor, 0.0, 1.0)
    sheet = _sheet(photo, faces, drawn_to)
    return place_gains(sheet, photo, faces, drawn_to, _layout(), pen_width=PEN, cut=0.05)


def test_a_face_drawn_lighter_than_its_place_is_raised_and_nothing_else():
    faces = _face(60, 100)
    gains = _gains(0.5, faces)
    assert gains is not None
    inside = gains[faces > 0.5]
    assert np.all(inside == inside[0])  # one factor over the face
    assert 1.4 <= inside[0] <= MOST
    assert np.all(gains[faces <= 0.5] == 1.0)


def test_raised_to_its_place_the_face_lays_what_the_sheet_lays_at_its_tones():
    faces = _face(60, 100)
    photo = _photo()
    light = np.clip(photo * 0.8, 0.0, 1.0)
    gains = _gains(0.8, faces)
    assert gains is not None

    def ink_ratio(drawn_to: np.ndarray) -> float:
        """The runs' ink in the face over the hatching's in the same columns above and below it."""
        from pencilbot.planning.dither import ink_on_grid
        from pencilbot.planning.flow import Grid

        sheet = _sheet(photo, faces, drawn_to)
        grid = Grid(_layout().drawing_box, 1.0)  # a millimetre's cells: the face 20 by 40
        ink = ink_on_grid(sheet, grid, PEN)
        return float(ink[22:58, 32:48].mean() / np.concatenate([ink[2:16, 32:48], ink[64:78, 32:48]]).mean())

    before, after = ink_ratio(light), ink_ratio(np.clip(light * gains, 0.0, 1.0))
    assert before < 0.8  # 0.71 as measured
    assert 0.9 <= after <= 1.1  # 0.97


@pytest.mark.parametrize("factor", [1.4, 2.0])
def test_a_face_drawn_darker_than_its_place_is_left_as_it_is(factor):
    assert _gains(factor, _face(60, 100)) is None


def test_each_face_gets_its_own_factor():
    faces = np.maximum(_face(20, 50), _face(110, 140))
    photo = _photo()
    drawn_to = photo.copy()
    drawn_to[:, :80] *= 0.4  # the left face drawn far lighter than its place, the right one darker
    drawn_to[:, 80:] = np.clip(drawn_to[:, 80:] * 1.5, 0.0, 1.0)
    sheet = _sheet(photo, faces, drawn_to)
    gains = place_gains(sheet, photo, faces, drawn_to, _layout(), pen_width=PEN, cut=0.05)
    assert gains is not None
    assert gains[80, 35] > 1.3 and gains[80, 125] == 1.0


def test_no_faces_or_only_face_give_nothing():
    photo = _photo()
    sheet = _sheet(photo, _face(60, 100), photo)
    assert place_gains(sheet, photo, np.zeros_like(photo), photo, _layout(), pen_width=PEN, cut=0.05) is None
    everywhere = np.ones_like(photo)
    assert place_gains(sheet, photo, everywhere, photo, _layout(), pen_width=PEN, cut=0.05) is None


def test_faces_over_most_of_the_drawing_are_left_as_they_are():
    # A close portrait: the sheet outside the face is too little to set the order by.
    assert _gains(0.5, _face(10, 150, 10, 150)) is None


def test_a_plan_s_shading_draws_a_face_lighter_than_its_place_darker():
    from pencilbot.imaging.faces import Face, face_mask, portrait_darkness
    from pencilbot.imaging.io import image_from_array
    from pencilbot.imaging.pencil import sketch
    from pencilbot.planning.dither import LEVELS
    from pencilbot.planning.one_pen import one_pen_shading
    from pencilbot.planning.sketch_tone import sketch_darkness
    from pencilbot.planning.stages import stages_of
    from pencilbot.planning.style import Style

    grey = np.tile(np.linspace(235, 40, SIZE).astype(np.uint8), (SIZE, 1))
    drawing = sketch(image_from_array(np.dstack([grey] * 3), source="ramp"))
    layout = _layout()
    tone = sketch_darkness(drawing, 1.0 / layout.mm_per_px)
    faces = [Face(60.0, 50.0, 40.0, 1.0)]
    dithered = face_mask(drawing.gray.shape, faces)
    hatching = stages_of(Style(), drawing.line).hatching
    assert hatching is not None
    shade, faces_at = one_pen_shading(
        drawing, tone, layout, hatching, Paths.empty(), dithered, dithered, faces, 63.0
    )
    layers, scale = shade(1.0)
    runs = next(layer.paths for layer in layers if layer.name == FACE_TONE)
    as_asked = hatching.faces(
        portrait_darkness(tone, 1.0 - drawing.gray, faces),
        layout,
        Paths.empty(),
        paper=1.0 - drawing.gray,
        dithered=dithered,
        level=LEVELS[0],
        face_scale=scale**0.5,
    )
    more = runs.drawn_lengths().sum() / as_asked.drawn_lengths().sum()
    assert more > 1.1
    # and the budgets' later drawings of the runs keep the face at its place
    assert np.array_equal(faces_at(LEVELS[0], scale).points, runs.points)
