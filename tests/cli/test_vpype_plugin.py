"""`vpype pencilbot PHOTO`: the plugin, run by vpype's own command line as a user runs it, gives
the layers `pencilbot plan` gives for the same photo."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from skimage import data
from skimage import io as skio

from pencilbot.cli import main
from pencilbot.export.svg_read import read_svg

PX_PER_MM = 96 / 25.4
VPYPE = shutil.which("vpype", path=str(Path(sys.executable).parent))


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    path = tmp_path_factory.mktemp("plugin") / "camera.png"
    skio.imsave(path, data.camera()[::4, ::4])
    return path


@pytest.fixture(scope="module")
def planned(photo, tmp_path_factory):
    """`pencilbot plan` of the photo, read back."""
    out = tmp_path_factory.mktemp("plan") / "plan.svg"
    assert main(["plan", str(photo), "-o", str(out), "-q"]) == 0
    return read_svg(out)


def vpype(*args, cwd) -> subprocess.CompletedProcess:
    assert VPYPE, "vpype's console script is installed with the test extra"
    return subprocess.run([VPYPE, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


def test_vpype_stat_shows_the_plans_layers(photo, planned, tmp_path):
    done = vpype("pencilbot", str(photo), "stat", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    layers = re.findall(
        r"Layer (\d+)\n(?:  .*\n)*?  Path count: (\d+)\n(?:  .*\n)*?    vp_name: '([^']*)'\n"
        r"    vp_pen_width: ([\d.]+)\n    vp_color: Color\(red=0, green=0, blue=0",
        done.stdout,
    )
    assert [(int(lid), name, int(count)) for lid, count, name, _ in layers] == [
        (i, layer.name, len(layer.paths)) for i, layer in enumerate(planned.layers, start=1)
    ]
    assert [float(width) / PX_PER_MM for *_, width in layers] == pytest.approx(
        [l.pen_width for l in planned.layers]
    )
    page = re.search(r"Current page size: \(([\d.]+), ([\d.]+)\)", done.stdout)
    assert (float(page[1]) / PX_PER_MM, float(page[2]) / PX_PER_MM) == pytest.approx(
        (planned.page.width, planned.page.height)
    )


def test_vpype_write_gives_the_plans_paths(photo, planned, tmp_path):
    done = vpype("pencilbot", str(photo), "write", "x.svg", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    written = read_svg(tmp_path / "x.svg")  # vpype's own SVG, read as any SVG is
    assert (written.page.width, written.page.height) == pytest.approx(
        (planned.page.width, planned.page.height)
    )
    # A dot (a face's one-cell run) is written by vpype as a zero-length <line>, which vpype's
    # reader, and ours as it, reads as nothing drawn: the plan's lines are what comes back.
    lines = [[path for path in layer.paths if len(path) > 1] for layer in planned.layers]
    assert [(l.name, len(l.paths)) for l in written.layers] == [
        (l.name, len(k)) for l, k in zip(planned.layers, lines)
    ]
    assert [l.pen_width for l in written.layers] == pytest.approx(
        [l.pen_width for l in planned.layers], abs=1e-4
    )
    for ours, theirs in zip(written.paths(), [path for kept in lines for path in kept]):
        np.testing.assert_allclose(ours, theirs, atol=2e-3)  # vpype writes 4 decimals of px, we 3 of mm


def test_a_pipeline_adds_after_its_own_layers_and_takes_the_options(photo, tmp_path):
    # vpype's commands take their options before their arguments.
    done = vpype(
        "rect",
        "1cm",
        "1cm",
        "2cm",
        "2cm",
        "pencilbot",
        "--no-hatch",
        "--pen-width",
        "0.3",
        "--page",
        "A5",
        str(photo),
        "linesimplify",
        "write",
        "y.svg",
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    written = read_svg(tmp_path / "y.svg")
    assert [l.name for l in written.layers] == [
        "1",
        "edges",
    ]  # the rect's layer (vpype names it by number), then ours
    assert written.layers[1].pen_width == pytest.approx(0.3, abs=1e-4)
    assert len(written.layers[1].paths) > 10  # contours of a small coffee, one line each (edge_lines = 1)


def test_a_mistake_is_one_plain_message(photo, tmp_path):
    done = vpype("pencilbot", "--style", "nonesuch", str(photo), "stat", cwd=tmp_path)
    assert done.returncode != 0
    assert "Traceback" not in done.stderr
    assert "no style named 'nonesuch'" in done.stderr and done.stderr.strip().count("\n") == 0


def test_the_plugin_takes_the_plan_command_s_photo_options_declared_once():
    """Every photo option of `pencilbot plan` (but its listings) is an option of the plugin, with
    the same check: the plugin does not declare them a second time."""
    import argparse

    from pencilbot.commands.options import add_photo_options
    from pencilbot.vpype_plugin import pencilbot as plugin

    parser = argparse.ArgumentParser(add_help=False)
    add_photo_options(parser)
    cli = {
        flag for action in parser._actions for flag in action.option_strings if not flag.startswith("--list-")
    }
    plugin_flags = {flag for param in plugin.params for flag in (*param.opts, *param.secondary_opts)}
    assert cli <= plugin_flags and plugin_flags - cli <= {"--help", "photo"}


def test_no_hatch_draws_only_the_edges_in_the_plugin_and_in_plan(photo, tmp_path):
    done = vpype("pencilbot", "--no-hatch", str(photo), "write", "x.svg", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert main(["plan", str(photo), "--no-hatch", "-o", str(tmp_path / "p.svg"), "-q"]) == 0
    assert [l.name for l in read_svg(tmp_path / "p.svg").layers] == ["edges"]
    assert [l.name for l in read_svg(tmp_path / "x.svg").layers] == ["edges"]
    bad = vpype("pencilbot", "--margin", "nan", str(photo), "stat", cwd=tmp_path)
    assert bad.returncode != 0 and "--margin" in bad.stderr and "Traceback" not in bad.stderr
