"""The library API a script uses: sketch, plan, export_gcode, draw."""

from __future__ import annotations

import numpy as np
import pytest
from skimage import data
from skimage import io as skio

import pencilbot
from pencilbot.errors import ImageLoadError, PencilbotError, ProfileError
from sim import protocol_sim


@pytest.fixture(scope="module")
def camera_small():
    return data.camera()[::4, ::4]  # 128 × 128 grey


def test_sketch_accepts_an_array_and_a_path_alike(camera_small, tmp_path):
    skio.imsave(tmp_path / "cam.png", camera_small)
    from_array = pencilbot.sketch(camera_small)
    from_file = pencilbot.sketch(tmp_path / "cam.png")
    assert from_array.result.shape == camera_small.shape
    np.testing.assert_array_equal(from_array.result, from_file.result)


def test_sketch_takes_stroke_options_and_a_texture(camera_small):
    plain = pencilbot.sketch(camera_small)
    bold = pencilbot.sketch(camera_small, stroke_gamma=2.5, stroke_width=2.0)
    assert (bold.line.gamma, plain.line.gamma) == (2.5, 1.0)
    assert bold.line.drawing.mean() < plain.line.drawing.mean()
    stripes = np.tile(np.where(np.arange(12) % 4 == 0, 0.3, 0.95), (12, 1))
    textured = pencilbot.sketch(camera_small, texture=stripes)
    assert np.abs(textured.texture - plain.texture).mean() > 0.02


def test_plan_honours_page_and_pen_width(camera_small):
    plan = pencilbot.plan(camera_small, page="A5", orientation="landscape", pen_width=0.3)
    assert (plan.page.width, plan.page.height) == (210.0, 148.0)
    assert {layer.pen_width for layer in plan.layers} == {0.3}
    points = np.concatenate(plan.paths())
    assert points.min() >= plan.page.margin - 1e-6
    assert points[:, 0].max() <= plan.page.width - plan.page.margin + 1e-6


def test_export_gcode_lines_equal_the_written_file(camera_small, tmp_path):
    plan = pencilbot.plan(camera_small, page="A5")
    lines = pencilbot.gcode(plan, "grbl-servo-a4")
    summary = pencilbot.export_gcode(plan, "grbl-servo-a4", tmp_path / "out.gcode")
    assert (tmp_path / "out.gcode").read_text().splitlines() == lines
    assert summary.paths == len(plan.paths())
    assert any(line.startswith("G1") for line in lines)


def test_draw_delivers_every_line_once_to_the_virtual_plotter(camera_small):
    lines = pencilbot.gcode(pencilbot.plan(camera_small, page="A5"), "grbl-servo-a4")
    result = pencilbot.draw(lines, "sim://api-test")
    try:
        accepted = protocol_sim.plotter("api-test").firmware.accepted_lines()
    finally:
        protocol_sim.forget("api-test")
    sent = [line.split(";")[0].replace(" ", "") for line in lines]  # the driver sends lines compacted
    assert accepted == [line for line in sent if line]
    assert result.lines_sent == len(accepted)


def test_user_mistakes_raise_pencilbot_errors(tmp_path):
    (tmp_path / "x.png").write_bytes(b"not a png")
    with pytest.raises(ImageLoadError, match="x.png"):
        pencilbot.sketch(tmp_path / "x.png")
    with pytest.raises(ProfileError, match="nope"):
        pencilbot.plan(data.camera()[::8, ::8], style="nope")
    with pytest.raises(PencilbotError, match="stroke_gamma"):
        pencilbot.sketch(data.camera()[::8, ::8], stroke_gamma=-1)
    with pytest.raises(ImageLoadError, match="pencil texture: .*x.png"):
        pencilbot.sketch(data.camera()[::8, ::8], texture=tmp_path / "x.png")


def test_the_api_says_each_signature_once():
    """``draw``'s options are the driver's (one signature, typed); export_gcode always writes,
    and its old lines-without-a-path spelling still works for a release, with a warning."""
    import inspect
    import warnings

    from pencilbot.driver import draw as driver_draw

    assert inspect.signature(pencilbot.draw) == inspect.signature(driver_draw)
    assert "on_error" in inspect.signature(pencilbot.draw).parameters
    plan = pencilbot.plan(np.ones((40, 60)), page="A5")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = pencilbot.export_gcode(plan, "grbl-servo-a4")
    assert old == pencilbot.gcode(plan, "grbl-servo-a4")
    assert any(issubclass(w.category, DeprecationWarning) for w in caught)
