"""The workspace's routes: the plan and a plot's progress on the sheet, the drawing's placement
and skipped layers, presets, and pen heights (tried and kept in the user's profile).

Registered from :func:`~pencilbot.studio.app.create_app`; they answer as its routes do (a
user's mistake: a 4xx with one plain sentence).
"""

from __future__ import annotations

from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import JSONResponse
from starlette.routing import Route

from pencilbot.errors import PencilbotError
from pencilbot.studio import presets
from pencilbot.studio.options import parse_options
from pencilbot.studio.ports import port_url
from pencilbot.studio.sheet import Placement, parse_placement, plan_json, plot_json
from pencilbot.studio.state import Studio


def work_routes(studio: Studio, refusals, json_body, chosen_port, profile_of, number) -> list[Route]:
    """The routes; the helpers are :mod:`~pencilbot.studio.app`'s own (one way of refusing)."""

    async def plan_drawing(request: Request):
        plan = studio.raw_plan()
        return JSONResponse(await run_in_threadpool(plan_json, plan, studio.planner.generation))

    async def placement(request: Request):
        studio.placement = parse_placement(await json_body(request), studio.placement)
        studio.changed()
        return JSONResponse(studio.placement.summary())

    async def plot_sheet(request: Request):
        port = request.query_params.get("port", "")
        session = studio.plotters.sessions.get(port)
        if session is None:
            return JSONResponse({"error": f"{port} has no plot"}, status_code=404)
        return JSONResponse(await run_in_threadpool(plot_json, session.gcode, session.profile))

    async def preset_list(request: Request):
        return JSONResponse({"presets": await run_in_threadpool(presets.names)})

    async def preset(request: Request):
        name = request.path_params["name"]
        if request.method == "GET":
            return JSONResponse(await run_in_threadpool(presets.load, name))
        if request.method == "DELETE":
            await run_in_threadpool(presets.delete, name)
        else:
            body = await json_body(request)
            settings = {"options": body.get("options", {}), "placement": body.get("placement", {})}
            if not isinstance(settings["options"], dict) or not isinstance(settings["placement"], dict):
                raise PencilbotError(
                    "a preset is the drawing options and the placement, as the page sends them"
                )
            await run_in_threadpool(parse_options, settings["options"])  # checked as the page's own
            parse_placement(settings["placement"], Placement())
            await run_in_threadpool(presets.save, name, settings)
        return JSONResponse({"presets": await run_in_threadpool(presets.names)})

    async def pen_heights(request: Request):
        plotter = parse_profile(request.query_params.get("profile", ""), profile_of)
        return JSONResponse(heights_of(plotter))

    async def pen_height(request: Request):
        """Try a height (``which``: up or down, ``value``) on the plotter, or keep both (``save``)."""
        body = await json_body(request)
        plotter = profile_of(body)
        needed = ("up", "down") if request.path_params["what"] == "save" else ("which", "value")
        if missing := [key for key in needed if key not in body]:
            raise PencilbotError(f"say the pen's {' and '.join(missing)}")
        if request.path_params["what"] == "save":
            from pencilbot.api import save_to_user_profile

            values = {"up": number(body, "up"), "down": number(body, "down")}
            path = await run_in_threadpool(save_to_user_profile, plotter, {"pen": values})
            return JSONResponse({"said": f"pen up {values['up']:g}, down {values['down']:g} kept in {path}"})
        which, value = body.get("which"), number(body, "value")
        if which not in ("up", "down"):
            raise PencilbotError("which must be up or down")
        port = chosen_port(body)
        session = studio.plotters.sessions.get(port)
        if session is not None and session.active:
            raise PencilbotError(f"{port} is plotting; try heights when the plot is done or stopped")
        url = port_url(port, plotter.name, studio.sim_speed)
        said = await run_in_threadpool(studio.controls.try_height, url, plotter.name, which, value)
        return JSONResponse({"said": said})

    return [
        Route("/api/plan-drawing", refusals(plan_drawing)),
        Route("/api/placement", refusals(placement), methods=["POST"]),
        Route("/api/plot-sheet", refusals(plot_sheet)),
        Route("/api/presets", refusals(preset_list)),
        Route("/api/presets/{name}", refusals(preset), methods=["GET", "POST", "DELETE"]),
        Route("/api/pen-heights", refusals(pen_heights)),
        Route("/api/pen-height/{what}", refusals(pen_height), methods=["POST"]),
    ]


def parse_profile(name: str, profile_of):
    return profile_of({"profile": name})


def heights_of(plotter) -> dict:
    """The profile's pen heights for the page: up, down and their unit."""
    from pencilbot.machine.profile_edit import pen_unit

    return {
        "profile": plotter.name,
        "up": float(plotter.pen.up),
        "down": float(plotter.pen.down),
        "unit": pen_unit(plotter),
    }
