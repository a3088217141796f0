"""`pencilbot plan` end to end: a real image file in, an SVG in mm and a preview PNG out."""

import re
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image
from skimage import data
from skimage.transform import resize

from pencilbot.cli import main
from pencilbot.export.svg_read import read_svg


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    """A small real photo (coffee at 1/3 size) written as a PNG file."""
    rgb = resize(data.coffee(), (134, 200), anti_aliasing=True)
    path = tmp_path_factory.mktemp("in") / "coffee.png"
    Image.fromarray((rgb * 255).astype(np.uint8)).save(path)
    return path


def _svg_size(path):
    head = path.read_text()[:2000]
    width = re.search(r'width="([\d.]+)mm"', head)
    height = re.search(r'height="([\d.]+)mm"', head)
    return float(width[1]), float(height[1])


def test_plan_writes_an_svg_in_mm_and_a_preview(photo, tmp_path, capsys):
    out, preview = tmp_path / "plan.svg", tmp_path / "preview.png"
    code = main(["plan", str(photo), "-o", str(out), "--preview", str(preview), "--orientation", "portrait"])
    assert code == 0
    assert _svg_size(out) == (210.0, 297.0)
    plan = read_svg(out)
    names = [layer.name for layer in plan.layers]
    assert names[-1] == "edges" and any(name.startswith("hatch") for name in names)
    with Image.open(preview) as png:
        assert png.size == (827, 1170)  # A4 at 100 dpi
        ink = 255 - np.asarray(png.convert("L"), dtype=float)
    assert ink.mean() > 5  # something is drawn ...
    assert ink[:100].max() == 0 and ink[:, :50].max() == 0  # ... but nothing in the margins
    assert "plan.svg" in capsys.readouterr().out


def test_page_orientation_margin_and_pen_reach_the_plan(photo, tmp_path):
    out = tmp_path / "plan.svg"
    args = ["plan", str(photo), "-o", str(out), "--page", "A5", "--orientation", "auto"]
    assert main([*args, "--margin", "10", "--pen-width", "0.3", "--style", "outline", "-q"]) == 0
    assert _svg_size(out) == (210.0, 148.0)  # the photo is wide: landscape A5
    plan = read_svg(out)
    assert [layer.name for layer in plan.layers] == ["edges"]
    pts = np.concatenate(plan.paths())
    assert pts.min() >= 10 - 1e-6 and pts[:, 0].max() <= 200 + 1e-6 and pts[:, 1].max() <= 138 + 1e-6


def test_the_time_budget_reaches_the_plan_and_a_style_file_may_set_it(photo, tmp_path):
    out = tmp_path / "plan.svg"
    assert main(["plan", str(photo), "-o", str(out), "--style", "outline", "--time-budget", "2", "-q"]) == 0
    assert read_svg(out).meta["time_budget"] == "2"
    style = tmp_path / "slow.toml"
    style.write_text("hatch = false\ntime_budget = 1.5\n")
    assert main(["plan", str(photo), "-o", str(out), "--style", str(style), "-q"]) == 0
    assert read_svg(out).meta["time_budget"] == "1.5"


def test_a_style_file_is_accepted(photo, tmp_path):
    style = tmp_path / "mine.toml"
    style.write_text("hatch_angles = [0]\npen_width = 0.8\n")
    out = tmp_path / "plan.svg"
    assert main(["plan", str(photo), "-o", str(out), "--style", str(style), "-q"]) == 0
    assert [layer.name for layer in read_svg(out).layers] == ["hatch1-0", "edges"]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--style", "nope"], "no style named 'nope'"),
        (["--pen-width", "-1"], "--pen-width must be at least 0.05"),
        (["--pen-width", "nan"], "--pen-width must be"),
        (["--pen-width", "inf"], "--pen-width must be"),
        (["--margin", "nan"], "margin"),
        (["--max-pixels", "0", "--downscale"], "--max-pixels must be at least 1"),
        (["--page", "B7"], "unknown page size"),
        (["--margin", "200"], "margin"),
        (["--time-budget", "0.5"], "--time-budget must be at least 1 and at most 4 times the default"),
        (["--time-budget", "nan"], "--time-budget must be"),
    ],
)
def test_bad_options_give_one_clear_error_and_no_file(photo, tmp_path, capsys, extra, message):
    out = tmp_path / "plan.svg"
    assert main(["plan", str(photo), "-o", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1
    assert not out.exists()


def test_bad_input_files_give_one_clear_error(tmp_path, capsys):
    out = tmp_path / "plan.svg"
    assert main(["plan", str(tmp_path / "missing.jpg"), "-o", str(out)]) == 2
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not a picture")
    assert main(["plan", str(junk), "-o", str(out)]) == 2
    assert main(["plan", str(junk), "-o", str(tmp_path / "plan.pdf")]) == 2
    err = capsys.readouterr().err
    assert err.count("pencilbot: error:") == 3 and "Traceback" not in err
    assert not out.exists()


def test_the_console_script_runs(photo, tmp_path):
    out = tmp_path / "plan.svg"
    done = subprocess.run(
        [sys.executable, "-m", "pencilbot.cli", "plan", str(photo), "-o", str(out), "--style", "outline"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert out.stat().st_size > 0


def test_a_preview_in_a_missing_folder_is_refused_before_the_plan_is_written(photo, tmp_path, capsys):
    out = tmp_path / "plan.svg"
    assert main(["plan", str(photo), "-o", str(out), "--preview", str(tmp_path / "nope" / "p.png")]) == 2
    err = capsys.readouterr().err
    assert "folder" in err and "nope" in err and "does not exist" in err and err.count("\n") == 1
    assert not out.exists()


def test_verbose_tells_where_the_time_goes(photo, tmp_path, caplog):
    assert main(["plan", str(photo), "-o", str(tmp_path / "plan.svg"), "-v"]) == 0
    said = [r.getMessage() for r in caplog.records if r.name.startswith("pencilbot")]
    assert any(m.startswith("sketch of") and "edges" in m and "beta" in m for m in said)
    assert any(m.startswith("layer edges:") and "paths, ordered in" in m for m in said)


def test_faces_are_listed_in_the_svg_and_no_faces_switches_them_off(tmp_path):
    photo = tmp_path / "astronaut.png"
    Image.fromarray(data.astronaut()[::2, ::2]).save(photo)
    found, off = tmp_path / "found.svg", tmp_path / "off.svg"
    assert main(["plan", str(photo), "-o", str(found), "--page", "A5"]) == 0
    assert main(["plan", str(photo), "-o", str(off), "--page", "A5", "--no-faces"]) == 0
    x, y, size = (float(v) for v in read_svg(found).meta["faces"].split(","))
    assert 75 <= x <= 100 and 20 <= y <= 45 and 40 <= size <= 60  # her face, in px of the photo as planned
    assert read_svg(off).meta["faces"] == "off"
    assert read_svg(found).paths().points.shape != read_svg(off).paths().points.shape
