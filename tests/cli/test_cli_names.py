"""A file whose name is not UTF-8 (bytes ``os.fsdecode`` turns into surrogates) is named in what a
command prints escaped, not a UnicodeEncodeError after the work is done."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
from PIL import Image


def test_an_output_named_in_bytes_that_are_not_utf8_is_printed_escaped(tmp_path):
    photo = tmp_path / "photo.png"
    Image.fromarray(np.random.default_rng(1).integers(0, 255, (48, 64), dtype=np.uint8)).save(photo)
    out = os.fsencode(tmp_path) + b"/sk\xff\xfeetch.png"
    env = {**os.environ, "PYTHONIOENCODING": "utf-8"}  # strict on stdout, as a UTF-8 terminal is
    done = subprocess.run(
        [sys.executable, "-m", "pencilbot.cli", "sketch", str(photo), "-o", out],
        capture_output=True,
        env=env,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr.decode("utf-8", "replace")
    assert b"sk\\udcff\\udcfeetch.png" in done.stdout and os.path.exists(out)
