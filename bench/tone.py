"""How closely the tone follows the 3-layer pencil model: GML against SML.

For several skimage.data photos, prints JSON with the L1 distance between the cumulative
histograms of a tone image and of the model (Σ|ΔCDF| / 255: the earth mover's distance in tone
units, 0 = identical, 1 = all mass at the wrong end), for

* ``tone``   — the tone target J itself (what histogram specification controls), and
* ``result`` — the finished drawing R = L · T (texture and lines spread the histogram again),

plus the textbook 8-level case's L1 histogram error, and for each of the two which method is
closer on which photo (``closer``: the paper's claim is GML's). Run: ``python bench/tone.py``.
"""

from __future__ import annotations

import json

import numpy as np
import skimage.data

from pencilbot.imaging.gmed import edge_map
from pencilbot.imaging.io import image_from_array
from pencilbot.imaging.strokes import line_drawing
from pencilbot.imaging.texture import pencil_texture, texture_map
from pencilbot.imaging.tone import LEVELS, gml_lut, pencil_histogram, sml_lut, tone_target

PHOTOS = ("camera", "coffee", "astronaut", "chelsea", "rocket", "moon")


def cdf_distance(tone: np.ndarray, model: np.ndarray) -> float:
    levels = np.rint(np.clip(tone, 0, 1) * (LEVELS - 1)).astype(np.int64).ravel()
    hist = np.bincount(levels, minlength=LEVELS) / levels.size
    return float(np.abs(np.cumsum(hist) - np.cumsum(model)).sum() / (LEVELS - 1))


def textbook() -> dict[str, float]:
    source = np.array([0.19, 0.25, 0.21, 0.16, 0.08, 0.06, 0.03, 0.02])
    target = np.zeros(8)
    target[[3, 5, 7]] = [0.2, 0.5, 0.3]
    errors = {}
    for name, lut in (("gml", gml_lut), ("sml", sml_lut)):
        mapped = np.bincount(lut(source, target), weights=source, minlength=8)
        errors[f"{name}_hist_l1"] = round(float(np.abs(mapped - target).sum()), 4)
    return errors


def main() -> None:
    model = pencil_histogram()
    photos = {}
    for name in PHOTOS:
        image = image_from_array(getattr(skimage.data, name)(), source=name)
        lines = line_drawing(edge_map(image.gray)).drawing
        texture = pencil_texture(image.shape)
        row = {"size": f"{image.shape[1]}x{image.shape[0]}"}
        for method in ("gml", "sml"):
            J = tone_target(image.gray, method=method)
            R = lines * texture_map(J, texture).T
            row[method] = {
                "tone": round(cdf_distance(J, model), 4),
                "result": round(cdf_distance(R, model), 4),
            }
        row["photo"] = round(cdf_distance(image.gray, model), 4)
        photos[name] = row
    closer = {
        stage: {
            method: [name for name, row in photos.items() if row[method][stage] < row[other][stage]]
            for method, other in (("gml", "sml"), ("sml", "gml"))
        }
        for stage in ("tone", "result")
    }
    print(
        json.dumps(
            {
                "metric": "L1 of CDFs / 255 vs the 3-layer model (52:37:11)",
                "textbook": textbook(),
                "closer": closer,
                "photos": photos,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
