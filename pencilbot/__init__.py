"""pencilbot: photo → GMED pencil drawing → pen-plotter strokes → G-code → plotter."""

__version__ = "0.1.0"
