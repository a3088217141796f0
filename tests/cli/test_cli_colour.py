"""Colour from the command line: --pens for plan, export (--split-pens) and simulate, bad pen sets
refused in one message. Real photos, real files, the virtual plotter over the real driver."""

from __future__ import annotations

import numpy as np
import pytest
from gcodeparser import parse_gcode_lines
from PIL import Image
from skimage import data

from pencilbot.cli import main
from pencilbot.export.svg import write_svg
from pencilbot.machine.pens import load_pens
from pencilbot.planning.plan import Layer, Page, Plan

DPI = 100
BED_HEIGHT = 310.0  # grbl-servo-a4


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    path = tmp_path_factory.mktemp("photo") / "coffee.png"
    Image.fromarray(data.coffee()[::4, ::4]).save(path)
    return path


def square(x: float, y: float, size: float = 20.0, step: float = 0.5) -> list[np.ndarray]:
    """A filled square of horizontal lines, bottom-left at (x, y) mm."""
    return [np.array([[x, y + k], [x + size, y + k]]) for k in np.arange(0.0, size, step)]


def two_pen_plan() -> Plan:
    pens = {pen.name: pen for pen in load_pens("cmyk").pens}
    layers = [
        Layer(f"{name}-hatch", square(x, 50.0), pen_width=0.5, role="hatch", pen=name, color=pens[name].color)
        for name, x in (("yellow", 20.0), ("magenta", 60.0), ("black", 100.0))
    ]
    return Plan(Page(150.0, 150.0, margin=10.0, name="test"), layers)


def colour_at(png, x: float, y: float, page_offset=(0.0, 0.0)) -> np.ndarray:
    rgb = np.asarray(Image.open(png).convert("RGB"), np.float64) / 255.0
    mm = DPI / 25.4
    row, col = int((BED_HEIGHT - y - page_offset[1]) * mm), int((x + page_offset[0]) * mm)
    return rgb[row - 3 : row + 4, col - 3 : col + 4].reshape(-1, 3).mean(axis=0)


def test_simulate_passes_every_pen_change_and_draws_each_pen_in_its_ink(tmp_path, capsys):
    svg, gcode, png = tmp_path / "plan.svg", tmp_path / "plan.gcode", tmp_path / "plot.png"
    write_svg(two_pen_plan(), svg)
    assert main(["export", str(svg), "-o", str(gcode), "-q"]) == 0
    assert gcode.read_text().count("M0 (pen change: insert") == 3
    assert main(["simulate", str(gcode), "-o", str(png), "--dpi", str(DPI)]) == 0
    assert "with 3 pens" in capsys.readouterr().out
    # The page is centred on the bed: find where by the black square, the only dark one.
    rgb = np.asarray(Image.open(png).convert("RGB"), np.float64) / 255.0
    dark = np.argwhere(rgb.max(axis=2) < 0.3)
    mm = DPI / 25.4
    top, left = dark.min(axis=0) / mm  # the black square's top-left corner on the bed image
    offset = (left - 100.0, (BED_HEIGHT - top) - 70.0)  # bed mm of page (0, 0), Y up
    yellow = colour_at(png, 30.0, 60.0, offset)
    magenta = colour_at(png, 70.0, 60.0, offset)
    assert yellow[2] < 0.3 and yellow[0] > 0.9 and yellow[1] > 0.8  # yellow: red and green, no blue
    assert magenta[1] < 0.3 and magenta[0] > 0.7  # magenta: red and blue, little green
    assert colour_at(png, 110.0, 60.0, offset).max() < 0.3
    assert colour_at(png, 50.0, 100.0, offset).min() > 0.99  # paper


def test_plan_and_export_with_a_pen_set_and_split_pens(tmp_path, photo, capsys):
    svg, preview = tmp_path / "plan.svg", tmp_path / "preview.png"
    assert (
        main(
            [
                "plan",
                str(photo),
                "--pens",
                "cmyk",
                "-o",
                str(svg),
                "--preview",
                str(preview),
                "--page",
                "120x90",
            ]
        )
        == 0
    )
    said = capsys.readouterr().out
    assert (
        "pens in load order: yellow, cyan, magenta, black" in said
        or "pens in load order: yellow, magenta, black" in said
    )
    picture = np.asarray(Image.open(preview))
    assert picture.ndim == 3 and np.ptp(picture.astype(int), axis=2).max() > 100  # in colour
    out = tmp_path / "job.gcode"
    assert (
        main(["export", str(photo), "--pens", "cmyk", "--page", "120x90", "--split-pens", "-o", str(out)])
        == 0
    )
    files = sorted(tmp_path.glob("job-*.gcode"))
    drawn = [f.stem.split("-", 2)[2] for f in files]
    assert drawn == [p for p in ["yellow", "cyan", "magenta", "black"] if p in drawn] and drawn[-1] == "black"
    assert len(drawn) >= 3 and not out.exists()
    for file in files:
        text = file.read_text()
        assert "M0" not in text and f": {file.stem.split('-', 2)[2]} #" in text
        assert list(parse_gcode_lines(text))  # gcodeparser reads it


def test_a_bad_pen_set_is_one_message_before_any_planning(tmp_path, photo, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[pen]]\nname = "teal"\ncolor = "teal"\nwidth = 0.5\n')
    assert main(["plan", str(photo), "--pens", str(bad), "-o", str(tmp_path / "x.svg")]) == 2
    err = capsys.readouterr().err
    assert "pen 1 ('teal') color" in err and "#rrggbb" in err and "Traceback" not in err
    assert not (tmp_path / "x.svg").exists()
    assert main(["export", str(photo), "--pens", "rainbow", "-o", str(tmp_path / "x.gcode")]) == 2
    assert "no pen set named 'rainbow'" in capsys.readouterr().err


def test_the_vpype_plugin_gives_one_layer_per_pen_in_load_order_with_its_ink(tmp_path, photo):
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    import vpype

    command = shutil.which("vpype", path=str(Path(sys.executable).parent))
    out = tmp_path / "vp.svg"
    done = subprocess.run(
        [command, "pencilbot", "--pens", "primaries", "--page", "120x90", str(photo), "write", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    document = vpype.read_multilayer_svg(str(out), quantization=0.1)
    found = [
        (layer.property("vp_name"), layer.property("vp_color").as_hex()[:7])
        for _, layer in sorted(document.layers.items())
    ]
    order = [(pen.name, pen.color) for pen in load_pens("primaries").load_order]
    assert found == [pen for pen in order if pen[0] in dict(found)] and found[-1] == order[-1]


def test_demo_with_cmyk_plots_in_colour_close_to_the_colour_sketch(tmp_path, photo, capsys):
    import json

    out = tmp_path / "demo"
    assert main(["demo", str(photo), "--pens", "cmyk", "--page", "120x90", "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pens"][-1] == "black" and set(summary["pens"]) <= {"yellow", "cyan", "magenta", "black"}
    assert summary["colour_delta_e00_3mm"] < 8.0
    assert summary["plot_vs_preview_r"] > 0.99  # the simulated plot, every pen change passed, is the plan
    for name in ("sketch.png", "preview.png", "plot.png"):
        picture = np.asarray(Image.open(out / name).convert("RGB")).astype(int)
        assert np.ptp(picture, axis=2).max() > 100, name  # in colour
    assert (out / "drawing.gcode").read_text().count("M0 (pen change: insert") == len(summary["pens"])
