"""Stream G-code to a pen plotter over serial and survive what real hardware does.

``draw(gcode, port, ...)`` is the one entry point for scripts (its options as keywords or one
:class:`~pencilbot.driver.plot.DrawOptions`); ``pencilbot draw`` is its CLI.
The pieces: :mod:`~pencilbot.driver.gcode.job` (a file ready to stream), :mod:`~pencilbot.driver.gcode.stream`
(the one streaming core, over any firmware of the registry), :mod:`~pencilbot.driver.plot` (a job
from start to end), :mod:`~pencilbot.driver.gcode.runner` (its run on the board, faults turned into
messages by :mod:`~pencilbot.driver.messages`), :mod:`~pencilbot.driver.gcode.resume`,
:mod:`~pencilbot.driver.gcode.resume_point` and :mod:`~pencilbot.driver.journal` (continuing a stopped
job).
"""

from pencilbot.driver.plot import DrawOptions, draw
from pencilbot.driver.result import DrawResult

__all__ = ["DrawOptions", "DrawResult", "draw"]
