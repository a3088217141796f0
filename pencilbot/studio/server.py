"""Run the studio: uvicorn on the chosen address, the URL said, the browser opened."""

from __future__ import annotations

import socket
import sys
import threading
import webbrowser
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pencilbot.driver import stop_signals
from pencilbot.errors import PencilbotError
from pencilbot.studio import tables
from pencilbot.studio.guard import is_loopback, new_token

if TYPE_CHECKING:
    from pencilbot.studio.state import Studio


@dataclass
class Running:
    """A studio being served: its state, uvicorn's server, the URL to open (with any token)."""

    studio: Studio
    server: Any  # uvicorn.Server (uvicorn ships no types)
    url: str
    sock: socket.socket

    def serve(self) -> list[str]:
        """Serve until :meth:`stop` or a stop signal (in the main thread: Ctrl-C, SIGTERM, SIGHUP,
        SIGQUIT); every plot then stops with the pen up. Returns what to tell the person: each
        stopped plot kept, and how to resume it (see :meth:`Studio.close`)."""
        solver = tables.start()
        try:
            self.server.run(sockets=[self.sock])
        finally:
            tables.stop(solver)
            said = self.studio.close()
            self.sock.close()
        return said

    def stop(self) -> None:
        self.studio.closing = True
        self.studio.changed()
        self.server.should_exit = True


def prepare(
    photo: Path | None = None,
    *,
    port: str | None = None,
    profile: str = "",
    host: str = "127.0.0.1",
    listen_port: int = 8765,
    sim_speed: float = 1.0,
    stages=None,
) -> Running:
    """Bind the address, start the planner, take the photo: a :class:`Running` ready to serve."""
    import uvicorn

    from pencilbot.studio.app import create_app
    from pencilbot.studio.connections import HeaderTimeoutProtocol
    from pencilbot.studio.state import Studio

    token = None if is_loopback(host) else new_token()
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, listen_port))
    except OSError as err:
        sock.close()
        raise PencilbotError(
            f"cannot listen on {host}:{listen_port} ({err.strerror}); give another --listen-port"
        ) from None
    sock.listen(128)  # the URL is said before uvicorn runs: a browser that comes at once waits in the backlog
    bound = sock.getsockname()[1]
    studio = Studio(ports=(port,) if port else (), profile=profile, sim_speed=sim_speed, stages=stages)
    try:
        studio.planner.warm_up()
        if photo is not None:
            studio.set_photo(Path(photo).read_bytes(), Path(photo).name)
    except BaseException:
        studio.close()
        sock.close()
        raise
    app = create_app(studio, host=host, port=bound, token=token)
    shown = f"[{host}]" if ":" in host else host
    url = f"http://{shown}:{bound}/" + (f"?token={token}" if token else "")
    config = uvicorn.Config(
        app, log_level="warning", lifespan="off", timeout_graceful_shutdown=2, http=HeaderTimeoutProtocol
    )

    class Server(uvicorn.Server):
        @contextmanager
        def capture_signals(self):
            """The stop signals of every plot (:mod:`pencilbot.driver.stop_signals`), not
            uvicorn's two: each ends the server as Ctrl-C does, and none is raised again after
            (uvicorn's re-raised SIGTERM killed the process before a plot's pen was lifted)."""
            with stop_signals.caught(self.stop_by):
                yield

        def stop_by(self, by: str) -> None:
            studio.closing = True  # the page's event streams end first
            studio.changed()
            self.force_exit = self.should_exit  # a second signal: do not wait for connections
            self.should_exit = True

    return Running(studio, Server(config), url, sock)


def serve(
    photo: Path | None = None,
    *,
    port: str | None = None,
    profile: str = "",
    host: str = "127.0.0.1",
    listen_port: int = 8765,
    browser: bool = True,
    sim_speed: float = 1.0,
    out=None,
) -> None:
    """Serve the studio until Ctrl-C.

    Parameters
    ----------
    photo : Path, optional
        A photo to start with (its bytes are kept in the server's own folder).
    port : str, optional
        A plotter port to list besides the ones found.
    profile : str
        The plotter profile chosen at first ("": the user's default).
    host : str
        Address to listen on; off the loopback a token is required (printed in the URL).
    listen_port : int
        TCP port of the page (0: any free one).
    browser : bool
        Open the page in the user's browser.
    sim_speed : float
        The virtual plotter's speed over real time.
    """
    running = prepare(
        photo, port=port, profile=profile, host=host, listen_port=listen_port, sim_speed=sim_speed
    )
    note = "; the token in it is needed from other machines" if "token=" in running.url else ""
    print(
        f"pencilbot studio: {running.url}  (Ctrl-C stops the server{note})",
        file=out or sys.stdout,
        flush=True,
    )
    if browser:
        threading.Timer(0.5, webbrowser.open, args=(running.url,)).start()
    for line in running.serve():
        print(f"pencilbot studio: {line}", file=out or sys.stdout, flush=True)
