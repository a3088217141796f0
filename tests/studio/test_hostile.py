"""Hostile requests to the studio: none is answered 500 (a user's or a stranger's mistake is a
4xx with one sentence), a decompression bomb is 413 before anything is decoded, and a JSON body
larger than any the page sends is refused unread."""

from __future__ import annotations

import io
import json

import pytest
from PIL import Image

pytest.importorskip("starlette", reason="the studio extra is part of the test extra")


PORT, OWN = 8765, {"X-Studio": "1"}
JSON = {"Content-Type": "application/json", **OWN}


def bomb(width: int, height: int, kind: str = "PNG") -> bytes:
    """A picture of many pixels in a few kB (one bit a pixel, all zero: it compresses to nothing)."""
    buffer = io.BytesIO()
    Image.new("1", (width, height)).save(buffer, format=kind)
    return buffer.getvalue()


BODIES = {  # JSON routes and the bodies a stranger may send them
    "not JSON": b"{nope",
    "not UTF-8": b"\xff\xfe{}",
    "a list": b"[1, 2]",
    "a number": b"7",
    "null": b"null",
    "a string": b'"sim://"',
    "nested depth": b"[" * 100_000 + b"]" * 100_000,
    "port a list": json.dumps({"port": ["sim://"]}).encode(),
    "port a dict": json.dumps({"port": {"a": 1}}).encode(),
    "port unknown": json.dumps({"port": "sim://nowhere"}).encode(),
    "profile a list": json.dumps({"port": "sim://", "profile": ["x"]}).encode(),
    "profile a number": json.dumps({"port": "sim://", "profile": 3}).encode(),
    "dx a word": json.dumps({"port": "sim://", "dx": "left"}).encode(),
    "dx infinite": b'{"port": "sim://", "dx": Infinity}',
    "style a list": json.dumps({"style": ["default"]}).encode(),
    "page a number": json.dumps({"page": 4}).encode(),
    "hatch a word": json.dumps({"hatch": "maybe"}).encode(),
    "face_lines a number": json.dumps({"face_lines": 2}).encode(),
    "line_length huge": json.dumps({"line_length": 10**30}).encode(),
    "margin negative": json.dumps({"margin": -5}).encode(),
    "time_budget a word": json.dumps({"time_budget": "long"}).encode(),
    "time_budget past 4": json.dumps({"time_budget": 40}).encode(),
    "orientation odd": json.dumps({"orientation": {"x": 1}}).encode(),
}
ROUTES = [
    "/api/drawing",
    "/api/plot",
    "/api/plot/pause",
    "/api/plot/jog",
    "/api/plot/resume-job",
    "/api/machine/pen-up",
]


@pytest.mark.parametrize("route", ROUTES)
@pytest.mark.parametrize("kind", sorted(BODIES))
def test_no_json_body_is_answered_500(client, studio, route, kind):
    response = client.post(route, content=BODIES[kind], headers=JSON)
    assert 400 <= response.status_code < 500, (route, kind, response.status_code, response.text[:200])
    assert response.json()["error"]
    assert studio.plotters.sessions == {}


MALFORMED = ("not JSON", "not UTF-8", "a list", "a number", "null", "a string", "nested depth")
WORKSPACE = {  # the workspace's routes and the bodies of theirs a stranger may send
    "/api/placement": {
        "scale a word": {"scale": "big"},
        "scale zero": {"scale": 0},
        "dy huge": {"dy": 1e300},
        "skip a string": {"skip": "all"},
        "skip of numbers": {"skip": [1, 2]},
    },
    "/api/presets/mine": {
        "options a list": {"options": [1]},
        "placement a string": {"placement": "x"},
        "a style that is a list": {"options": {"style": ["default"]}},
        "a negative margin": {"options": {"margin": -5}},
        "an unknown pen set": {"options": {"pens": "../../etc/passwd"}},
        "a zero scale": {"placement": {"scale": 0}},
    },
    "/api/pen-height/try-up": {
        "which a number": {"port": "sim://", "which": 3, "value": 30},
        "value a word": {"port": "sim://", "which": "up", "value": "high"},
        "port unknown": {"port": "sim://nowhere", "which": "up", "value": 30},
        "profile unknown": {"port": "sim://", "profile": "../x", "which": "up", "value": 30},
    },
    "/api/pen-height/save": {"up a word": {"up": "high", "down": 30}, "down missing": {"up": 30}},
}


