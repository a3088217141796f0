"""Plotters by name: the nickname an EBB board keeps in its flash (``ST`` sets it, ``QT`` reads it),
as AxiDraw's software finds a named AxiDraw among several."""

from __future__ import annotations

from pencilbot.driver.ebb.link import EbbFault, EbbLink, greet, version_at_least
from pencilbot.driver.port import LineReader, PortLost, open_port
from pencilbot.errors import PlotError

QT_SINCE = (2, 5, 4)  # QT: firmware 2.5.4 and newer (EBB reference)
ASK_TIMEOUT = 1.0  # s for one board's answer


def nickname(device: str) -> str | None:
    """The nickname of the EBB board on ``device`` ("" when none is set); None when no EBB board
    answers there, or its firmware has no nicknames."""
    try:
        reader = LineReader(open_port(device))
    except PlotError:
        return None
    try:
        link = EbbLink(reader, ASK_TIMEOUT)
        if not version_at_least(greet(link), QT_SINCE):
            return None
        return (link.command("QT").data or "").strip()
    except (EbbFault, PortLost, IndexError, ValueError):
        return None
    finally:
        reader.port.close()


def find_named(name: str, devices: list[str] | None = None) -> str | None:
    """The port of the EBB board whose nickname is ``name`` (case as given), among ``devices``
    (default: the EBB boards the system's serial ports answer as); None if none is."""
    if devices is None:
        from pencilbot.driver.ports import find_plotters

        devices = [p.device for p in find_plotters() if p.plotter == "EBB"]
    return next((device for device in devices if nickname(device) == name), None)
