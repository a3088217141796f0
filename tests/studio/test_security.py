"""The studio refuses what is not its own page's: another Host, another Origin, a cross-site or
header-less change, an oversized upload, a path where a name is expected. Each answer is a clear
status and sentence, and nothing runs: no planning starts, no file is written, no plot begins."""

from __future__ import annotations

import io

import pytest
from PIL import Image

pytest.importorskip("starlette", reason="the studio extra is part of the test extra")
from starlette.testclient import TestClient

from pencilbot.studio import app as app_module
from pencilbot.studio.app import create_app

PORT = 8765
OWN = {"X-Studio": "1"}


def nothing_ran(studio) -> None:
    assert studio.planner.generation == 0, "planning started"
    assert list(studio.folder.iterdir()) == [], "a file was written"
    assert studio.plotters.sessions == {}, "a plot started"


def png(width: int, height: int, mode: str = "L") -> bytes:
    buffer = io.BytesIO()
    Image.new(mode, (width, height)).save(buffer, format="PNG")
    return buffer.getvalue()


def test_own_page_is_served(client):
    assert client.get("/").status_code == 200
    assert "pencilbot studio" in client.get("/").text
    assert client.get("/static/studio.js").status_code == 200


@pytest.mark.parametrize("host", ["evil.example", f"evil.example:{PORT}", "127.0.0.1:9999", "testserver:80"])
def test_another_host_is_refused(client, studio, host):
    for method, url in (("GET", "/api/state"), ("GET", "/"), ("POST", "/api/drawing")):
        response = client.request(method, url, headers={"Host": host, **OWN}, json={})
        assert response.status_code == 403
        assert "Host refused" in response.text
    nothing_ran(studio)


def test_cross_origin_post_is_refused(client, studio):
    photo = png(64, 48)
    for origin in (
        "http://evil.example",
        f"http://evil.example:{PORT}",
        "null",
        f"https://testserver:{PORT}",
    ):
        response = client.put("/api/photo", content=photo, headers={"Origin": origin, **OWN})
        assert response.status_code == 403 and "Origin refused" in response.text
        response = client.post("/api/plot", json={"port": "sim://"}, headers={"Origin": origin, **OWN})
        assert response.status_code == 403
    # A browser's cross-site request without Origin, and a plain form post (no X-Studio header):
    response = client.post(
        "/api/plot", json={"port": "sim://"}, headers={"Sec-Fetch-Site": "cross-site", **OWN}
    )
    assert response.status_code == 403 and "cross-site" in response.text
    response = client.post("/api/drawing", data={"style": "default"})
    assert response.status_code == 403 and "X-Studio" in response.text
    nothing_ran(studio)


def test_the_own_origin_is_let_through(client, studio):
    response = client.post(
        "/api/drawing", json={"pen_width": 0.7}, headers={"Origin": f"http://testserver:{PORT}", **OWN}
    )
    assert response.status_code == 200
    assert studio.options.pen_width == 0.7


def test_oversized_upload_is_refused(client, studio, monkeypatch):
    monkeypatch.setattr(app_module, "MAX_UPLOAD_BYTES", 10_000)
    response = client.put("/api/photo", content=b"\x89PNG" + bytes(20_000), headers=OWN)
    assert response.status_code == 413 and "MB the studio takes" in response.text
    nothing_ran(studio)


def test_upload_over_the_pixel_limit_is_refused(client, studio):
    huge = png(8000, 6000, mode="1")  # 48 MP in a few kB: more than DEFAULT_MAX_PIXELS
    assert len(huge) < 100_000
    response = client.put("/api/photo", content=huge, headers=OWN)
    assert response.status_code == 413 and "8000 × 6000 pixels" in response.json()["error"]
    assert studio.photo is None and studio.planner.generation == 0
    assert list(studio.folder.iterdir()) == []


def test_not_an_image_is_refused(client, studio):
    response = client.put("/api/photo", content=b"plain words, no picture", headers=OWN)
    assert response.status_code == 400 and "not an image" in response.json()["error"]
    assert studio.photo is None and list(studio.folder.iterdir()) == []


@pytest.mark.parametrize(
    "body", [b"<svg></svg>", b"<svg xmlns='http://www.w3.org/2000/svg'><g>", b"<?xml version='1.0'?><svg"]
)
def test_an_svg_with_nothing_to_draw_is_refused_in_plain_words(client, studio, body):
    response = client.put("/api/photo", content=body, headers={**OWN, "X-Filename": "x.svg"})
    said = response.json()["error"]
    assert response.status_code == 400 and said.startswith("that SVG") and str(studio.folder) not in said
    assert studio.photo is None and list(studio.folder.iterdir()) == []


@pytest.mark.parametrize(
    "body",
    [
        {"style": "/etc/passwd"},
        {"style": "../../../../etc/passwd"},
        {"pens": "/tmp/pens.toml"},
        {"profile": "../configs/plotters/grbl-servo-a4.toml"},
        {"style": "default", "texture": "/etc/passwd"},
        {"margin": "1; rm -rf /"},
        {"pen_width": float("nan")},
    ],
)
def test_a_path_or_bad_value_in_a_parameter_is_refused(client, studio, body, tmp_path):
    if "pens" in body:
        (tmp_path / "pens.toml").write_text('[[pens]]\nname = "a"\ncolor = "#000000"\nwidth = 0.5\n')
    response = client.post(
        "/api/drawing",
        content=__import__("json").dumps(body, allow_nan=True),
        headers={"Content-Type": "application/json", **OWN},
    )
    assert response.status_code == 400
    assert response.json()["error"]
    assert studio.options.style == ""  # unchanged
    nothing_ran(studio)


def test_a_path_as_port_or_download_is_refused(client, studio):
    for port in ("/etc/passwd", "/dev/null", "socket://10.0.0.1:23", "../sim://"):
        response = client.post("/api/plot", json={"port": port}, headers=OWN)
        assert response.status_code == 400 and "not one of the plotters found" in response.json()["error"]
        response = client.post("/api/machine/pen-down", json={"port": port}, headers=OWN)
        assert response.status_code == 400
    response = client.get("/api/download/plan.gcode", params={"profile": "/etc/passwd"})
    assert response.status_code in (400,)
    assert client.get("/api/download/..%2F..%2Fetc%2Fpasswd").status_code == 404
    assert client.get("/static/../guard.py").status_code == 404
    nothing_ran(studio)


def test_off_loopback_a_token_is_needed(studio):
    app = create_app(studio, host="192.0.2.7", port=PORT, token="s3cret-token", names=("testserver",))
    client = TestClient(app, base_url=f"http://192.0.2.7:{PORT}")
    assert client.get("/api/state").status_code == 401
    assert client.get("/api/state", params={"token": "wrong"}).status_code == 401
    page = client.get("/", params={"token": "s3cret-token"})
    assert page.status_code == 200
    assert client.get("/api/state").status_code == 200  # the cookie the page got
    assert (
        TestClient(app, base_url=f"http://localhost:{PORT}").get("/api/state").status_code == 403
    )  # not its name
    nothing_ran(studio)
