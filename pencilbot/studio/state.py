"""What one studio server holds: the photo, the newest plan's stages, the plots.

Files live only in a temporary folder the server made (the photo as uploaded, the G-code of a
plot and its journal); nothing the page sends is used as a path.
"""

from __future__ import annotations

import shutil
import struct
import tempfile
import threading
import time
from dataclasses import asdict
from pathlib import Path

from pencilbot.errors import PencilbotError
from pencilbot.imaging.io import DEFAULT_MAX_PIXELS, LoadedImage
from pencilbot.studio.machine import Controls
from pencilbot.studio.options import DrawingOptions
from pencilbot.studio.planner import LivePlanner, StageResult, png_bytes
from pencilbot.studio.plotting import Plotters
from pencilbot.studio.sheet import Placement, placed
from pencilbot.units import CSS_PX_PER_INCH, MM_PER_INCH

#: Upright pixels of the photo thumbnail the page shows.
THUMBNAIL_PIXELS = 160_000


class Studio:
    """The server's state; ``version`` grows with every change the page should see."""

    def __init__(
        self, *, ports: tuple[str, ...] = (), profile: str = "", sim_speed: float = 1.0, stages=None
    ):
        self.folder = Path(tempfile.mkdtemp(prefix="pencilbot-studio-"))
        self.ports, self.profile, self.sim_speed = ports, profile, sim_speed
        self.version = 0
        self.closing = False  # the server is stopping: event streams end
        self._changed = threading.Condition()
        self.photo: Path | None = None
        self.small: LoadedImage | None = None
        self.photo_name = ""
        self.thumbnail = b""
        self.options = DrawingOptions(profile=profile)
        self.results: dict[str, StageResult] = {}
        self.planner = LivePlanner(
            self._on_result, on_progress=self._on_progress, **({"stages": stages} if stages else {})
        )
        self.placement = Placement()  # where the person put the drawing on the sheet
        self.progress: dict = {}  # the newest generation's planning step
        self.plotters = Plotters(on_change=self.changed)
        self.controls = Controls()  # the machine controls' open port
        self._uploads = 0
        self.photo_number = 0  # photos taken: a page shows a new one when this grows
        self.photo_info: dict | None = None

    def changed(self) -> None:
        with self._changed:
            self.version += 1
            self._changed.notify_all()

    def wait_change(self, seen: int, timeout: float) -> int:
        """Wait until ``version`` passes ``seen`` (or ``timeout`` s); the version then."""
        with self._changed:
            self._changed.wait_for(lambda: self.version != seen, timeout=timeout)
            return self.version

    def close(self) -> list[str]:
        """Stop planning and every plot (pen up: a plot must not go on unwatched), keep each
        stopped plot's G-code and journal in the user's state folder (they are all that resumes
        it), remove the server's folder. Returns what to tell the person: each kept plot and the
        command that resumes it."""
        self.closing = True
        self.changed()
        self.planner.cancel()
        self.controls.release()
        for session in self.plotters.sessions.values():
            if session.active:
                session.press("stop")
        for session in self.plotters.sessions.values():
            if session.thread is not None:
                session.thread.join(timeout=30)
        said = []
        for session in self.plotters.sessions.values():
            if session.resumable and session.gcode.is_file():
                said.append(
                    f"the plot on {session.port} stopped with the pen up; "
                    f"{keep_stopped(session.gcode, session.port)}"
                )
        shutil.rmtree(self.folder, ignore_errors=True)
        return said

    # --- making the drawing ----------------------------------------------------------------

    def set_photo(self, data: bytes, name: str = "") -> dict:
        """Keep an uploaded photo (checked: an image of at most the pixel limit) and plan it."""
        from PIL import Image, UnidentifiedImageError

        from pencilbot.imaging.io import load_image

        self._uploads += 1
        if is_svg(data, name):
            return self._set_svg(data, name)
        path = self.folder / f"photo-{self._uploads}"
        path.write_bytes(data)
        try:
            with Image.open(path) as img:  # the header only: nothing is decoded before the checks
                width, height = img.size
        except Image.DecompressionBombError:
            path.unlink(missing_ok=True)
            raise TooLarge(
                f"the photo has more pixels than the {DEFAULT_MAX_PIXELS:,} pencilbot reads "
                "(more than the image library even opens); shrink it first"
            ) from None
        except (UnidentifiedImageError, OSError, ValueError, SyntaxError, EOFError, IndexError, struct.error):
            path.unlink(missing_ok=True)
            raise PencilbotError(
                "that file is not an image pencilbot can read; give a PNG, JPEG, TIFF, BMP or WebP file"
            ) from None
        if width * height > DEFAULT_MAX_PIXELS:
            path.unlink(missing_ok=True)
            raise TooLarge(
                f"the photo has {width} × {height} pixels, more than the {DEFAULT_MAX_PIXELS:,} "
                "pencilbot reads; shrink it first"
            )
        scale = min(1.0, (THUMBNAIL_PIXELS / max(width * height, 1)) ** 0.5)
        small = load_image(
            path, shrink_to=lambda shape: (max(1, round(shape[0] * scale)), max(1, round(shape[1] * scale)))
        )
        # the coarse stage plans ``small``, not the file: no decoding per change
        return self._take(path, name, png_bytes(small.rgb), small, {"width": width, "height": height})

    def _set_svg(self, data: bytes, name: str) -> dict:
        """Keep an uploaded SVG drawing (checked: the library's reader reads it) and plan it."""
        from pencilbot.export.svg_read import read_svg
        from pencilbot.planning.preview import preview_image

        path = self.folder / f"photo-{self._uploads}.svg"
        path.write_bytes(data)
        try:
            drawing = read_svg(path, dpi=CSS_PX_PER_INCH)
        except PencilbotError as err:
            path.unlink(missing_ok=True)
            said = str(err).replace(str(path), name[:200] or "the SVG")  # never the server's folder
            raise PencilbotError(f"that SVG cannot be drawn: {said}") from None
        if not any(len(layer.paths) for layer in drawing.layers):
            path.unlink(missing_ok=True)
            raise PencilbotError("that SVG has no lines to draw")
        page = drawing.page
        dpi = MM_PER_INCH * (THUMBNAIL_PIXELS / max(page.width * page.height, 1.0)) ** 0.5
        size = {"svg": True, "width": round(page.width, 1), "height": round(page.height, 1)}
        return self._take(path, name, png_bytes(preview_image(drawing, dpi)), None, size)

    def _take(self, path: Path, name: str, thumbnail: bytes, small, size: dict) -> dict:
        if self.photo is not None:
            self.photo.unlink(missing_ok=True)  # the folder keeps one photo
        self.thumbnail, self.small = thumbnail, small
        self.photo, self.photo_name = path, name[:200]
        self.photo_number += 1
        self.photo_info = {"name": self.photo_name, **size, "number": self.photo_number}
        self.plan()
        return self.photo_info

    def set_options(self, options: DrawingOptions) -> int:
        self.options = options
        return self.plan()

    def plan(self) -> int:
        if self.photo is None:
            return 0
        generation = self.planner.submit(self.photo, self.options, self.small)
        self.changed()
        return generation

    def _on_result(self, result: StageResult) -> None:
        if result.stage == "coarse" or result.error:
            self.results.pop("full", None)
        self.results[result.stage] = result
        self.changed()

    def _on_progress(self, generation: int, step: dict) -> None:
        self.progress = {"generation": generation, **step}
        self.changed()

    def raw_plan(self):
        """The newest full plan as planned (before the person's placement)."""
        result = self.results.get("full")
        if result is None or result.plan is None or result.generation != self.planner.generation:
            raise PencilbotError("the drawing is not planned yet; wait until the full preview shows")
        return result.plan

    def full_plan(self):
        """The newest full plan as it goes to the plotter: placed, skipped layers left out."""
        return placed(self.raw_plan(), self.placement)

    def summary(self) -> dict:
        stages = {
            name: {
                "generation": r.generation,
                "figures": r.figures,
                "error": r.error,
                "seconds": round(r.seconds, 3),
            }
            for name, r in self.results.items()
        }
        return {
            "version": self.version,
            "generation": self.planner.generation,
            "options": asdict(self.options),
            "photo": self.photo_info,
            "stages": stages,
            "progress": self.progress,
            "placement": self.placement.summary(),
            "plots": self.plotters.summary(),
        }


