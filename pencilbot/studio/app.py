"""The studio's HTTP routes (Starlette): the page, its JSON API, previews, downloads, events.

Routes only read the request, call :class:`~pencilbot.studio.state.Studio` or the library, and
answer; a user's mistake is a 4xx with one plain sentence (``{"error": ...}``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response, StreamingResponse
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from pencilbot.errors import PencilbotError
from pencilbot.studio.guard import COOKIE, MAX_UPLOAD_BYTES, Guard
from pencilbot.studio.options import parse_options
from pencilbot.studio.plotting import PlotBusy
from pencilbot.studio.ports import plotter_ports, port_url
from pencilbot.studio.routes_work import work_routes
from pencilbot.studio.state import Studio, TooLarge

STATIC = Path(__file__).parent / "static"
EVENT_WAIT = 15.0  # s between keep-alive events
#: Bytes a JSON request may have: the page sends a few hundred.
MAX_JSON_BYTES = 64 * 1024


def error(status: int, message: str) -> JSONResponse:
    return JSONResponse({"error": message}, status_code=status)


def _refusals(handler):
    """A user's mistake as a 4xx answer, never a traceback."""

    async def wrapped(request: Request):
        try:
            return await handler(request)
        except TooLarge as err:
            return error(413, str(err))
        except PlotBusy as err:
            return error(409, str(err))
        except PencilbotError as err:
            return error(400, str(err))
        except (json.JSONDecodeError, UnicodeDecodeError, RecursionError):
            return error(400, "the request body is not JSON")

    return wrapped


async def json_body(request: Request) -> dict:
    """The request's JSON object, read only up to :data:`MAX_JSON_BYTES` (413 past them)."""
    chunks, total = [], 0
    async for chunk in request.stream():
        total += len(chunk)
        if total > MAX_JSON_BYTES:
            raise TooLarge(
                f"the request is larger than the {MAX_JSON_BYTES // 1024} kB the studio's page ever sends"
            )
        chunks.append(chunk)
    body = json.loads(b"".join(chunks) or b"{}")
    if not isinstance(body, dict):
        raise PencilbotError("the request body must be a JSON object")
    return body


def number(body: dict, key: str) -> float:
    """A finite number from the body (0 when absent)."""
    value = body.get(key, 0.0)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise PencilbotError(f"{key} must be a number, not {value!r}")
    return float(value)


def profile_of(body: dict):
    """The plotter profile the body names (a listed name; "": the user's default)."""
    return parse_options({"profile": body.get("profile", "")}).plotter()


