"""`pencilbot demo` end to end: every promised file exists, is valid, and they agree."""

from __future__ import annotations

import json

import numpy as np
import pytest
from gcodeparser import parse_gcode_lines
from skimage import io as skio

from pencilbot.cli import main
from pencilbot.export.svg_read import read_svg
from pencilbot.machine.bed import Placement
from pencilbot.machine.profile import load_profile

PROFILE = "grbl-servo-a4"


def run_demo(out, capsys) -> dict:
    assert main(["demo", "-o", str(out), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def pen_down_paths(text: str, profile) -> list[np.ndarray]:
    """Pen-down polylines (machine mm) as a third-party parser reads the G-code."""
    down_s = float(profile.pen.down)
    paths, current, pen, pos = [], None, False, (0.0, 0.0)
    for line in parse_gcode_lines(text):
        word = f"{line.command[0]}{line.command[1]}"
        if word == "M3":
            pen = float(line.params.get("S", -1)) == down_s
            current = [pos] if pen else None
            if current is not None:
                paths.append(current)
        elif word in ("G0", "G1") and ("X" in line.params or "Y" in line.params):
            pos = (float(line.params.get("X", pos[0])), float(line.params.get("Y", pos[1])))
            if word == "G1":
                assert pen, "a G1 drawing move with the pen up"
                current.append(pos)
            else:
                assert not pen, "a G0 travel with the pen down"
    return [np.array(p) for p in paths]


def length(path: np.ndarray) -> float:
    return float(np.hypot(*np.diff(path, axis=0).T).sum())


def test_demo_writes_valid_outputs_that_agree(tmp_path, capsys):
    summary = run_demo(tmp_path, capsys)
    for name in ("sketch.png", "plan.svg", "preview.png", "drawing.gcode", "plot.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert summary["source"] == "skimage.data.coffee"

    sketch = skio.imread(tmp_path / "sketch.png")
    assert sketch.ndim == 2 and 0 < sketch.mean() < 255  # a drawing, not a blank or black page

    plan = read_svg(tmp_path / "plan.svg")
    assert [layer.name for layer in plan.layers][-1] == "edges"
    profile = load_profile(PROFILE)
    placement = Placement.on_bed(plan.page, profile.bed)
    drawn = pen_down_paths((tmp_path / "drawing.gcode").read_text(), profile)
    planned = plan.paths()
    assert len(drawn) == len(planned) == summary["paths"]
    on_page = [placement.to_page(p) for p in drawn]
    starts = np.array([p[0] for p in on_page]), np.array([p[0] for p in planned])
    ends = np.array([p[-1] for p in on_page]), np.array([p[-1] for p in planned])
    np.testing.assert_allclose(*starts, atol=2e-3)  # G-code rounds to 0.001 mm, SVG to 0.001 mm
    np.testing.assert_allclose(*ends, atol=2e-3)
    total_drawn, total_planned = sum(map(length, on_page)), sum(map(length, planned))
    assert total_drawn == pytest.approx(total_planned, rel=1e-3)
    assert total_planned / 1000 == pytest.approx(summary["pen_down_m"], abs=0.01)

    preview = 1 - skio.imread(tmp_path / "preview.png").astype(float) / 255
    plot = 1 - skio.imread(tmp_path / "plot.png").astype(float) / 255
    assert plot.shape == preview.shape
    assert plot.mean() > 0.02  # the plotter drew something
    assert np.corrcoef(plot.ravel(), preview.ravel())[0, 1] > 0.99
    assert plot.mean() == pytest.approx(preview.mean(), rel=0.01)
    assert summary["simulated_s"] == pytest.approx(summary["estimated_s"], rel=0.15)
    # Line fidelity is to the raster's lines, which are bold and keep texture's strokes; since
    # issue 23 a contour is one pen line and a painting's scribble is trimmed (the plan follows
    # the photo better): coffee 0.83, was 0.89.
    assert summary["line_fidelity_r"] >= 0.78 and summary["tone_fidelity_r"] >= 0.90


def test_demo_with_a_broken_photo_is_one_clear_error(tmp_path, capsys):
    bad = tmp_path / "photo.jpg"
    bad.write_bytes(b"\xff\xd8\xff\xe0 not really a jpeg")
    assert main(["demo", str(bad), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "photo.jpg" in err and "Traceback" not in err
    assert not (tmp_path / "out" / "drawing.gcode").exists()


def test_demo_refuses_an_unknown_profile_before_any_work(tmp_path, capsys):
    assert main(["demo", "--profile", "no-such-plotter", "-o", str(tmp_path / "o")]) == 2
    assert "no-such-plotter" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_blank_photo_gives_valid_json_and_no_warning(tmp_path, capsys):
    # Nothing to draw: the correlations are undefined and must come out as null, not NaN
    # (which is not JSON), and without numpy's divide warning on stderr.
    blank = tmp_path / "blank.png"
    skio.imsave(blank, np.full((32, 48), 255, np.uint8), check_contrast=False)
    assert main(["demo", str(blank), "--style", "outline", "-o", str(tmp_path / "o"), "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out, parse_constant=lambda name: pytest.fail(f"{name} in JSON"))
    assert summary["paths"] == 0 and summary["plot_vs_preview_r"] is None
    assert "Warning" not in captured.err
