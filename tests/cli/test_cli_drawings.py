"""Other tools' SVGs through the CLI: stat'ed in their own order, exported and simulated
reordered (or kept with --keep-order), and `pencilbot optimize` on them."""

import json
from pathlib import Path

import drawings
import numpy as np
import pytest
from gcodeparser import parse_gcode_lines

from pencilbot.cli import main
from pencilbot.export.svg_read import is_plan_svg, read_svg

# name → (write the file, options it needs to have a size)
DRAWINGS = {
    "inkscape": (lambda path: path.write_text(drawings.inkscape_svg()), []),
    "vpype": (drawings.vpype_svg, []),
    "hatched": (
        lambda path: path.write_text(drawings.hatched_svg(drawings.hatch_lines())),
        ["--svg-dpi", "96"],
    ),
    "linedraw": (
        lambda path: path.write_text(drawings.linedraw_svg(drawings.contour_lines())),
        ["--svg-dpi", "96"],
    ),
}


@pytest.fixture(params=list(DRAWINGS))
def drawing(request, tmp_path) -> tuple[Path, list[str]]:
    write, options = DRAWINGS[request.param]
    path = tmp_path / f"{request.param}.svg"
    write(path)
    return path, options


def stat(capsys, path, *options) -> dict:
    assert main(["stat", str(path), "--json", *options]) == 0
    return json.loads(capsys.readouterr().out)["total"]


def test_a_drawing_is_stated_exported_reordered_and_simulated(drawing, tmp_path, capsys):
    path, options = drawing
    as_written = stat(capsys, path, *options)
    read = read_svg(path, dpi=96 if options else None)
    assert as_written["paths"] == len(read.paths()) > 0

    gcode = tmp_path / "out.gcode"
    assert main(["export", str(path), "-o", str(gcode), *options]) == 0
    said = capsys.readouterr().out
    assert f"reordered: pen-up {as_written['pen_up_mm'] / 1000:.2f} →" in said
    parsed = list(parse_gcode_lines(gcode.read_text(encoding="ascii")))  # a third-party parser takes it all
    assert {c.command_str for c in parsed} <= {"G0", "G1", "G4", "G21", "G90", "G94", "M3", "M5"}
    reordered = stat(capsys, gcode)
    assert reordered["pen_up_mm"] <= as_written["pen_up_mm"] + 1e-6
    assert reordered["paths"] <= as_written["paths"]
    # Joins draw at most a pen width each: the ink is the same, give or take the joins.
    joins = as_written["paths"] - reordered["paths"]
    pen = max(layer.pen_width for layer in read.layers)
    assert (
        as_written["pen_down_mm"] - 0.01
        <= reordered["pen_down_mm"]
        <= as_written["pen_down_mm"] + joins * pen + 0.01
    )

    kept = tmp_path / "kept.gcode"
    assert main(["export", str(path), "-o", str(kept), "--keep-order", *options]) == 0
    assert "reordered" not in capsys.readouterr().out
    same = stat(capsys, kept)
    assert same["paths"] == as_written["paths"]
    assert same["pen_up_mm"] == pytest.approx(as_written["pen_up_mm"], abs=0.05)  # G-code rounds to µm

    png = tmp_path / "plot.png"
    assert main(["simulate", str(path), "-o", str(png), "-q", *options]) == 0
    assert png.stat().st_size > 1000
    assert main(["simulate", str(path), "-o", str(png), *options]) == 0
    out = capsys.readouterr().out
    assert "reordered: pen-up" in out and f"{reordered['paths']} pen-down strokes" in out


@pytest.mark.parametrize("command", ["stat", "export", "simulate", "optimize"])
def test_a_drawing_without_a_size_is_one_plain_message(tmp_path, capsys, command):
    path = tmp_path / "hatched.svg"
    path.write_text(drawings.hatched_svg(drawings.hatch_lines()))
    argv = [command, str(path)] + (
        [
            "-o",
            str(
                tmp_path
                / ("x.png" if command == "simulate" else "x.svg" if command == "optimize" else "x.gcode")
            ),
        ]
        if command != "stat"
        else []
    )
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no size on paper" in err and "--svg-dpi 96" in err and "--page A4" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hatched.svg"]


def test_a_page_fits_a_drawing_onto_the_sheet(tmp_path, capsys):
    path = tmp_path / "linedraw.svg"
    path.write_text(drawings.linedraw_svg(drawings.contour_lines()))
    out = tmp_path / "fitted.svg"
    assert main(["optimize", str(path), "-o", str(out), "--page", "A5", "--margin", "10"]) == 0
    plan = read_svg(out)
    assert (plan.page.width, plan.page.height, plan.page.margin) == (148, 210, 10)
    points = plan.paths().points
    assert points.min() >= 10 - 1e-3 and points[:, 0].max() <= 138 + 1e-3 and points[:, 1].max() <= 200 + 1e-3
    # linedraw's page runs from 0 to the drawing's far corner (a square here): it fills the
    # sheet's width, its far corner at the margin, scaled alike both ways.
    assert points[:, 0].max() == pytest.approx(138, abs=0.01)
    original = read_svg(path, dpi=96).paths().points
    span = lambda p: p.max(axis=0) - p.min(axis=0)  # noqa: E731
    np.testing.assert_allclose(
        span(points) / span(original), 128 / read_svg(path, dpi=96).page.width, rtol=1e-4
    )


def test_optimize_writes_a_plan_and_reports_before_and_after(tmp_path, capsys):
    path = tmp_path / "hatched.svg"
    path.write_text(drawings.hatched_svg(drawings.hatch_lines()))
    out = tmp_path / "ordered.svg"
    assert main(["optimize", str(path), "-o", str(out), "--svg-dpi", "96", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert is_plan_svg(out)
    assert report["after"]["pen_up_mm"] < 0.5 * report["before"]["pen_up_mm"]
    assert report["after"]["seconds"] < report["before"]["seconds"]
    assert stat(capsys, out) == pytest.approx(
        report["after"], rel=1e-4
    )  # what it wrote (to µm) is what it said
    assert stat(capsys, path, "--svg-dpi", "96") == pytest.approx(report["before"], rel=1e-6)
    assert read_svg(out).meta["source"] == str(path)
    # A plan of ours, once ordered, goes through export as it is.
    assert main(["export", str(out), "-o", str(tmp_path / "x.gcode")]) == 0
    assert "reordered" not in capsys.readouterr().out


def test_plan_of_a_drawing_points_to_optimize_and_export(tmp_path, capsys):
    path = tmp_path / "d.svg"
    path.write_text(drawings.inkscape_svg())
    assert main(["plan", str(path), "-o", str(tmp_path / "p.svg")]) == 2
    err = capsys.readouterr().err
    assert (
        "is a drawing, not a photo" in err
        and f"pencilbot optimize {path}" in err
        and f"pencilbot export {path}" in err
    )
