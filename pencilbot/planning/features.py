"""A face's contours: only its dark features are drawn with the pen (:func:`features_only`); in
a face drawn as runs, none, or only its dark lines (:func:`outside_faces`); and which strokes lie
mostly in a mask (a face, its dithered runs)."""

from __future__ import annotations

import cv2
import numpy as np

from pencilbot.imaging.faces import face_squares
from pencilbot.paths import Paths
from pencilbot.planning.layout import Layout

#: In a face, a contour is drawn with the pen only where it is a dark feature: along a line darker
#: than its surroundings (the photo's darkness at a FEATURE_BLUR mm blur at least FEATURE_VALLEY
#: above its FEATURE_SURROUND mm blur: eyes, brows, nostrils, the mouth's line, wrinkles, glasses'
#: frames), or darker than FEATURE_SHARE of the face's pixels (hair, a shadow). A contour on light
#: skin (a cheek against a pale wall) would lay a dark rim where the face is light; its form is
#: the hatching's. Measured (bench/fidelity.py, face rho@1mm / @0.5mm, every contour -> features
#: only): astronaut 0.931 / 0.838 -> 0.939 / 0.845, grace_hopper 0.948 / 0.868 -> 0.958 / 0.878
#: (and 1.2 min less plotting); messi5's 17 mm face 0.841 / 0.665 -> 0.828 / 0.661 (its dither).
FEATURE_SHARE = 0.7
FEATURE_BLUR = 0.5
FEATURE_SURROUND = 2.0
FEATURE_VALLEY = 0.02
#: A face drawn as runs (:mod:`pencilbot.planning.dither`) keeps, with the style's ``face_lines``,
#: the contours along a line this much darker than its surroundings (as FEATURE_VALLEY): the lids
#: and lashes, the brows, the mouth's line, the nostrils; not the jaw or the hairline, whose rims
#: the runs draw as tone. Measured (bench/fidelity.py --faceset; faces from 25 mm / 12-25 mm
#: meeting their bars, of 20 / 38, grace_hopper not run): no contours 18 / 32; every contour the
#: face keeps elsewhere 12 / 26 (the outlined jaw and lens-shaped lips of the last rounds); lines
#: from 0.04 16 / 27, from 0.08 too few to read (a brow, half a mouth). Looked at (face-api's demo photos): the three
#: laughing women of sample1 are blank ovals of runs without them, faces with eyes and a mouth
#: with them (docs/faces.md, stop 42).
FACE_LINE_VALLEY = 0.04


def features_only(
    strokes: Paths, layout: Layout, photo: np.ndarray, important: np.ndarray, faces: list
) -> Paths:
    """The edge strokes less those in a face that are no dark feature (see FEATURE_SHARE).

    Parameters
    ----------
    strokes : Paths
        Edge paths, page mm.
    layout : Layout
    photo : (H, W) float array
        Photo darkness 1 − luma on the layout's image grid.
    important : (H, W) float array in [0, 1]
        The faces' mask (:func:`~pencilbot.imaging.faces.face_mask`); a path is in a face when
        its points' mean mask value is over one half.
    faces : list of Face

    Returns
    -------
    Paths
        ``strokes`` without those, in order.
    """
    if not len(strokes):
        return strokes
    in_face = mostly_in(strokes, layout, important)
    dark, valley = _valleys(photo, layout)
    level = float(np.quantile(dark[face_squares(dark.shape, faces)], FEATURE_SHARE))
    light = _path_means(strokes, layout, dark) < level
    flat = _path_means(strokes, layout, valley) < FEATURE_VALLEY
    return strokes.take(np.flatnonzero(~(in_face & light & flat)))


def outside_faces(
    strokes: Paths, layout: Layout, photo: np.ndarray, runs: np.ndarray, *, lines: bool
) -> Paths:
    """The edge strokes not mostly in ``runs`` (the faces drawn as dithered runs, which draw
    their features as tone); with ``lines``, also those in it along a dark line of the ``photo``
    (darkness 1 − luma on the layout's image grid; see FACE_LINE_VALLEY), in order."""
    if not len(strokes):
        return strokes
    keep = ~mostly_in(strokes, layout, runs)
    if lines:
        keep |= _path_means(strokes, layout, _valleys(photo, layout)[1]) >= FACE_LINE_VALLEY
    return strokes.take(np.flatnonzero(keep))


def _valleys(photo: np.ndarray, layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """The photo's darkness at a FEATURE_BLUR mm blur, and how much darker that is than at a
    FEATURE_SURROUND mm blur (a dark line's valley)."""
    photo = np.asarray(photo, np.float32)
    dark = cv2.GaussianBlur(photo, (0, 0), FEATURE_BLUR / layout.mm_per_px)
    return dark, dark - cv2.GaussianBlur(photo, (0, 0), FEATURE_SURROUND / layout.mm_per_px)


def mostly_in(strokes: Paths, layout: Layout, mask: np.ndarray) -> np.ndarray:
    """(P,) bool: the strokes whose points' mean of ``mask`` (on the image grid) is above ½."""
    return _path_means(strokes, layout, mask) > 0.5


def _path_means(strokes: Paths, layout: Layout, values: np.ndarray) -> np.ndarray:
    """Mean of ``values`` (on the image grid) at each path's points, nearest pixel."""
    if not len(strokes):
        return np.zeros(0)
    px = np.rint(layout.mm_to_px(strokes.points)).astype(np.intp)
    cols, rows = np.clip(px[:, 0], 0, values.shape[1] - 1), np.clip(px[:, 1], 0, values.shape[0] - 1)
    return np.bincount(strokes.owners(), values[rows, cols], minlength=len(strokes)) / strokes.lengths
