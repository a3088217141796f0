"""pencilbot's HP-GL renders in hp2xx (the Debian package, an independent HP-GL interpreter) as
the virtual HP-GL plotter draws it: the two pictures, cropped to the ink and brought to one
size, correlate closely; a drawing that differs (mirrored) does not."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from scipy import ndimage
from skimage import io as skio
from skimage.transform import resize

from pencilbot.export.hpgl import write_hpgl
from pencilbot.machine.profile import load_profile
from pencilbot.paths import Paths
from pencilbot.planning.fidelity import pearson
from pencilbot.planning.plan import Layer, Page, Plan
from sim.hpgl.board import HpglBoard

pytestmark = pytest.mark.skipif(
    shutil.which("hp2xx") is None, reason="hp2xx is not installed (apt-get install hp2xx)"
)
SIZE = (300, 420)


def _plan(mirror: bool = False) -> Plan:
    rng = np.random.default_rng(7)
    t = np.linspace(0, 2 * np.pi, 60)
    paths = [
        np.column_stack([150 + r * np.cos(t + r / 9), 105 + 0.6 * r * np.sin(2 * t)])
        for r in range(10, 90, 8)
    ]
    paths += [np.array([[x, 30.0], [x + 20 * rng.random(), 80.0]]) for x in np.arange(30, 120, 6)]
    if mirror:
        paths = [np.column_stack([300 - p[:, 0], p[:, 1]]) for p in paths]
    return Plan(Page(297, 210, margin=0.0, name="A4"), [Layer("lines", Paths.of(paths))])


def _ink(picture: np.ndarray) -> np.ndarray:
    """Ink darkness cropped to its bounding box, resized to SIZE, blurred a little."""
    grey = picture[..., :3].mean(axis=2) / 255.0 if picture.ndim == 3 else picture / 255.0
    ink = grey < 0.5
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    ink = ink[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1].astype(float)
    return ndimage.gaussian_filter(resize(ink, SIZE, anti_aliasing=True), 2.0)


def _simulated(path, profile, tmp_path) -> np.ndarray:
    board = HpglBoard(profile)
    data = path.read_bytes()
    for at in range(0, len(data), 512):  # never more than the buffer holds (it is unforgiving)
        board.receive(data[at : at + 512])
        board.finish()
    assert board.overflows == 0 and board.error == 0
    from pencilbot.render import Canvas

    bed = profile.bed
    canvas = Canvas(bed.width, bed.height, dpi=100, pen_width=0.3)
    canvas.draw_paths(board.bed_strokes())
    return canvas.to_image()


def _hp2xx(path, tmp_path) -> np.ndarray:
    out = tmp_path / f"{path.stem}-hp2xx.png"
    subprocess.run(
        ["hp2xx", "-q", "-m", "png", "-d", "100", "-p", "3", "-f", str(out), str(path)],
        check=True,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        timeout=60,
    )
    return skio.imread(out)


def test_hp2xx_draws_our_hpgl_as_the_simulator_does(tmp_path):
    profile = load_profile("hp7475a")
    ours, mirrored = tmp_path / "ours.hpgl", tmp_path / "mirrored.hpgl"
    write_hpgl(_plan(), profile, ours)
    write_hpgl(_plan(mirror=True), profile, mirrored)
    simulated = _ink(_simulated(ours, profile, tmp_path))
    assert pearson(simulated, _ink(_hp2xx(ours, tmp_path))) > 0.9
    assert pearson(simulated, _ink(_hp2xx(mirrored, tmp_path))) < 0.6  # the comparison can fail
