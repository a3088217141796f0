"""``pencilbot studio`` as a user starts it: it says its URL, serves the page with the photo it
was given, refuses other hosts, and stops cleanly on Ctrl-C; off the loopback it needs a token."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import urllib.error
import urllib.request

import numpy as np
import pytest
from PIL import Image


def start(*args: str):
    process = subprocess.Popen(
        [sys.executable, "-m", "pencilbot.cli", "studio", "--no-browser", "--listen-port", "0", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    line = process.stdout.readline()
    found = re.search(r"(http://\S+)", line)
    if found is None:
        process.kill()
        pytest.fail(f"no URL said: {line!r} {process.stderr.read()}")
    return process, found.group(1)


def stop(process) -> int:
    process.send_signal(signal.SIGINT)
    try:
        return process.wait(timeout=20)
    finally:
        if process.poll() is None:
            process.kill()


def test_studio_says_its_url_serves_the_photo_and_stops_on_ctrl_c(tmp_path):
    photo = tmp_path / "grey.png"
    Image.fromarray(np.tile(np.arange(0, 256, 2, dtype=np.uint8), (96, 1))).save(photo)
    process, url = start(str(photo))
    try:
        assert url.startswith("http://127.0.0.1:") and "token" not in url
        with urllib.request.urlopen(url) as page:
            assert b"pencilbot studio" in page.read()
        with urllib.request.urlopen(url + "api/state") as answer:
            assert json.loads(answer.read())["photo"]["name"] == "grey.png"
        port = url.rsplit(":", 1)[1].strip("/")
        refused = urllib.request.Request(url + "api/state", headers={"Host": f"attacker.example:{port}"})
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(refused)
        assert err.value.code == 403
    finally:
        assert stop(process) == 0


def test_off_the_loopback_the_url_carries_a_token():
    process, url = start("--host", "0.0.0.0")  # every address: reached here through the loopback
    try:
        assert "?token=" in url
        url = url.replace("0.0.0.0", "127.0.0.1")
        bare = url.split("?")[0]
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(bare + "api/state")
        assert err.value.code == 401
        with urllib.request.urlopen(url) as page:
            assert page.status == 200
    finally:
        stop(process)


def test_a_missing_photo_is_one_plain_error(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "pencilbot.cli", "studio", str(tmp_path / "none.jpg"), "--no-browser"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode != 0
    assert done.stderr.strip().startswith("pencilbot: error:") and "no such file" in done.stderr
    assert "Traceback" not in done.stderr
