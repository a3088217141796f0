"""Stream G-code to a pen plotter over serial and survive what real hardware does.

``draw(gcode, port, ...)`` is the one entry point for scripts; ``pencilbot draw`` is its CLI.
The pieces: :mod:`~pencilbot.driver.job` (a file ready to stream), :mod:`~pencilbot.driver.stream`
(the one streaming core, over any firmware of the registry), :mod:`~pencilbot.driver.plot` (a job
from start to end), :mod:`~pencilbot.driver.runner` (its run on the board, faults turned into
messages by :mod:`~pencilbot.driver.messages`), :mod:`~pencilbot.driver.resume`,
:mod:`~pencilbot.driver.resume_point` and :mod:`~pencilbot.driver.journal` (continuing a stopped
job).
"""

from pencilbot.driver.plot import draw
from pencilbot.driver.runner import DrawResult

__all__ = ["DrawResult", "draw"]
