"""Who may talk to the studio: its own page, on its own address, and nobody else.

A server that moves a machine must not obey another web site the user has open (a cross-site
``POST``) nor a name that was made to point at 127.0.0.1 (DNS rebinding): every request must
name the server's own host in ``Host``, and any ``Origin`` must be the server's own. Requests
that change something must also carry the ``X-Studio`` header, which a cross-site form cannot
send. Off the loopback address a token printed at start is needed too (once in the URL, then a
same-site cookie).
"""

from __future__ import annotations

import hmac
import ipaddress
import secrets
from html import escape

from starlette.responses import HTMLResponse, PlainTextResponse

#: Bytes an uploaded photo may have (a 40 MP JPEG is ~20 MB; a 16-bit TIFF of the pixel limit more).
MAX_UPLOAD_BYTES = 256 * 1024 * 1024
COOKIE = "pencilbot_studio"
SAFE_METHODS = {"GET", "HEAD"}


#: What a person who followed a link from another page sees: the studio still refuses it.
REFUSED_PAGE = """<!doctype html><html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1"><title>pencilbot studio: not from here</title>
<style>body{font:16px/1.5 system-ui,sans-serif;max-width:34em;margin:4em auto;padding:0 1em;color:#222;background:#f6f5f1}
h1{font-size:1.3em}p.why{color:#666;font-size:.9em}@media (prefers-color-scheme: dark){body{background:#1c1d20;color:#e8e6e1}p.why{color:#aaa}}</style>
</head><body><h1>This page can only be opened from pencilbot studio itself</h1>
<p>pencilbot studio drives a plotter, so it answers only its own page: a link or a form on another
web page (even one on this computer) may not reach it.</p>
<p>To use the studio, open the address that <code>pencilbot studio</code> printed when it started,
by typing it or from the terminal.</p><p class="why">Refused: {why}</p></body></html>
"""


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Guard:
    """ASGI middleware refusing requests from anywhere but the server's own page (403).

    Parameters
    ----------
    app : ASGI app
    host : str
        The address the server listens on.
    port : int
        Its port.
    token : str or None
        Required (URL ``?token=`` once, then the cookie) when set.
    names : iterable of str, optional
        Further host names the server answers to (the test client's).
    """

    def __init__(self, app, host: str, port: int, token: str | None = None, names=()):
        self.app, self.token = app, token
        hosts = {host, *names} | ({"localhost", "127.0.0.1"} if is_loopback(host) else set())
        self.hosts = {f"{name}:{port}" for name in hosts} | {f"[{host}]:{port}"}
        # Listening on every address (0.0.0.0, ::), the page may be reached by any of the
        # machine's names: any Host is taken, the token keeps others out (a rebinding site's
        # page has neither the token nor the cookie), and the Origin must be that Host's.
        self.any_host = host in ("0.0.0.0", "::") and token is not None

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        headers = {key.decode("latin-1").lower(): value.decode("latin-1") for key, value in scope["headers"]}
        refusal = self.refusal(scope, headers)
        if refusal is not None:
            if "text/html" in headers.get("accept", "") and scope["method"] in SAFE_METHODS:
                page = REFUSED_PAGE.replace(
                    "{why}", escape(refusal[1])
                )  # a person followed a link: tell them
                return await HTMLResponse(page, status_code=refusal[0])(scope, receive, send)
            return await PlainTextResponse(refusal[1], status_code=refusal[0])(scope, receive, send)
        return await self.app(scope, receive, send)

    def refusal(self, scope, headers: dict) -> tuple[int, str] | None:
        """(status, why) for a request to refuse, else None."""
        host = headers.get("host", "")
        if host not in self.hosts and not (self.any_host and host):
            return 403, "pencilbot studio answers only requests for its own address (Host refused)"
        origin = headers.get("origin")
        if origin is not None and origin != f"http://{host}":
            return 403, "pencilbot studio takes requests only from its own page (Origin refused)"
        if headers.get("sec-fetch-site") == "cross-site":
            return 403, "pencilbot studio takes requests only from its own page (cross-site request refused)"
        if scope["method"] not in SAFE_METHODS and headers.get("x-studio") != "1":
            return 403, "pencilbot studio takes changes only from its own page (X-Studio header missing)"
        if self.token is not None and not self._has_token(scope, headers):
            return 401, "pencilbot studio needs the token printed when it started: open the URL it printed"
        return None

    def _has_token(self, scope, headers: dict) -> bool:
        from urllib.parse import parse_qs

        given = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [""])[0]
        for part in headers.get("cookie", "").split(";"):
            name, _, value = part.strip().partition("=")
            if name == COOKIE:
                given = given or value
        return bool(given) and hmac.compare_digest(given, self.token)


def new_token() -> str:
    return secrets.token_urlsafe(24)
