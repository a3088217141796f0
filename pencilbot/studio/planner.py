"""Planning for the page: a worker process per change, the newest change wins.

Each change of the controls is a new *generation*. :meth:`LivePlanner.submit` ends the process still
planning an older one (terminated: its result can no longer arrive) and starts a new one, which
sends a coarse stage first and then the full plan at the real pen width. The coarse stage is the
drawing at half scale (page, margin and every length of the style halved; a third with several
pens) with a pen six times wider at full scale (nine), planned as a draft (paths unordered and
unjoined, the colour separation unpolished): a fraction of the work (the tone loop's grid has a
fixed cell, so a smaller sheet is what makes it cheap), shown at the same size. A result is kept
only if its generation is still the newest. Processes come from a fork server that has the planning
stack imported already, so a new one starts in milliseconds.
"""

from __future__ import annotations

import dataclasses
import io
import multiprocessing
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.process import BaseProcess
from pathlib import Path

import numpy as np

from pencilbot.errors import PencilbotError
from pencilbot.studio.options import PREVIEW_DPI, DrawingOptions
from pencilbot.units import CSS_PX_PER_INCH

STAGES = ("coarse", "full")
#: The coarse stage's pen, as drawn at full scale: this many times the real one.
COARSE_PEN_FACTOR = 6.0
#: The coarse stage plans on a sheet this many times smaller (every length of the style too).
COARSE_SCALE = 2.0
#: With several pens (a colour separation per cell, a layer per pen and hatch family) the coarse
#: stage's sheet and pen are coarser still: its preview stays under half a second at 1 MP.
COARSE_SCALE_PENS, COARSE_PEN_FACTOR_PENS = 3.0, 9.0
_STYLE_LENGTHS = ("margin", "hatch_form", "hatch_blur", "min_hatch_run", "hatch_join")  # mm
_PRELOAD = ["pencilbot.studio.warm"]


@dataclass
class StageResult:
    """One stage of one generation: PNG previews, figures, and (full stage) the plan."""

    generation: int
    stage: str
    preview_png: bytes = b""
    sketch_png: bytes = b""
    figures: dict = field(default_factory=dict)
    plan: object = None
    error: str = ""
    seconds: float = 0.0  # from the change to this result


