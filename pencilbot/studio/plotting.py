"""Plots started from the page: :func:`pencilbot.api.draw` in a thread per plotter.

The page's buttons reach the driver through the two interfaces it already has for a terminal:
:class:`WebKeys` (pause / resume, stop, as :class:`~pencilbot.driver.keys.KeyReader` does) and
:class:`WebOperator` (pen-change and re-zero prompts, as
:class:`~pencilbot.driver.keys.TerminalOperator` does), answered from the page's dialogs. What the
page shows comes from the driver's progress records (lines acknowledged, the line the machine
is running, its position). A plot belongs to the server, not to a tab: closing the page does not
stop it, and a new page sees it. One plot per plotter at a time.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from pencilbot.driver.faults import Interrupted
from pencilbot.errors import PencilbotError, PlotError

STOP_BY = "the stop button of the studio page"
_WAIT = 0.1  # s between looks at the page's requests while a prompt is open


class WebKeys:
    """The page's pause and stop buttons, polled by the stream (a :class:`KeyReader`'s interface)."""

    def __init__(self):
        self._requests: queue.Queue[str] = queue.Queue()

    def press(self, request: str) -> None:
        self._requests.put(request)

    def poll(self) -> list[str]:
        requests = []
        while True:
            try:
                requests.append(self._requests.get_nowait())
            except queue.Empty:
                return requests


class WebOperator:
    """The person at the page: answers the driver's prompts through :attr:`PlotSession.prompt`.

    Each prompt has its own ``id``; an answer counts only for the prompt it names (the page sends
    the id of the dialog it showed), so a double click, or a press that arrives late, can never
    answer the next prompt (a skipped pen change draws one colour with another pen)."""

    def __init__(self, session: PlotSession):
        self.session = session
        self.answers: queue.Queue[tuple] = queue.Queue()
        self.asked = 0

    def answer(self, prompt, *answer) -> None:
        """An answer to the prompt whose ``id`` is ``prompt`` (None: the prompt open now)."""
        current = self.session.prompt
        if prompt is None and current is not None:
            prompt = current["id"]
        self.answers.put((prompt, *answer))

    def _ask(self, kind: str, text: str, **extra):
        self.asked += 1
        asked = self.asked
        self.session.set(prompt={"kind": kind, "text": text, "id": asked, **extra})
        try:
            while True:
                if self.session.stop_requested.is_set():
                    raise Interrupted(STOP_BY)
                try:
                    prompt, *answer = self.answers.get(timeout=_WAIT)
                except queue.Empty:
                    continue
                if prompt == asked:  # an answer to an earlier dialog is dropped
                    yield answer
        finally:
            self.session.set(prompt=None)

    def pause(self, prompt: str) -> None:
        for answer in self._ask("pause", prompt):
            if answer[0] == "go":
                return

    def jog_to_mark(self, prompt, mark, jog) -> None:
        for answer in self._ask("rezero", prompt):
            if answer[0] == "go":
                return
            if answer[0] == "give up":
                raise PlotError(
                    "re-zero abandoned; nothing was drawn. Resume again when the pen can be jogged"
                )
            if answer[0] == "jog":
                jog(answer[1], answer[2])


@dataclass
class PlotSession:
    """One plot on one plotter, as the page sees it (``status``: running, done, stopped)."""

    port: str
    profile: str
    gcode: Path
    url: str
    on_change: Callable[[], None] | None = None
    status: str = "starting"
    record: dict = field(default_factory=dict)
    prompt: dict | None = None
    message: str = ""
    resumable: bool = False
    started: float = field(default_factory=time.time)
    keys: WebKeys = field(default_factory=WebKeys)
    stop_requested: threading.Event = field(default_factory=threading.Event)
    thread: threading.Thread | None = None

    def __post_init__(self):
        self.operator = WebOperator(self)

    @property
    def active(self) -> bool:
        return self.thread is not None and self.thread.is_alive()

    def set(self, **values) -> None:
        for key, value in values.items():
            setattr(self, key, value)
        if self.on_change is not None:
            self.on_change()

    def summary(self) -> dict:
        return {
            "port": self.port,
            "profile": self.profile,
            "status": self.status,
            "record": self.record,
            "prompt": self.prompt,
            "message": self.message,
            "resumable": self.resumable,
            "active": self.active,
            "started": self.started,
        }

    def start(self, resume: bool = False) -> None:
        self.stop_requested.clear()
        self.keys = WebKeys()
        self.set(status="running", message="", resumable=False, prompt=None, record={})
        self.thread = threading.Thread(
            target=self._run, args=(resume,), name=f"plot {self.port}", daemon=True
        )
        self.thread.start()

    def _listen(self, record: dict) -> None:
        if record.get("event") == "progress":
            if "xy" in record:
                from pencilbot.studio.drawn_json import view_of

                record["view"] = view_of(self.profile, record["xy"])
            self.set(record={**self.record, **record})

    def _run(self, resume: bool) -> None:
        from pencilbot import api
        from pencilbot.driver.journal import journal_path

        try:
            result = api.draw(
                self.gcode,
                self.url,
                profile=self.profile,
                operator=self.operator,
                keys=self.keys,
                on_progress=self._listen,
                resume=journal_path(self.gcode) if resume else None,
            )
            self.set(
                status="done",
                message=f"drew {result.lines_sent} lines in {result.seconds:.1f} s",
                record={**self.record, "percent": 100.0, "eta_s": 0.0},
            )
        except PencilbotError as err:
            from pencilbot.studio.words import page_words

            resumable = journal_path(self.gcode).is_file()
            self.set(
                status="stopped", message=page_words(str(err), self.gcode, resumable), resumable=resumable
            )
        except Exception as err:  # noqa: BLE001 - the page must hear of anything, not a silent thread
            self.set(status="stopped", message=f"the plot stopped: {err!r}")

    # --- the page's buttons ----------------------------------------------------------------

    def press(self, button: str, dx: float = 0.0, dy: float = 0.0, prompt=None) -> None:
        """``pause`` (toggles hold), ``stop``, ``go`` (answer a prompt), ``jog``, ``give up``;
        ``go``, ``jog`` and ``give up`` answer only the prompt whose ``id`` is ``prompt`` (None:
        the one open now)."""
        if button == "stop":
            self.stop_requested.set()
            self.keys.press("stop")
        elif button == "pause":
            self.keys.press("pause")
        elif button in ("go", "give up"):
            self.operator.answer(prompt, button)
        elif button == "jog":
            self.operator.answer(prompt, "jog", dx, dy)


class Plotters:
    """The plot sessions by port: at most one running per plotter."""

    def __init__(self, on_change=None):
        self.sessions: dict[str, PlotSession] = {}
        self.on_change = on_change
        self._lock = threading.Lock()

    def start(self, port: str, url: str, profile: str, gcode: Path) -> PlotSession:
        with self._lock:
            old = self.sessions.get(port)
            if old is not None and old.active:
                raise PlotBusy(f"{port} is plotting already; stop that plot first")
            session = PlotSession(port, profile, gcode, url, on_change=self.on_change)
            self.sessions[port] = session
            session.start()
            return session

    def resume(self, port: str) -> PlotSession:
        with self._lock:
            session = self.sessions.get(port)
            if session is None or session.active or not session.resumable:
                raise PlotBusy(f"{port} has no stopped plot to resume")
            session.start(resume=True)
            return session

    def get(self, port: str) -> PlotSession:
        session = self.sessions.get(port)
        if session is None:
            raise KeyError(port)
        return session

    def summary(self) -> list[dict]:
        return [session.summary() for session in self.sessions.values()]


class PlotBusy(PencilbotError):
    """A plotter that is plotting already (or has nothing to resume)."""
