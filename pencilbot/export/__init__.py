"""Files from a plan: :mod:`~pencilbot.export.svg` (and reading it back) and
:mod:`~pencilbot.export.gcode` for a plotter profile. Free functions over a plan and a machine
description; the plan knows nothing of them."""
