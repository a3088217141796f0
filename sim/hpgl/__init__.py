"""The virtual HP 7475A: the board (:mod:`.board`: buffer, carousel, device control, hard-clip
limits; :mod:`.shapes`: circles, arcs, rectangles as chords) and the plotter behind wires
(:mod:`.plotter`)."""
