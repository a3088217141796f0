"""`pencilbot sketch` with tone and texture, end to end on real photo files."""

import subprocess
import sys

import numpy as np
import pytest
import skimage.data
from PIL import Image

from pencilbot.cli import main
from pencilbot.imaging.io import load_image
from pencilbot.imaging.pencil import sketch


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    path = tmp_path_factory.mktemp("in") / "coffee.png"
    Image.fromarray(skimage.data.coffee()).save(path)
    return path


def as_png_pixels(array):
    return np.round(np.clip(array, 0, 1) * 255).astype(np.uint8)


def test_grey_sketch_file_is_the_library_result(photo, tmp_path, capsys):
    out = tmp_path / "coffee-sketch.png"
    assert main(["sketch", str(photo), "-o", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    written = Image.open(out)
    assert written.mode == "L" and written.size == (600, 400)
    expected = sketch(load_image(photo)).result
    np.testing.assert_array_equal(np.asarray(written), as_png_pixels(expected))


def test_colour_sketch_file_keeps_colour(photo, tmp_path):
    out = tmp_path / "colour.png"
    assert main(["sketch", str(photo), "-o", str(out), "--color", "-q"]) == 0
    written = np.asarray(Image.open(out))
    assert written.shape == (400, 600, 3)
    np.testing.assert_array_equal(written, as_png_pixels(sketch(load_image(photo), color=True).result))
    # Coffee's red cup stays red: not a grey drawing copied into three channels.
    assert np.mean(written[..., 0].astype(int) - written[..., 2]) > 15


def test_seed_and_line_length_options(photo, tmp_path, capsys):
    first, second = tmp_path / "a.png", tmp_path / "b.png"
    assert main(["sketch", str(photo), "-o", str(first), "--texture-seed", "3", "--line-length", "9"]) == 0
    assert "stroke length 9 px" in capsys.readouterr().out
    assert main(["sketch", str(photo), "-o", str(second), "--texture-seed", "4", "--line-length", "9"]) == 0
    a, b = (np.asarray(Image.open(p)).astype(int) for p in (first, second))
    assert np.abs(a - b).mean() > 2  # another texture
    assert main(["sketch", str(photo), "-o", str(second), "--texture-seed", "3", "--line-length", "9"]) == 0
    np.testing.assert_array_equal(np.asarray(Image.open(second)), a)  # same seed, same file


def test_stages_include_tone_texture_beta_and_T(photo, tmp_path):
    stages = tmp_path / "stages"
    assert main(["sketch", str(photo), "-o", str(tmp_path / "s.png"), "--stages", str(stages), "-q"]) == 0
    names = sorted(p.stem for p in stages.glob("*.png"))
    assert names == sorted(["denoised", "gradient", "edges", "lines", "tone", "texture", "beta", "T"])
    drawn = sketch(load_image(photo))
    for name, array in [("tone", drawn.tone), ("texture", drawn.texture), ("T", drawn.T)]:
        np.testing.assert_array_equal(np.asarray(Image.open(stages / f"{name}.png")), as_png_pixels(array))
    beta = np.asarray(Image.open(stages / "beta.png"))
    assert beta.max() == 255  # scaled to its peak: more passes, brighter
    assert np.corrcoef(beta.ravel(), drawn.beta.ravel())[0, 1] > 0.99


def test_console_script_on_a_jpeg(tmp_path):
    photo = tmp_path / "chelsea.jpg"
    Image.fromarray(skimage.data.chelsea()).save(photo, quality=90)
    out = tmp_path / "chelsea-sketch.jpg"
    proc = subprocess.run(
        [sys.executable, "-m", "pencilbot.cli", "sketch", str(photo), "-o", str(out), "--color"],
        capture_output=True, text=True, timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    written = np.asarray(Image.open(out))
    assert written.shape == (300, 451, 3)
    # A pencil drawing: mostly light paper with graphite, not the photo.
    assert np.median(written) > 150


def test_negative_texture_seed_is_a_clear_error(photo, tmp_path, capsys):
    out = tmp_path / "x.png"
    assert main(["sketch", str(photo), "-o", str(out), "--texture-seed", "-1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error:") and "--texture-seed" in err and "Traceback" not in err
    assert not out.exists()