@pytest.mark.parametrize(
    "route,kind,body",
    [
        (route, kind, json.dumps(body).encode())
        for route, bodies in WORKSPACE.items()
        for kind, body in bodies.items()
    ]
    + [(route, kind, BODIES[kind]) for route in WORKSPACE for kind in MALFORMED],
)
def test_the_workspace_refuses_what_the_page_never_sends(client, route, kind, body, monkeypatch, tmp_path):
    monkeypatch.setenv("PENCILBOT_CONFIG_DIR", str(tmp_path))  # nothing refused is written
    response = client.post(route, content=body, headers=JSON)
    assert 400 <= response.status_code < 500, (route, kind, response.status_code, response.text[:200])
    assert response.json()["error"]
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]


@pytest.mark.parametrize("route", [*ROUTES, "/api/photo"])
def test_a_huge_body_is_413_unread(client, route):
    response = client.post(
        route,
        content=b"{" + b" " * (300 * 1024 * 1024) if route == "/api/photo" else b"[" * (2 << 20),
        headers=JSON,
    )
    assert response.status_code == 413, response.text[:200]


@pytest.mark.parametrize("kind", ["PNG", "TIFF", "GIF", "BMP"])
def test_a_decompression_bomb_is_413_and_nothing_is_decoded(client, studio, kind, monkeypatch):
    data = bomb(20_000, 20_000, kind)  # 400 MP: over PIL's own bomb limit, which raises at open
    decoded = []
    monkeypatch.setattr(Image.Image, "load", lambda self, *a: decoded.append(self.size))
    response = client.put("/api/photo", content=data, headers=OWN)
    assert response.status_code == 413, response.text[:200]
    assert "pixels" in response.json()["error"]
    assert decoded == [] and studio.photo is None and list(studio.folder.iterdir()) == []


@pytest.mark.parametrize(
    "request_kind",
    [
        (
            "PUT",
            "/api/photo",
            b'--x\r\nContent-Disposition: form-data; name="f"; filename="a.png"\r\n\r\n\x89PNG\r\n--x--',
            {"Content-Type": "multipart/form-data; boundary=x"},
        ),
        ("PUT", "/api/photo", b"\x89PNG\r\n\x1a\n" + b"\x00" * 64, {}),  # a PNG signature and nothing after
        ("PUT", "/api/photo", b"GIF89a\xff\xff\xff\xff", {}),
        ("PUT", "/api/photo", b"II*\x00" + b"\xff" * 60, {}),  # a broken TIFF header
        ("PUT", "/api/photo", b"", {}),
        ("GET", "/api/download/plan.svg", b"", {}),
        ("GET", "/api/download/plan.gcode?profile=%ff", b"", {}),
        ("GET", "/api/download/sketch.png", b"", {}),
        ("GET", "/api/plot-paths?port=%00", b"", {}),
        ("GET", "/api/picture/full-x.png", b"", {}),
        ("GET", "/api/picture/-.png", b"", {}),
        ("POST", "/api/plot/%ff", b"{}", JSON),
        ("DELETE", "/api/photo", b"", {}),
        ("GET", "/api/presets/..%2F..%2Fetc%2Fpasswd", b"", {}),
        ("GET", "/api/presets/%00", b"", {}),
        ("GET", "/api/presets/" + "x" * 5000, b"", {}),
        ("GET", "/api/presets/nobody", b"", {}),
        ("DELETE", "/api/presets/..", b"", {}),
        ("GET", "/api/pen-heights?profile=%00", b"", {}),
        ("GET", "/api/pen-heights?profile=../../x", b"", {}),
        ("POST", "/api/pen-height/%ff", b"{}", JSON),
        ("GET", "/api/plot-sheet?port=%00", b"", {}),
        ("PUT", "/api/photo", b'<svg xmlns="http://www.w3.org/2000/svg"><path d="M 0 0 L nan 1"/></svg>', {}),
        ("PUT", "/api/photo", b'<?xml version="1.0" encoding="klingon"?><svg/>', {}),
        ("PUT", "/api/photo", b'<!DOCTYPE s [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;">]><svg>&b;</svg>', {}),
    ],
)
def test_no_other_request_is_answered_500(client, request_kind):
    method, url, body, headers = request_kind
    response = client.request(method, url, content=body, headers={**OWN, **headers})
    assert 400 <= response.status_code < 500, (url, response.status_code, response.text[:200])
