"""Where a plan's order of tones departs from its photo's: the rank residual of the whole box.

The whole box's Spearman rho (``bench/fidelity.py``) is one number; this tells where it is lost.
Each photo is planned as ``bench/fidelity.py`` plans it, rendered over its drawing box at the
yardstick's resolution and blurred by its 1 mm, as is the photo's darkness and the sketch's.
Every pixel's rank (0 lightest, 1 darkest) in the plot minus its rank in the photo is the plot's
residual: above 0 the plot draws it darker than its place among the photo's tones, below 0
lighter. The same for the sketch. Per photo: rho of the plot and of the sketch, the mean squared
residual, its share in the photo's lightest and darkest ``BAND`` of pixels and inside the faces
found (the detector's squares, ``plan.meta["faces"]``), and the faces' mean residual (how much
darker or lighter they are drawn than their place).

With ``--maps DIR``, a PNG per photo: the blurred photo and the blurred plot above, the sketch's
residual and the plot's below (red: drawn darker than its place, blue: lighter).

At stop 46 (docs/faces.md, eleventh round) it showed where sample1's whole box (0.918) is lost:
three fifths of it in the photo's lightest 30 % (sparse dashes and bare paper, in no order at
1 mm), a seventh in its three faces (6.5 % of the box), drawn darker than their place.

Usage: ``python bench/residuals.py [--photos coffee,/path/to/photo.jpg] [--faceset] [--maps DIR]
[--time-budget X]``; prints JSON ``{photo: {...}, "missing": [...]}``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import cv2
import faceset
import fidelity
import numpy as np
from scipy import ndimage as ndi
from scipy.stats import rankdata

from pencilbot.errors import PencilbotError
from pencilbot.planning.fidelity import YARDSTICK_PX_PER_MM, YARDSTICK_SIGMA_MM, plotted_darkness, sketch_grey
from pencilbot.planning.layout import Layout
from pencilbot.render import write_png

#: The photo's lightest and darkest tones whose share of the residual is told: this share of its pixels.
BAND = 0.3
#: Height of each panel of a map, px.
PANEL = 500


def ranks(picture: np.ndarray) -> np.ndarray:
    """Each pixel's rank among the picture's, 0 (lightest) to 1 (darkest); ties share their mean."""
    return (rankdata(picture.ravel()) / picture.size).reshape(picture.shape).astype(np.float32)


def residuals(name: str, maps: Path | None = None) -> dict | None:
    """The rank residuals of photo ``name``'s plan and sketch (None when its package is missing)."""
    image = fidelity.photo(name)
    if image is None:
        return None
    plan, drawing, _, _ = fidelity.plan_photo(image)
    layout = Layout.fit(drawing.line.edges.shape, plan.page)
    plotted = plotted_darkness(plan.paths(), layout.drawing_box, pen_width=plan.pen_width)
    height, width = plotted.shape
    sigma = YARDSTICK_SIGMA_MM * YARDSTICK_PX_PER_MM
    sketch = sketch_grey(drawing)

    def blurred(darkness: np.ndarray) -> np.ndarray:
        darkness = cv2.resize(np.asarray(darkness, np.float32), (width, height), interpolation=cv2.INTER_AREA)
        return ndi.gaussian_filter(darkness, sigma)

    plot, photo, drawn = (
        ndi.gaussian_filter(plotted, sigma),
        blurred(1.0 - drawing.gray),
        blurred(1.0 - sketch),
    )
    from_photo, from_plot, from_sketch = ranks(photo), ranks(plot), ranks(drawn)
    plot_residual, sketch_residual = from_plot - from_photo, from_sketch - from_photo
    faces = _squares(fidelity.planned_faces(plan), drawing.gray.shape, (height, width))
    squared = plot_residual**2

    def share(where: np.ndarray) -> float:  # of the plot's squared residual
        return round(float(squared[where].sum() / max(squared.sum(), 1e-12)), 3)

    result = {
        "rho_plot": round(_rho(from_plot, from_photo), 3),
        "rho_sketch": round(_rho(from_sketch, from_photo), 3),
        "mean_sq_residual_plot": round(float(squared.mean()), 4),
        "mean_sq_residual_sketch": round(float((sketch_residual**2).mean()), 4),
        "lightest_share_of_residual": share(from_photo < BAND),
        "darkest_share_of_residual": share(from_photo > 1 - BAND),
        "faces_share_of_box": round(float(faces.mean()), 3),
        "faces_share_of_residual": share(faces),
        "faces_mean_residual_plot": round(float(plot_residual[faces].mean()), 3) if faces.any() else None,
        "faces_mean_residual_sketch": round(float(sketch_residual[faces].mean()), 3) if faces.any() else None,
    }
    if maps is not None:
        write_png(maps / f"{Path(name).name}.png", _map(photo, plot, sketch_residual, plot_residual))
    return result


