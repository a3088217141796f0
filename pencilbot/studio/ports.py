"""The plotters the page may choose: the serial ports found, and the virtual plotter.

One small function, so that the shared port probe (``pencilbot ports``) can take its place.
"""

from __future__ import annotations

import urllib.parse

VIRTUAL = "sim://"


def plotter_ports(extra: tuple[str, ...] = ()) -> list[dict]:
    """``[{"port": ..., "title": ...}]``: the virtual plotter, ``extra`` (``--port``) and every
    serial port pyserial lists."""
    from serial.tools import list_ports

    found = [{"port": VIRTUAL, "title": "virtual plotter (sim://)"}]
    found += [{"port": port, "title": f"{port} (given)"} for port in extra if port != VIRTUAL]
    for info in sorted(list_ports.comports(), key=lambda info: info.device):
        if info.device not in extra:
            found.append({"port": info.device, "title": f"{info.device} ({info.description})"})
    return found


def port_url(port: str, profile: str, sim_speed: float) -> str:
    """What to open for ``port``: the virtual plotter gets the profile and its speed over real time,
    and a board of its own per profile (a board made for one firmware must not answer another's)."""
    if port != VIRTUAL:
        return port
    return f"sim://studio-{profile}?" + urllib.parse.urlencode(
        {"profile": profile, "realtime": f"{sim_speed:g}"}
    )
