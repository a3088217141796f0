"""The virtual EiBotBoard (AxiDraw, NextDraw, iDraw): the board (:mod:`.board`: FIFO, steps on the
25 kHz tick, servo, queries) and the plotter that records its drawing behind wires (:mod:`.plotter`)."""