def is_svg(data: bytes, name: str) -> bool:
    """Whether an upload is an SVG drawing (by its start, or its name and an XML start)."""
    head = data[:4096].lstrip(b"\xef\xbb\xbf \t\r\n")
    return b"<svg" in head or (name.lower().endswith(".svg") and head.startswith(b"<"))


class TooLarge(PencilbotError):
    """An upload over the size or pixel limit (413)."""


def keep_stopped(gcode: Path, port: str) -> str:
    """Copy a stopped plot's G-code out of the server's folder into the user's state folder,
    its journal beside it (naming the copy); the sentence that says where and how to resume."""
    from pencilbot.driver import journal as journal_mod

    journal = journal_mod.load_journal(journal_mod.journal_path(gcode))
    folder = journal_mod.state_dir()
    folder.mkdir(parents=True, exist_ok=True)
    kept = folder / f"studio-{time.strftime('%Y%m%d-%H%M%S')}-{gcode.name}"
    shutil.copyfile(gcode, kept)
    journal.gcode, journal.path = str(kept.resolve()), journal_mod.journal_path(kept)
    journal.port = journal.port or port
    journal.resume = journal_mod.resume_command(journal)
    journal.save()
    return f"its G-code and journal are kept in {folder}. Resume with: {journal.resume}"
