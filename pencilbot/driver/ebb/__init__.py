"""The EBB family (AxiDraw, NextDraw, iDraw): a G-code job's moves planned on the host and sent as
step commands (:mod:`.plot`), the board's commands and replies (:mod:`.link`), the guided re-zero
after a lost count (:mod:`.rezero`), the machine control (:mod:`.control`), boards by nickname
(:mod:`.names`)."""
