"""Files from a plan: :mod:`~pencilbot.export.svg` (read back by :mod:`~pencilbot.export.svg_read`) and
:mod:`~pencilbot.export.gcode` for a plotter profile. Free functions over a plan and a machine
description; the plan knows nothing of them."""
