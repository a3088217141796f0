"""`pencilbot sketch --lines-only` end to end on a real photo file, and its error paths."""

import subprocess
import sys

import numpy as np
import pytest
import skimage.data
from PIL import Image

from pencilbot.cli import main


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    path = tmp_path_factory.mktemp("in") / "astronaut.jpg"
    Image.fromarray(skimage.data.astronaut()).save(path, quality=92)
    return path


def test_console_script_writes_line_drawing_and_stages(photo, tmp_path):
    out = tmp_path / "lines.png"
    stages = tmp_path / "stages"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pencilbot.cli",
            "sketch",
            str(photo),
            "-o",
            str(out),
            "--lines-only",
            "--stages",
            str(stages),
            "--line-length",
            "8",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "stroke length 8 px" in proc.stdout
    drawing = np.asarray(Image.open(out))
    assert drawing.shape == (512, 512) and drawing.dtype == np.uint8
    # A line drawing: mostly paper, some dark strokes, not a plain grey photo.
    assert np.median(drawing) > 235 and drawing.min() < 40 and (drawing < 128).mean() < 0.1
    assert sorted(p.name for p in stages.iterdir()) == [
        "denoised.png",
        "edges.png",
        "gradient.png",
        "lines.png",
    ]
    np.testing.assert_array_equal(np.asarray(Image.open(stages / "lines.png")), drawing)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temp files left


def test_quiet_and_default_length(photo, tmp_path, capsys):
    out = tmp_path / "q.png"
    assert main(["sketch", str(photo), "-o", str(out), "--lines-only", "-q"]) == 0
    assert capsys.readouterr().out == ""
    assert Image.open(out).size == (512, 512)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--max-pixels", "1000"], "--downscale"),
        (["--line-length", "0"], "--line-length"),
        (["--line-length", "100000"], "--line-length"),  # was a MemoryError traceback
        (["--color"], "--color"),
    ],
)
def test_bad_options_clear_error(photo, tmp_path, capsys, extra, message):
    out = tmp_path / "x.png"
    assert main(["sketch", str(photo), "-o", str(out), "--lines-only", *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error:") and message in err and "Traceback" not in err
    assert not out.exists()


def test_downscale_flag(photo, tmp_path):
    out = tmp_path / "small.png"
    assert (
        main(
            [
                "sketch",
                str(photo),
                "-o",
                str(out),
                "--lines-only",
                "--max-pixels",
                "10000",
                "--downscale",
                "-q",
            ]
        )
        == 0
    )
    w, h = Image.open(out).size
    assert w * h <= 10000 and w == h


def missing(folder):
    return folder / "missing.png"


def empty(folder):
    (folder / "empty.png").write_bytes(b"")
    return folder / "empty.png"


def text(folder):
    (folder / "text.jpg").write_text("hello")
    return folder / "text.jpg"


@pytest.mark.parametrize(
    ("make_input", "message"), [(missing, "no such file"), (empty, "empty"), (text, "not an image")]
)
def test_bad_input_clear_error(tmp_path, capsys, make_input, message):
    assert main(["sketch", str(make_input(tmp_path)), "-o", str(tmp_path / "o.png"), "--lines-only"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_bad_output_paths(photo, tmp_path, capsys):
    assert main(["sketch", str(photo), "-o", str(tmp_path / "no" / "o.png"), "--lines-only"]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["sketch", str(photo), "-o", str(tmp_path / "o.xyz"), "--lines-only"]) == 2
    assert "image format" in capsys.readouterr().err


def test_unwritable_target_leaves_nothing(photo, tmp_path, capsys):
    blocked = tmp_path / "taken.png"
    blocked.mkdir()  # a folder where the image should go: the final rename must fail cleanly
    assert main(["sketch", str(photo), "-o", str(blocked), "--lines-only"]) == 2
    assert "cannot write" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken.png"]


def test_colour_is_spelt_either_way():
    from pencilbot.commands import build_parser

    for spelling in ("--color", "--colour"):
        assert build_parser().parse_args(["sketch", "in.png", "-o", "out.png", spelling]).color is True
    assert build_parser().parse_args(["sketch", "in.png", "-o", "out.png"]).color is False
