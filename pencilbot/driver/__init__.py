"""Stream G-code to a pen plotter over serial and survive what real hardware does.

``draw(gcode, port, ...)`` is the one entry point for scripts; ``pencilbot draw`` is its CLI.
"""

from pencilbot.driver.job import DrawResult, draw

stream = draw  # the name CONTRACTS.md gives the streaming entry point

__all__ = ["DrawResult", "draw", "stream"]
