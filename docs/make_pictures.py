"""Make the README's picture rows: photo → pencil sketch → plan preview → simulated plot, and
the colour sketch → the colour plot with the cmyk pens.

Runs ``pencilbot demo`` on scikit-image's coffee photo, then ``pencilbot simulate --travel`` on
its G-code (the virtual plotter's drawing, pen-up travel in red), then ``pencilbot demo --pens
cmyk`` (its colour sketch and what the virtual plotter drew, pen by pen), and writes small PNGs
to docs/images/.
Usage: ``python docs/make_pictures.py``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import cv2
import numpy as np
from skimage import data

HERE = Path(__file__).resolve().parent
WIDTH = 360  # px per picture in the README row


def save_small(image: np.ndarray, path: Path) -> None:
    scale = WIDTH / image.shape[1]
    size = (WIDTH, round(image.shape[0] * scale))
    small = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    if small.ndim == 3:
        small = cv2.cvtColor(small, cv2.COLOR_RGB2BGR)
    cv2.imwrite(str(path), small)


def crop_to_ink(image: np.ndarray, pad: int = 20) -> np.ndarray:
    """The drawn part of a render, with a little paper around it."""
    rows, cols = np.nonzero((image if image.ndim == 2 else image.min(axis=2)) < 250)
    top, left = max(rows.min() - pad, 0), max(cols.min() - pad, 0)
    return image[top : rows.max() + pad, left : cols.max() + pad]


def main() -> None:
    out = HERE / "images"
    out.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "pencilbot.cli", "demo", "-o", tmp, "-q"], check=True)
        save_small(data.coffee(), out / "1-photo.png")
        save_small(cv2.imread(str(Path(tmp) / "sketch.png"), cv2.IMREAD_GRAYSCALE), out / "2-sketch.png")
        preview = cv2.imread(str(Path(tmp) / "preview.png"), cv2.IMREAD_GRAYSCALE)
        save_small(crop_to_ink(preview), out / "3-plan.png")
        plot = Path(tmp) / "plot-travel.png"
        subprocess.run(
            [
                sys.executable,
                "-m",
                "pencilbot.cli",
                "simulate",
                str(Path(tmp) / "drawing.gcode"),
                "-o",
                str(plot),
                "--travel",
                "-q",
            ],
            check=True,
        )
        bed = cv2.cvtColor(cv2.imread(str(plot)), cv2.COLOR_BGR2RGB)
        # The landscape sheet lies turned a quarter turn on the portrait bed: show it upright.
        save_small(crop_to_ink(np.rot90(bed, k=-1)), out / "4-plot.png")
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(
            [sys.executable, "-m", "pencilbot.cli", "demo", "--pens", "cmyk", "-o", tmp, "-q"], check=True
        )
        save_small(
            cv2.cvtColor(cv2.imread(str(Path(tmp) / "sketch.png")), cv2.COLOR_BGR2RGB),
            out / "5-colour-sketch.png",
        )
        plot = cv2.cvtColor(
            cv2.imread(str(Path(tmp) / "plot.png")), cv2.COLOR_BGR2RGB
        )  # on the page, upright
        save_small(crop_to_ink(plot), out / "6-colour-plot.png")
    print(f"wrote {sorted(p.name for p in out.glob('*.png'))} to {out}")


if __name__ == "__main__":
    main()
