"""Units: pencilbot measures everything physical in millimetres; an inch, where one appears
(G20 programs, SVG sizes, dots per inch), is this many."""

MM_PER_INCH = 25.4

#: CSS pixels per inch: the unit of an SVG's user space when its size has no unit (Inkscape,
#: vpype and svgelements read it so).
CSS_PX_PER_INCH = 96.0

#: Pen width (mm) when nothing says otherwise: a common fineliner, and the default style's pen.
DEFAULT_PEN_WIDTH = 0.5