def _rho(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman's rho of two rankings: Pearson's r of the ranks (ties at their mean rank)."""
    return float(np.corrcoef(a.ravel(), b.ravel())[0, 1])


def _squares(faces: list, image: tuple[int, int], box: tuple[int, int]) -> np.ndarray:
    """(H, W) bool over the drawing box: the squares of ``faces`` ((x, y, size) in px of the
    ``image`` as planned, :func:`fidelity.planned_faces`)."""
    inside = np.zeros(box, bool)
    scale_y, scale_x = box[0] / image[0], box[1] / image[1]
    for x, y, size in faces:
        r0, c0 = max(0, int(y * scale_y)), max(0, int(x * scale_x))
        inside[r0 : int((y + size) * scale_y), c0 : int((x + size) * scale_x)] = True
    return inside


def _map(
    photo: np.ndarray, plot: np.ndarray, sketch_residual: np.ndarray, plot_residual: np.ndarray
) -> np.ndarray:
    """The four panels: photo and plot (darkness as grey) above, the residuals (red / blue) below."""
    size = (round(PANEL * photo.shape[1] / photo.shape[0]), PANEL)

    def grey(darkness: np.ndarray) -> np.ndarray:
        small = cv2.resize(np.clip(1.0 - darkness, 0.0, 1.0), size, interpolation=cv2.INTER_AREA)
        return np.repeat((255 * small).astype(np.uint8)[..., None], 3, axis=2)

    def coloured(residual: np.ndarray) -> np.ndarray:
        d = np.clip(cv2.resize(residual, size, interpolation=cv2.INTER_AREA) / 0.5, -1.0, 1.0)
        red = np.where(d > 0, 1.0, 1.0 + d)  # a darker residual loses green and blue: red
        blue = np.where(d < 0, 1.0, 1.0 - d)
        return (255 * np.dstack([red, 1.0 - np.abs(d), blue])).astype(np.uint8)

    return np.vstack(
        [
            np.hstack([grey(photo), grey(plot)]),
            np.hstack([coloured(sketch_residual), coloured(plot_residual)]),
        ]
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", default="coffee,astronaut", help="comma-separated names or files")
    parser.add_argument("--faceset", action="store_true", help="the face set's photos (bench/faceset.py)")
    parser.add_argument("--maps", type=Path, default=None, help="folder for a PNG map per photo")
    parser.add_argument("--time-budget", type=float, default=None, help="the style's time_budget")
    args = parser.parse_args()
    if args.maps is not None:
        try:
            args.maps.mkdir(parents=True, exist_ok=True)
        except OSError as error:  # a file of that name, a read-only place
            parser.error(f"--maps {args.maps}: {error.strerror}; give a folder you can write to")
    if args.time_budget is not None:
        fidelity.STYLE_OVERRIDES["time_budget"] = args.time_budget
    names = list(faceset.PHOTOS) if args.faceset else [name for name in args.photos.split(",") if name]
    try:
        result = {name: residuals(name, args.maps) for name in names}
    except PencilbotError as error:  # an unreadable photo, a time budget out of range, a map not written
        parser.error(str(error))
    missing = [name for name, value in result.items() if value is None]
    print(json.dumps({**{k: v for k, v in result.items() if v is not None}, "missing": missing}, indent=1))


if __name__ == "__main__":
    main()
