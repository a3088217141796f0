"""Files that are not regular files (issue 33): an existing FIFO or device named as output is
refused, never replaced by a file (14 of 14 were); a FIFO, device or folder named as input is
refused at the door with one line (a FIFO journal or config.toml hung, /dev/zero as a profile
ended in MemoryError); a file read whole is bounded before it is read."""

import os
import stat
import threading

import pytest
from sweep import device

from pencilbot import fileio
from pencilbot.cli import main
from pencilbot.errors import PencilbotError
from pencilbot.fileio import write_atomic


@pytest.mark.parametrize("kind", ["fifo", "device", "folder"])
def test_an_output_that_is_no_regular_file_is_refused_and_stays(tmp_path, kind):
    target = tmp_path / "out.png"
    {"fifo": os.mkfifo, "device": lambda p: device(p, 3), "folder": os.mkdir}[kind](target)
    before = os.lstat(target)
    with pytest.raises(PencilbotError, match="out.png is a|cannot write .*out.png \\(Is a directory"):
        write_atomic(target, b"data")
    after = os.lstat(target)
    assert (after.st_mode, after.st_rdev) == (before.st_mode, before.st_rdev)
    assert os.listdir(tmp_path) == ["out.png"]  # no temporary file either


@pytest.mark.parametrize(
    "argv",
    [
        ["sketch", "p.png", "-o", "OUT.png"],
        ["plan", "p.png", "-o", "OUT.svg"],
        ["export", "d.svg", "-o", "OUT.gcode"],
        ["simulate", "d.gcode", "-o", "OUT.png"],
        ["optimize", "d.svg", "-o", "OUT.svg"],
    ],
)
def test_the_commands_refuse_a_fifo_output_in_one_line(tmp_path, capsys, monkeypatch, argv):
    import numpy as np
    from PIL import Image

    monkeypatch.chdir(tmp_path)
    Image.fromarray(np.full((40, 40), 128, np.uint8)).save("p.png")
    (tmp_path / "d.svg").write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" width="50mm" height="50mm" '
        'viewBox="0 0 50 50"><path d="M 5 5 L 40 40" stroke="black"/></svg>'
    )
    (tmp_path / "d.gcode").write_text("G21\nG90\nM3 S30\nG0 X10 Y10\nM3 S90\nG1 X20 F900\nM3 S30\n")
    output = next(a for a in argv if a.startswith("OUT"))
    os.mkfifo(output)
    assert main([*argv, "-q"]) == 2
    err = capsys.readouterr().err
    assert (
        err
        == f"pencilbot: error: the output {output} is a FIFO (named pipe), not a file; pencilbot writes only "
        "regular files: name a file (a new one, or one to replace)\n"
    )
    assert stat.S_ISFIFO(os.lstat(output).st_mode)


def _unblock(path):
    """Open the FIFO's other end if a reader waits on it (so an old reader that opened it does not
    hang the test: it then reads nothing and fails some other way)."""

    def run():
        try:
            fd = os.open(path, os.O_WRONLY)
            os.close(fd)
        except OSError:
            pass

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


@pytest.mark.parametrize("what", ["journal", "config", "profile", "gcode"])
def test_a_fifo_or_device_input_is_refused_at_the_door(tmp_path, capsys, monkeypatch, what):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d.svg").write_text(
        '<svg xmlns="http://www.w3.org/2000/svg" width="50mm" height="50mm" '
        'viewBox="0 0 50 50"><path d="M 5 5 L 40 40" stroke="black"/></svg>'
    )
    if what == "journal":
        os.mkfifo("job.json")
        argv, path = ["draw", "--resume", "job.json", "--port", "sim://"], "job.json"
    elif what == "config":
        folder = tmp_path / "config"
        folder.mkdir()
        os.mkfifo(folder / "config.toml")
        monkeypatch.setenv("PENCILBOT_CONFIG_DIR", str(folder))
        argv, path = ["stat", "d.svg"], str(folder / "config.toml")
    elif what == "profile":
        device(tmp_path / "zero.toml", 5)
        monkeypatch.setenv("PENCILBOT_PROFILE", str(tmp_path / "zero.toml"))
        argv, path = ["stat", "d.svg"], str(tmp_path / "zero.toml")
    else:
        os.mkfifo("d.gcode")
        argv, path = ["stat", "d.gcode"], "d.gcode"
    if stat.S_ISFIFO(os.stat(path).st_mode):
        _unblock(path)
    code = main([*argv, "-q"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("pencilbot: error: ") and err.count("\n") == 1, err
    assert f"{path} is a " in err and "not a file" in err


def test_a_file_read_whole_is_bounded_before_it_is_read(tmp_path):
    sparse = tmp_path / "big.toml"
    with open(sparse, "wb") as handle:
        handle.truncate(20 << 30)
    with pytest.raises(PencilbotError, match="big.toml is longer than 16 MB"):
        fileio.read_bounded(sparse, "plotter profile")
    with pytest.raises(PencilbotError, match="is a folder"):
        fileio.refuse_special_input(tmp_path, "image")
    fileio.refuse_special_input(tmp_path, "input", folder_ok=True)  # a folder of photos
