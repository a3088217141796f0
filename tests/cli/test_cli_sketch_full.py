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
        capture_output=True,
        text=True,
        timeout=120,
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


@pytest.fixture(scope="module")
def hand_texture(tmp_path_factory):
    """A 'scanned' pencil texture: dark diagonal hatching strokes on off-white paper, as a PNG."""
    import cv2

    rng = np.random.default_rng(7)
    paper = np.full((180, 240), 235, np.uint8)
    for x, y, pressure in rng.uniform((-60, 0, 60), (240, 180, 160), (220, 3)):
        cv2.line(paper, (int(x), int(y + 40)), (int(x + 40), int(y)), int(pressure), 1, cv2.LINE_AA)
    path = tmp_path_factory.mktemp("tex") / "hatching.png"
    Image.fromarray(paper).save(path)
    return path


def test_a_hand_drawn_texture_file_changes_the_sketch(photo, hand_texture, tmp_path, capsys):
    plain, textured = tmp_path / "plain.png", tmp_path / "textured.png"
    assert main(["sketch", str(photo), "-o", str(plain), "-q"]) == 0
    assert main(["sketch", str(photo), "-o", str(textured), "--texture", str(hand_texture), "-q"]) == 0
    a, b = (np.asarray(Image.open(p)).astype(float) for p in (plain, textured))
    assert np.abs(a - b).mean() > 3
    # The file is the library's result with that texture, and its tone stays the photo's.
    expected = sketch(load_image(photo), texture=hand_texture).result
    np.testing.assert_array_equal(b.astype(np.uint8), as_png_pixels(expected))
    assert abs(a.mean() - b.mean()) < 15


@pytest.mark.parametrize(
    ("make_texture", "message"),
    [
        (lambda d: d / "missing.png", "no such file"),
        (lambda d: (d / "notes.png").write_text("not an image") and d / "notes.png", "not an image file"),
        (lambda d: (d / "empty.png").write_bytes(b"") or d / "empty.png", "empty"),
    ],
    ids=["missing", "not-an-image", "empty"],
)
def test_an_unreadable_texture_is_one_message(photo, tmp_path, capsys, make_texture, message):
    texture, out = make_texture(tmp_path), tmp_path / "x.png"
    assert main(["sketch", str(photo), "-o", str(out), "--texture", str(texture)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error: pencil texture:") and message in err
    assert "Traceback" not in err and err.count("\n") == 1
    assert not out.exists()


def test_stroke_gamma_and_width_options(photo, tmp_path):
    outputs = {}
    for name, extra in {
        "plain": [],
        "gamma": ["--stroke-gamma", "3"],
        "wide": ["--stroke-width", "3"],
    }.items():
        outputs[name] = tmp_path / f"{name}.png"
        assert main(["sketch", str(photo), "-o", str(outputs[name]), "--lines-only", "-q", *extra]) == 0
    plain, gamma, wide = (
        np.asarray(Image.open(outputs[n])).astype(float) for n in ("plain", "gamma", "wide")
    )
    # γ > 1 darkens strokes without moving them; a wider stroke covers more paper.
    assert gamma.mean() < plain.mean() - 1 and np.all(gamma <= plain + 1)
    assert (wide < 128).sum() > 1.5 * (plain < 128).sum()


@pytest.mark.parametrize(
    "extra",
    [
        ["--stroke-gamma", "0"],
        ["--stroke-gamma", "nan"],
        ["--stroke-width", "0.1"],
        ["--stroke-width", "500"],
        ["--lines-only", "--texture", "x.png"],
    ],
)
def test_bad_stroke_and_texture_options_are_one_message(photo, tmp_path, capsys, extra):
    out = tmp_path / "x.png"
    assert main(["sketch", str(photo), "-o", str(out), *extra]) == 2
    err = capsys.readouterr().err
    flag = next(a for a in extra if a.startswith("--") and a != "--lines-only")
    assert err.startswith("pencilbot: error:") and flag in err and "Traceback" not in err
    assert not out.exists()
