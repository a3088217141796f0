"""Units: pencilbot measures everything physical in millimetres; an inch, where one appears
(G20 programs, SVG sizes, dots per inch), is this many."""

MM_PER_INCH = 25.4
