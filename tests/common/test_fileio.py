"""Atomic writes: whole file or nothing, ordinary permissions, no temporary file left."""

from __future__ import annotations

import os

import pytest

from pencilbot.errors import PencilbotError
from pencilbot.fileio import write_atomic


def test_written_file_has_umask_permissions_and_no_temp_left(tmp_path):
    old = os.umask(0o022)
    try:
        import importlib

        import pencilbot.fileio as fileio

        importlib.reload(fileio)
        fileio.write_atomic(tmp_path / "a.gcode", b"G0 X1\n")
    finally:
        os.umask(old)
        importlib.reload(fileio)
    assert (tmp_path / "a.gcode").read_bytes() == b"G0 X1\n"
    assert (tmp_path / "a.gcode").stat().st_mode & 0o777 == 0o644
    assert [p.name for p in tmp_path.iterdir()] == ["a.gcode"]


def test_failure_mid_write_keeps_the_old_file_and_leaves_no_temp(tmp_path, monkeypatch):
    target = tmp_path / "plan.svg"
    target.write_bytes(b"old")

    def broken_replace(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(PencilbotError, match="No space left"):
        write_atomic(target, b"new")
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["plan.svg"]


def test_missing_folder_is_a_plain_error(tmp_path):
    with pytest.raises(PencilbotError, match="does not exist"):
        write_atomic(tmp_path / "nope" / "x.png", b"")
