"""Faces are found where they are, and only there (the model ships with scikit-image)."""

from __future__ import annotations

import numpy as np
from skimage import data
from skimage.color import rgb2gray

from pencilbot.imaging.faces import Face, face_mask, find_faces


def test_the_astronauts_face_is_found_where_it_is():
    faces = find_faces(rgb2gray(data.astronaut()).astype(np.float32))
    assert len(faces) == 1
    face = faces[0]
    # Her face: eyes near row 110, between columns 190 and 260, chin near row 170.
    assert 150 <= face.x <= 195 and 45 <= face.y <= 90 and 80 <= face.size <= 120
    # Found at any size: the picture is searched at most SEARCH_SIDE px, boxes come back in its pixels.
    big = np.kron(rgb2gray(data.astronaut()).astype(np.float32), np.ones((3, 3), np.float32))
    (large,) = find_faces(big)
    assert abs(large.x - 3 * face.x) < 15 and abs(large.size - 3 * face.size) < 20


def test_a_cats_cheek_and_a_cup_are_not_faces():
    # The cascade answers on chelsea's cheek on one side only: the mirror check drops it.
    assert find_faces(rgb2gray(data.chelsea()).astype(np.float32)) == []
    assert find_faces(rgb2gray(data.coffee()).astype(np.float32)) == []
    assert find_faces(np.ones((100, 100), np.float32)) == []
    assert find_faces(np.ones((10, 10), np.float32)) == []


def test_the_mask_covers_the_face_and_fades_out():
    mask = face_mask((200, 300), [Face(100, 50, 80, 1.0)])
    assert mask.dtype == np.float32 and mask.min() >= 0 and mask.max() <= 1
    assert mask[50 + 36, 140] == 1.0  # between the eyes
    assert mask[0, 0] == 0.0 and mask[199, 299] == 0.0
    soft = mask[(mask > 0) & (mask < 1)]
    assert soft.size > 0  # a soft edge, not a cut
    assert np.all(face_mask((50, 50), []) == 0)


def test_a_portraits_tone_shades_the_skin_keeps_highlights_white_and_one_order():
    from pencilbot.imaging.faces import PORTRAIT_HIGHLIGHT, face_squares, portrait_darkness

    rng = np.random.default_rng(0)
    photo = rng.uniform(0.1, 0.9, (120, 160)).astype(np.float32)
    tone = np.where(photo < 0.5, 0.0, photo - 0.5).astype(np.float32)  # the pencil tone: light skin is paper
    faces = [Face(40, 20, 60, 1.0)]
    lifted = portrait_darkness(tone, photo, faces)
    assert np.all(lifted >= tone)  # never lighter than the pencil tone
    skin = (photo > 0.3) & (photo < 0.5)
    assert lifted[skin].min() > 0.0  # light skin is shaded, not paper
    inside = face_squares(photo.shape, faces)
    highlights = photo <= np.quantile(photo[inside], PORTRAIT_HIGHLIGHT)
    assert np.all(lifted[highlights] == tone[highlights])  # the lightest stay as the tone had them
    # One curve for the whole sheet: the same photo and tone darkness, inside a face or not,
    # are shaded alike (a wall as grey as the cheek is drawn as the cheek).
    order = np.argsort(photo, axis=None)
    assert np.all(np.diff(lifted.ravel()[order]) >= -1e-6)
    assert np.array_equal(portrait_darkness(tone, photo, []), tone)
