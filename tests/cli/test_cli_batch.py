"""`pencilbot plan` and `pencilbot export` over several photos and folders: every good file gets
its result, every broken one one line naming it, on a process pool or one by one alike."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest
import skimage.data
from gcodeparser import parse_gcode_lines
from PIL import Image
from skimage.transform import resize

from pencilbot.cli import build_parser, main
from pencilbot.export.svg_read import read_svg

NAMES = ["camera", "coins", "moon"]
#: A small sheet where the sheet does not matter to what a test checks: a plan of a photo on A4
#: costs a few seconds, and these tests run a dozen.
SMALL = ["--page", "105x148"]


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    """Three small real photos (128 px) and a PNG cut off halfway, in one folder with a stray text file."""
    folder = tmp_path_factory.mktemp("photos")
    for name in NAMES:
        pixels = resize(getattr(skimage.data, name)(), (128, 128), anti_aliasing=True)
        Image.fromarray((pixels * 255).astype(np.uint8)).save(folder / f"{name}.png")
    whole = (folder / "camera.png").read_bytes()
    (folder / "broken.png").write_bytes(whole[: len(whole) // 2])
    (folder / "notes.txt").write_text("not a photo")
    return folder


def files(photos, *names):
    return [str(photos / f"{name}.png") for name in names]


def pen_downs(path) -> int:
    """Pen-down commands (grbl-servo-a4: M3 S90) in a G-code file, parsed by a third-party parser."""
    commands = parse_gcode_lines(path.read_text(encoding="ascii"))
    return sum(c.command_str == "M3" and c.params.get("S") == 90 for c in commands)


def test_export_of_three_photos_and_a_broken_one(photos, tmp_path, capsys):
    out = tmp_path / "gcode"
    assert main(["export", *files(photos, *NAMES, "broken"), "-o", str(out), *SMALL]) == 2
    assert sorted(p.name for p in out.iterdir()) == ["camera.gcode", "coins.gcode", "moon.gcode"]
    assert all(pen_downs(out / f"{name}.gcode") > 20 for name in NAMES)
    assert len({(out / f"{name}.gcode").read_bytes() for name in NAMES}) == 3  # each its own photo
    captured = capsys.readouterr()
    errors = [line for line in captured.err.splitlines() if "error" in line]
    assert errors == [
        f"pencilbot: error: {photos / 'broken.png'} could not be decoded (image file is truncated); "
        "it is probably truncated or corrupt. Re-export or re-download the image."
    ]
    assert "Traceback" not in captured.err
    assert captured.out.splitlines() == ["3 written, 1 failed"]


def test_plan_of_a_folder_writes_a_plan_and_a_preview_per_photo(photos, tmp_path, capsys):
    plans, previews = tmp_path / "plans", tmp_path / "previews"
    assert (
        main(["plan", str(photos), "-o", str(plans), "--preview", str(previews), "--style", "outline", "-v"])
        == 2
    )
    assert sorted(p.name for p in plans.iterdir()) == ["camera.svg", "coins.svg", "moon.svg"]
    assert sorted(p.name for p in previews.iterdir()) == ["camera.png", "coins.png", "moon.png"]
    for name in NAMES:
        assert ET.parse(plans / f"{name}.svg").getroot().tag.endswith("svg")
        assert [layer.name for layer in read_svg(plans / f"{name}.svg").layers] == ["edges"]
        with Image.open(previews / f"{name}.png") as png:
            assert png.size == (827, 1170) and np.asarray(png.convert("L")).min() < 128
    captured = capsys.readouterr()
    assert sorted(line.split(" (")[0] for line in captured.out.splitlines()[:-1]) == [
        f"wrote {plans / name}.svg" for name in NAMES
    ]  # -v: one line per file written, then the summary
    assert captured.out.splitlines()[-1] == "3 written, 1 failed"
    assert captured.err.count("pencilbot: error:") == 1 and "broken.png" in captured.err


@pytest.mark.parametrize("command", ["plan", "export"])
def test_pool_and_one_by_one_write_the_same_files(photos, tmp_path, command):
    # the default style orders paths in counted rounds, not seconds: a plan does not depend on CPU load
    outputs = []
    for jobs in ([], ["--jobs", "1"]):
        out = tmp_path / f"out{len(jobs)}"
        argv = [command, *files(photos, *NAMES), "-o", str(out), "-q", *SMALL, *jobs]
        assert main(argv) == 0
        outputs.append({p.name: p.read_bytes() for p in out.iterdir()})
    assert len(outputs[0]) == 3 and outputs[0] == outputs[1]


def test_quiet_batch_prints_only_the_failure(photos, tmp_path, capsys):
    assert main(["export", *files(photos, "moon", "broken"), "-o", str(tmp_path / "out"), "-q", *SMALL]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and "broken.png" in captured.err


def test_one_input_still_writes_the_file_named(photos, tmp_path, capsys):
    out = tmp_path / "moon.gcode"
    assert main(["export", *files(photos, "moon"), "-o", str(out)]) == 0
    assert pen_downs(out) > 20 and capsys.readouterr().out.startswith(f"wrote {out} for grbl-servo-a4")


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["plan", "{a}", "{b}", "-o", "{tmp}/plans.svg"],
            "2 inputs need a folder for the plan, not the file",
        ),
        (["export", "{a}", "{b}", "-o", "{tmp}/x.gcode"], "2 inputs need a folder for the output"),
        (["plan", "{a}", "{b}", "-o", "{tmp}/missing/plans"], "missing does not exist"),
        # an existing file, whatever its name, is no folder (this was a FileExistsError traceback)
        (["plan", "{a}", "{b}", "-o", "{tmp}/other/camera.png"], "need a folder for the plan, not the file"),
        (
            ["export", "{a}", "{b}", "-o", "{tmp}/other/camera.png"],
            "need a folder for the output, not the file",
        ),
        (
            ["plan", "{a}", "{b}", "-o", "{tmp}/plans", "--preview", "{tmp}/p.png"],
            "need a folder for the preview",
        ),
        (["export", "{a}", "{tmp}/other/camera.png", "-o", "{tmp}/out"], "would both be written to"),
        (["export", "{tmp}/empty", "-o", "{tmp}/out"], "holds no photo"),
        (["plan", "{a}", "{b}", "-o", "{tmp}/plans", "--style", "nope"], "no style named 'nope'"),
    ],
)
def test_batch_mistakes_are_one_line_before_any_file(photos, tmp_path, capsys, argv, message):
    (tmp_path / "empty").mkdir()
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "camera.png").write_bytes((photos / "camera.png").read_bytes())
    before = sorted(tmp_path.rglob("*"))
    a, b = files(photos, "camera", "coins")
    argv = [arg.format(a=a, b=b, tmp=tmp_path) for arg in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("pencilbot: error: ") and message in err and err.count("\n") == 1
    assert sorted(tmp_path.rglob("*")) == before


@pytest.mark.parametrize("jobs", ["0", "-2", "two"])
def test_jobs_must_be_a_count(photos, tmp_path, capsys, jobs):
    assert (
        main(["export", *files(photos, "camera", "coins"), "-o", str(tmp_path / "out"), "--jobs", jobs]) == 2
    )
    assert (
        capsys.readouterr().err
        == f"pencilbot: error: --jobs must be at least 1 and at most 256, a whole number, not {jobs!r}\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_every_subcommand_takes_quiet_and_verbose():
    parser = build_parser()
    subcommands = parser._subparsers._group_actions[0].choices  # argparse keeps no public accessor
    assert {"sketch", "plan", "stat", "export", "simulate", "sim-serve", "draw"} <= set(subcommands)
    for name, sub in subcommands.items():
        flags = {flag for action in sub._actions for flag in action.option_strings}
        assert {"-q", "--quiet", "-v", "--verbose"} <= flags, name
