"""The firmware registry: one module per firmware, each declaring what the others ask of it.

The G-code writer (dwell units, line numbers, how ``G0`` takes a feed), the driver (framing and
validation, what a reply means, the receive budget, capabilities) and the virtual plotter (which
protocol to speak) look a firmware up here by a profile's ``dialect`` and never compare names.
"""

from __future__ import annotations

from pencilbot.firmware.base import Firmware
from pencilbot.firmware.ebb import EBB
from pencilbot.firmware.grbl import GRBL
from pencilbot.firmware.grblhal import GRBLHAL
from pencilbot.firmware.hpgl import HPGL
from pencilbot.firmware.marlin import MARLIN

REGISTRY: dict[str, Firmware] = {firmware.name: firmware for firmware in (GRBL, GRBLHAL, MARLIN, HPGL, EBB)}


def names() -> tuple[str, ...]:
    """Every registered firmware's name (what a profile's ``dialect`` may be)."""
    return tuple(REGISTRY)


def get(name: str) -> Firmware:
    """The firmware called ``name`` (``KeyError`` if none is registered)."""
    return REGISTRY[name]
