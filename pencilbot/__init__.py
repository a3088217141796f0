"""pencilbot: photo → GMED pencil drawing → pen-plotter strokes → G-code → plotter.

The library API (see :mod:`pencilbot.api`): ``sketch``, ``plan``, ``export_gcode``, ``gcode``, ``write_svg``,
``read_svg``, ``draw`` (``DrawOptions``), ``open_control``, ``load_image``. They are imported on first use, so the CLI starts without
loading them.
"""

__version__ = "0.1.0"

_API = (
    "sketch",
    "plan",
    "export_gcode",
    "gcode",
    "write_svg",
    "read_svg",
    "draw",
    "DrawOptions",
    "load_image",
    "as_image",
    "open_control",
)
__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        from pencilbot import api

        return getattr(api, name)
    raise AttributeError(f"module 'pencilbot' has no attribute {name!r}")