def png_bytes(image: np.ndarray) -> bytes:
    """A grey or RGB uint8 (or float in [0, 1]) picture as PNG bytes."""
    from PIL import Image

    if image.dtype != np.uint8:
        image = np.clip(np.rint(image * 255.0), 0, 255).astype(np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(image).save(buffer, format="PNG", compress_level=1)
    return buffer.getvalue()


#: What the page says a stage is doing, in order (its progress: step ``i`` of these).
STEPS = ("sketching and planning the paths", "drawing the preview", "estimating the plot time")


def plan_stage(photo, options: DrawingOptions, stage: str, say=lambda step: None) -> dict:
    """Plan ``photo`` (a file, a picture or a :class:`~pencilbot.imaging.io.LoadedImage`; an
    ``.svg`` file is read as a finished drawing) with ``options`` for one stage; what a
    :class:`StageResult` carries. ``say(i)`` is called as step ``i`` of :data:`STEPS` begins."""
    from pencilbot.planning.preview import preview_image

    say(0)
    drawing, plan = _drawing(photo, options, stage)
    say(1)
    dpi = PREVIEW_DPI
    if stage == "coarse":  # half the full preview's pixels a side (a photo's coarse plan is smaller)
        dpi = PREVIEW_DPI * (coarse_scale(options.prepared().pens)[0] / 2 if drawing is not None else 0.5)
    result: dict[str, object] = {
        "preview_png": png_bytes(preview_image(plan, dpi)),
        "sketch_png": png_bytes(drawing.result) if drawing is not None else b"",
    }
    if stage == "full":
        say(2)
        result.update(figures=_figures(plan, drawing, options), plan=plan)
    return result


def _drawing(source, options: DrawingOptions, stage: str):
    """(the sketch or None, the plan): a photo sketched and planned through the application
    layer (every guard at full scale), an SVG read, fitted onto the sheet and (full stage)
    reordered by the library's optimizer."""
    from pencilbot.app.photo import PhotoRequest, sketch_and_plan

    prepared = options.prepared()
    if isinstance(source, Path) and source.suffix == ".svg":
        from pencilbot import api
        from pencilbot.planning.layout import fit_plan
        from pencilbot.planning.optimize import reorder_plan

        style = prepared.style
        plan = fit_plan(
            api.read_svg(source, dpi=CSS_PX_PER_INCH), style.page, style.orientation, style.margin
        )
        return None, reorder_plan(plan).plan if stage == "full" else plan
    if stage == "coarse":
        style, pens = coarse(prepared.style, prepared.pens)
        dpi = PREVIEW_DPI * coarse_scale(prepared.pens)[0] / 2
        return sketch_and_plan(source, PhotoRequest(style=style, pens=pens, preview_dpi=dpi, draft=True))
    return sketch_and_plan(source, prepared)


def _figures(plan, drawing, options: DrawingOptions) -> dict:
    from pencilbot.planning.fidelity import photo_likeness
    from pencilbot.planning.stats import estimate

    figures: dict[str, object] = {
        "paths": sum(len(layer.paths) for layer in plan.layers),
        "page": f"{plan.page.width:g} × {plan.page.height:g} mm",
        "pens": list(plan.pens),
    }
    try:
        total = estimate(plan, options.plotter()).total
        figures.update(
            pen_down_m=round(total.pen_down_mm / 1000, 2),
            pen_up_m=round(total.pen_up_mm / 1000, 2),
            lifts=total.lifts,
            seconds=round(total.seconds, 1),
        )
    except PencilbotError as err:
        figures["estimate_error"] = str(err)
    if drawing is not None:
        figures["likeness"] = round(photo_likeness(plan, drawing).rho, 3)
    return figures


def coarse_scale(pens) -> tuple[float, float]:
    """How many times smaller the coarse stage's sheet is, and how many times wider its pen
    is at full scale: :data:`COARSE_SCALE`, or :data:`COARSE_SCALE_PENS` with several pens."""
    if pens is not None and len(pens.pens) > 1:
        return COARSE_SCALE_PENS, COARSE_PEN_FACTOR_PENS
    return COARSE_SCALE, COARSE_PEN_FACTOR


def coarse(style, pens):
    """The coarse stage's style and pens: the drawing at 1 / scale with a pen factor times wider
    at full scale (:func:`coarse_scale`)."""
    from pencilbot.planning.layout import page_size

    sheet = page_size(style.page, None, margin=style.margin)
    scale, factor = coarse_scale(pens)
    widen = factor / scale
    lengths = {key: getattr(style, key) / scale for key in _STYLE_LENGTHS}
    style = dataclasses.replace(
        style,
        page=f"{sheet.width / scale:g}x{sheet.height / scale:g}",
        pen_width=style.pen_width * widen,
        **lengths,
    )
    if pens is not None:  # the pens' widths set the plan's: widen them as well
        pens = dataclasses.replace(
            pens, pens=tuple(dataclasses.replace(pen, width=pen.width * widen) for pen in pens.pens)
        )
    return style, pens


def _work(conn, photo: str, options: DrawingOptions, stages: tuple[str, ...], small=None) -> None:
    """The worker process: each stage's result (or the error) through ``conn``; the coarse stage
    plans ``small`` (the photo already decoded small) when given, the full one the file."""
    for stage in stages:
        try:
            source = small if stage == "coarse" and small is not None else Path(photo)

            def say(step: int, stage: str = stage) -> None:
                conn.send(
                    ("progress", {"stage": stage, "step": step, "of": len(STEPS), "words": STEPS[step]})
                )

            conn.send((stage, plan_stage(source, options, stage, say)))
        except PencilbotError as err:
            conn.send((stage, {"error": str(err)}))
            return
        except MemoryError:
            conn.send((stage, {"error": "not enough memory to plan this; use a smaller page or a wider pen"}))
            return
    conn.close()


class LivePlanner:
    """Plans the newest change; ``on_result(StageResult)`` is called (in a reader thread) for each
    stage of the newest generation, never for an older one."""

    def __init__(
        self,
        on_result: Callable[[StageResult], None],
        stages: tuple[str, ...] = STAGES,
        on_progress: Callable[[int, dict], None] = lambda generation, step: None,
    ):
        self.on_result, self.on_progress = on_result, on_progress
        self.stages = stages
        self.generation = 0
        self._lock = threading.Lock()
        self._process: BaseProcess | None = None
        self._context = multiprocessing.get_context("forkserver")
        self._context.set_forkserver_preload(_PRELOAD)

    def warm_up(self) -> None:
        """Start the fork server now (it imports the planning stack once, ~1 s)."""
        process = self._context.Process(target=_idle, daemon=True)
        process.start()
        process.join()

    def submit(self, photo: Path, options: DrawingOptions, small=None) -> int:
        """Start planning ``photo`` with ``options`` (the coarse stage from ``small``, a
        :class:`~pencilbot.imaging.io.LoadedImage` of it, if given); end the older one. Returns
        the generation."""
        with self._lock:
            self.generation += 1
            generation = self.generation
            self._end_process()
            receive, send = self._context.Pipe(duplex=False)
            process = self._context.Process(
                target=_work, args=(send, str(photo), options, self.stages, small), daemon=True
            )
            started = time.monotonic()
            process.start()
            send.close()
            self._process = process
        threading.Thread(
            target=self._read,
            args=(receive, generation, started, process),
            daemon=True,
            name=f"planner-{generation}",
        ).start()
        return generation

    def cancel(self) -> None:
        """Drop the generation in flight (its process is ended)."""
        with self._lock:
            self.generation += 1
            self._end_process()

    def _end_process(self) -> None:
        if self._process is not None and self._process.is_alive():
            self._process.terminate()
        self._process = None

    def _read(self, receive, generation: int, started: float, process) -> None:
        try:
            while True:
                try:
                    stage, payload = receive.recv()
                except (EOFError, OSError):
                    break
                with self._lock:
                    if generation != self.generation:
                        break  # a newer change: this result is dropped
                if stage == "progress":
                    self.on_progress(generation, {**payload, "seconds": round(time.monotonic() - started, 2)})
                    continue
                self.on_result(StageResult(generation, stage, seconds=time.monotonic() - started, **payload))
        finally:
            receive.close()
            process.join(timeout=5)


def _idle() -> None:
    pass
