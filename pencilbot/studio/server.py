"""Run the studio: uvicorn on the chosen address, the URL said, the browser opened."""

from __future__ import annotations

import sys
import threading
import webbrowser
from pathlib import Path

from pencilbot.errors import PencilbotError
from pencilbot.studio.guard import is_loopback, new_token


def serve(photo: Path | None = None, *, port: str | None = None, profile: str = "", host: str = "127.0.0.1",
          listen_port: int = 8765, browser: bool = True, sim_speed: float = 1.0, out=None) -> None:
    """Serve the studio until Ctrl-C.

    Parameters
    ----------
    photo : Path, optional
        A photo to start with (copied into the server's own folder).
    port : str, optional
        A plotter port to list besides the ones found.
    profile : str
        The plotter profile chosen at first ("" : the user's default).
    host : str
        Address to listen on; off the loopback a token is required (printed in the URL).
    listen_port : int
        TCP port of the page (0: any free one).
    browser : bool
        Open the page in the user's browser.
    sim_speed : float
        The virtual plotter's speed over real time.
    """
    import socket

    import uvicorn

    from pencilbot.studio.app import create_app
    from pencilbot.studio.state import Studio

    out = out or sys.stdout
    token = None if is_loopback(host) else new_token()
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, listen_port))
    except OSError as err:
        raise PencilbotError(f"cannot listen on {host}:{listen_port} ({err.strerror}); give another --listen-port") from None
    bound = sock.getsockname()[1]
    studio = Studio(ports=(port,) if port else (), profile=profile, sim_speed=sim_speed)
    try:
        studio.planner.warm_up()
        if photo is not None:
            studio.set_photo(Path(photo).read_bytes(), Path(photo).name)
        app = create_app(studio, host=host, port=bound, token=token)
        shown = f"[{host}]" if ":" in host else host
        url = f"http://{shown}:{bound}/" + (f"?token={token}" if token else "")
        print(f"pencilbot studio: {url}  (Ctrl-C stops the server{'; the token is needed off this machine' if token else ''})",
              file=out, flush=True)
        if browser:
            threading.Timer(0.5, webbrowser.open, args=(url,)).start()
        config = uvicorn.Config(app, log_level="warning", lifespan="off", timeout_graceful_shutdown=1)
        uvicorn.Server(config).run(sockets=[sock])
    finally:
        studio.close()
        sock.close()
