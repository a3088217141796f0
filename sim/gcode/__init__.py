"""The virtual GRBL board (GRBL 1.1, grblHAL): the protocol front end (:mod:`.firmware`, its `$`
lines, status reports and line log), the G-code machine (:mod:`.machine`: parser, arcs, settings,
motion control, look-ahead planner) and the plotter that puts them behind wires (:mod:`.plotter`)."""
