"""grblHAL: GRBL's protocol with a 1024-byte receive buffer and 256-character lines."""

from __future__ import annotations

from firmware_protocol import grblhal as protocol
from pencilbot.firmware.grbl import Grbl


class GrblHal(Grbl):
    """grblHAL in its default (extended, GRBL 1.1-compatible) protocol."""

    name = "grblhal"
    title = "grblHAL"
    protocol = protocol
    receive_buffer = protocol.RX_BUFFER_SIZE
    line_limit = protocol.LINE_BUFFER_SIZE - 1
    planner_blocks = protocol.BLOCK_BUFFER_SIZE - 1
    idle_lock = 0.0  # grblHAL de-energises the steppers from a timer callback and goes on
    paused_states = ("Hold", "Door", "Tool")  # "Tool": a manual tool change waits for cycle start


GRBLHAL = GrblHal()
