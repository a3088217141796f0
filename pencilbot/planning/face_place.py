"""Each face at its place in the sheet's order of tones: a face drawn lighter than the sheet draws
the same tones of the photo elsewhere is drawn darker.

The faces' runs (:mod:`pencilbot.planning.dither`) leave their lightest skin bare and lay the rest
at the level's ink; the hatching around them lays its own tone, scaled by the sheet's budgets. In
a group photo of mid-grey faces the runs come out lighter than the hatching lays the same tones
of the photo in the walls and clothes around them (the faces' mean rank residual against the
photo down to −0.11 on the face set, ``bench/residuals.py``), and a face's darker half then
falls among the sheet's lighter tones. Here the sheet as first shaded is rendered at 1 mm, the
darkness it lays outside the faces is read as a function of the photo's rank, and a face drawn
lighter than that function gives at its photo tones has its darkness raised by one factor, so
that its mean comes to it: the runs lay (d·f − cut)/(1 − cut), linear in f past the cut.

A face drawn darker than its place is left as it is: lighter, its lit skin would fall further
under the runs' cut and be drawn as bare paper, which is where lit faces already lose their
figure (docs/faces.md, twelfth round). Measured (the factors found from the plot, both ways and
darker only): docs/faces.md, thirteenth round.
"""

from __future__ import annotations

import cv2
import numpy as np

from pencilbot.paths import Paths
from pencilbot.planning.dither import ink_on_grid
from pencilbot.planning.flow import Grid, gaussian, sample_image

#: Cell (mm) of the grid the sheet is judged on, and the blur (mm) it is judged at: the 1 mm at
#: which the whole sheet and its faces are compared with the photo.
CELL = 0.5
BLUR = 1.0
#: Bins of the photo's rank over which the sheet's darkness outside the faces is averaged.
BINS = 40
#: A face lighter than its place by less than this share of it is left as it is.
SLACK = 0.03
#: Most a face's darkness is raised by.
MOST = 2.0
#: Faces covering more of the drawing than this are left as they are: the sheet outside them is
#: too little to set the order of tones by (Tom_Cruise_avp_2014_4, a face over three quarters of
#: the picture as planned, was raised by 1.28 and its whole box fell 0.983 -> 0.922).
MOST_SHARE = 0.5


def place_gains(
    sheet: Paths,
    photo: np.ndarray,
    dithered: np.ndarray,
    darkness: np.ndarray,
    layout,
    *,
    pen_width: float,
    cut: float,
) -> np.ndarray | None:
    """The factor each face's darkness is raised by, on the picture's grid (1 elsewhere), or None
    when every face is at its place or darker, or the faces cover more than ``MOST_SHARE`` of the
    drawing.

    Parameters
    ----------
    sheet : Paths
        Everything the sheet draws, as first shaded: contours, hatching and the faces' runs.
    photo : (H, W) float array in [0, 1]
        Darkness of the photo (1 − luma), on the layout's image grid.
    dithered : (H, W) float array in [0, 1]
        The faces drawn as runs (where above ½); each connected part is one face.
    darkness : (H, W) float array in [0, 1]
        The darkness the runs were drawn to (before their cut).
    layout : Layout
    pen_width : float
        mm.
    cut : float
        Darkness the runs leave bare (:class:`~pencilbot.planning.dither.RunLevel`'s ``lightest``).
    """
    count, labels = cv2.connectedComponents((np.asarray(dithered) > 0.5).astype(np.uint8))
    if count < 2:
        return None
    grid = Grid(layout.drawing_box, CELL)
    # Each cell's face: the label of the picture's pixel at its centre (0: none).
    px = np.rint(layout.mm_to_px(grid.centres().reshape(-1, 2))).astype(np.int64)
    rows, cols = np.clip(px[:, 1], 0, labels.shape[0] - 1), np.clip(px[:, 0], 0, labels.shape[1] - 1)
    cells = labels[rows, cols].reshape(grid.shape)
    if not cells.any() or np.mean(cells > 0) > MOST_SHARE:
        return None
    ink = gaussian(ink_on_grid(sheet, grid, pen_width), BLUR / CELL)
    tone = gaussian(sample_image(photo, layout, grid), BLUR / CELL)
    order = np.argsort(tone, axis=None, kind="stable")
    rank = np.empty(tone.size, np.float32)
    rank[order] = (np.arange(tone.size) + 0.5) / tone.size
    bins = np.minimum((rank.reshape(tone.shape) * BINS).astype(np.int64), BINS - 1)
    outside = cells == 0
    totals = np.bincount(bins[outside], ink[outside], BINS)
    counts = np.bincount(bins[outside], minlength=BINS)
    known = counts > 0
    centres = (np.arange(BINS) + 0.5) / BINS
    curve = np.interp(centres, centres[known], totals[known] / counts[known])  # darkness at each rank
    # Per face: its ink, the sheet's darkness at its ranks (both on the grid), its mean darkness.
    sizes = np.bincount(cells.ravel(), minlength=count)
    size = np.maximum(sizes, 1)
    drawn = np.bincount(cells.ravel(), ink.ravel(), count) / size
    placed = np.bincount(cells.ravel(), curve[bins].ravel(), count) / size
    pixels = np.maximum(np.bincount(labels.ravel(), minlength=count), 1)
    mean = np.bincount(labels.ravel(), np.asarray(darkness, np.float64).ravel(), count) / pixels
    low = placed <= drawn * (1.0 + SLACK)
    low |= (mean <= cut) | (sizes == 0)
    low[0] = True  # (not a face)
    if low.all():
        return None
    ratio = placed / np.maximum(drawn, 1e-3)
    share = cut / np.maximum(mean, 1e-6)
    factor = np.where(low, 1.0, np.minimum(MOST, ratio * (1.0 - share) + share)).astype(np.float32)
    return factor[labels]