class _Pages:
    """The studio's HTTP endpoints, one method a route, over one :class:`Studio`."""

    def __init__(self, studio: Studio, token: str | None) -> None:
        self.studio, self.token = studio, token

    async def index(self, request: Request):
        response = FileResponse(STATIC / "index.html")
        if self.token is not None and request.query_params.get("token"):
            response.set_cookie(COOKIE, self.token, httponly=True, samesite="strict")
        return response

    async def choices(self, request: Request):
        from pencilbot.configs_io import config_names
        from pencilbot.machine.pens import list_pen_sets
        from pencilbot.machine.profile import default_profile
        from pencilbot.planning.layout import ORIENTATIONS
        from pencilbot.planning.style import default_style, list_styles, load_style

        def defaults(name: str) -> dict:  # what a control shows until the person moves it
            style = load_style(name)
            return {
                "page": style.page,
                "orientation": style.orientation,
                "margin": style.margin,
                "pen_width": style.pen_width,
                "hatch_coverage": style.hatch_coverage,
                "line_length": style.line_length,
                "hatch": style.hatch,
                "face_lines": style.face_lines,
                "time_budget": style.time_budget,
            }

        return JSONResponse(
            {
                "styles": list_styles(),
                "style": default_style(),
                "pens": list_pen_sets(),
                "profiles": list(config_names("plotters")),
                "profile": self.studio.profile or default_profile(),
                "orientations": list(ORIENTATIONS),
                "pages": ["A5", "A4", "A3", "Letter"],
                "style_defaults": {name: defaults(name) for name in list_styles()},
                "ports": await run_in_threadpool(plotter_ports, self.studio.ports),
            }
        )

    async def state(self, request: Request):
        return JSONResponse(self.studio.summary())

    async def upload(self, request: Request):
        size = request.headers.get("content-length")
        if size is None or not size.isdigit():
            return error(411, "send the photo with its length (Content-Length)")
        if int(size) > MAX_UPLOAD_BYTES:
            return error(
                413,
                f"the photo is {int(size) / 1e6:.0f} MB, more than the {MAX_UPLOAD_BYTES / 1e6:.0f} MB the studio takes",
            )
        chunks, total = [], 0
        async for chunk in request.stream():
            total += len(chunk)
            if total > MAX_UPLOAD_BYTES:
                return error(413, "the photo is larger than it said")
            chunks.append(chunk)
        info = await run_in_threadpool(
            self.studio.set_photo, b"".join(chunks), request.headers.get("x-filename", "")
        )
        return JSONResponse(info)

    async def drawing(self, request: Request):
        options = parse_options(await json_body(request))
        if self.studio.photo is None:
            self.studio.options = options
            self.studio.changed()  # every tab shows the same settings
            return JSONResponse({"generation": 0})
        return JSONResponse({"generation": await run_in_threadpool(self.studio.set_options, options)})

    async def picture(self, request: Request):
        name = request.path_params["name"]
        if name == "photo":
            data = self.studio.thumbnail
        else:
            stage, _, kind = name.partition("-")
            result = self.studio.results.get(stage)
            data = (
                getattr(result, f"{kind}_png", b"")
                if result is not None and kind in ("preview", "sketch")
                else b""
            )
        if not data:
            return error(404, "no such picture yet")
        return Response(data, media_type="image/png", headers={"Cache-Control": "no-store"})

    async def download(self, request: Request):
        what = request.path_params["what"]
        if what == "sketch.png":
            result = self.studio.results.get("full")
            if result is None or not result.sketch_png:
                return error(404, "the drawing is not planned yet")
            return Response(result.sketch_png, media_type="image/png", headers=_attachment("sketch.png"))
        plan = self.studio.full_plan()
        if what == "plan.svg":
            from pencilbot.export.svg import svg_text

            return Response(svg_text(plan), media_type="image/svg+xml", headers=_attachment("plan.svg"))
        if what == "plan.gcode":
            from pencilbot.export.gcode import gcode_program

            options = parse_options({"profile": request.query_params.get("profile", "")})
            program = await run_in_threadpool(gcode_program, plan, options.plotter())
            return Response(program, media_type="text/plain", headers=_attachment("plan.gcode"))
        return error(404, f"no download called {what}")

    async def events(self, request: Request):
        async def stream():
            seen = -1
            while not self.studio.closing and not await request.is_disconnected():
                version = await run_in_threadpool(self.studio.wait_change, seen, 0.5)
                if version != seen:
                    seen = version
                    yield f"data: {json.dumps(self.studio.summary())}\n\n"

        return StreamingResponse(
            stream(), media_type="text/event-stream", headers={"Cache-Control": "no-store"}
        )

    def chosen_port(self, body: dict) -> str:
        port = body.get("port")
        if not isinstance(port, str) or port not in {
            entry["port"] for entry in plotter_ports(self.studio.ports)
        }:
            raise PencilbotError(f"port {port!r} is not one of the plotters found; pick one from the list")
        return port

    async def plot(self, request: Request):
        body = await json_body(request)
        port = self.chosen_port(body)
        profile = profile_of(body)
        plan = self.studio.full_plan()
        gcode = self.studio.folder / f"plot-{len(self.studio.plotters.sessions) + 1}-{id(plan):x}.gcode"

        def write():
            from pencilbot import api

            api.export_gcode(plan, profile, gcode)

        await run_in_threadpool(write)
        await run_in_threadpool(self.studio.controls.release)  # the plot takes the port over
        session = self.studio.plotters.start(
            port, port_url(port, profile.name, self.studio.sim_speed), profile.name, gcode
        )
        return JSONResponse(session.summary())

    async def plot_button(self, request: Request):
        body = await json_body(request)
        port, button = self.chosen_port(body), request.path_params["button"]
        dx, dy = number(body, "dx"), number(body, "dy")
        if button == "resume-job":
            await run_in_threadpool(self.studio.controls.release)
            return JSONResponse(self.studio.plotters.resume(port).summary())
        if button not in ("pause", "stop", "go", "give up", "jog"):
            return error(404, f"no plot button called {button}")
        try:
            session = self.studio.plotters.get(port)
        except KeyError:
            return error(409, f"{port} is not plotting")
        session.press(button, dx, dy, prompt=body.get("prompt"))
        return JSONResponse(session.summary())

    async def machine(self, request: Request):
        body = await json_body(request)
        port, action = self.chosen_port(body), request.path_params["action"]
        profile = profile_of(body).name
        dx, dy = number(body, "dx"), number(body, "dy")
        session = self.studio.plotters.sessions.get(port)
        if session is not None and session.active:
            raise PlotBusy(f"{port} is plotting; its controls wait until the plot is done or stopped")
        said = await run_in_threadpool(
            self.studio.controls.press,
            port_url(port, profile, self.studio.sim_speed),
            profile,
            action,
            dx,
            dy,
        )
        return JSONResponse({"said": said})

    async def plot_paths(self, request: Request):
        from pencilbot.studio.drawn_json import job_drawing

        port = request.query_params.get("port", "")
        session = self.studio.plotters.sessions.get(port)
        if session is None:
            return error(404, f"{port} has no plot")
        return JSONResponse(await run_in_threadpool(job_drawing, session.gcode, session.profile))


def create_app(
    studio: Studio, *, host: str = "127.0.0.1", port: int = 8765, token: str | None = None, names=()
) -> Guard:
    """The studio as an ASGI app, behind its :class:`~pencilbot.studio.guard.Guard`."""
    pages = _Pages(studio, token)
    routes = [
        Route("/", pages.index),
        Route("/api/choices", _refusals(pages.choices)),
        Route("/api/state", pages.state),
        Route("/api/photo", _refusals(pages.upload), methods=["PUT", "POST"]),
        Route("/api/drawing", _refusals(pages.drawing), methods=["POST"]),
        Route("/api/picture/{name}.png", pages.picture),
        Route("/api/download/{what}", _refusals(pages.download)),
        Route("/api/events", pages.events),
        Route("/api/plot", _refusals(pages.plot), methods=["POST"]),
        Route("/api/plot/{button}", _refusals(pages.plot_button), methods=["POST"]),
        Route("/api/machine/{action}", _refusals(pages.machine), methods=["POST"]),
        Route("/api/plot-paths", _refusals(pages.plot_paths)),
        *work_routes(studio, _refusals, json_body, pages.chosen_port, profile_of, number),
        Mount("/static", StaticFiles(directory=STATIC)),
    ]
    app = Starlette(routes=routes)
    return Guard(app, host, port, token, names)


def _attachment(name: str) -> dict:
    return {"Content-Disposition": f'attachment; filename="{name}"', "Cache-Control": "no-store"}
