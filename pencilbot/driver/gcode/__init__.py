"""The G-code family: a file read once into a job (:mod:`.job`, its modal state :mod:`.modal`,
coordinate systems :mod:`.coords`, bed check :mod:`.bed_check`, system lines :mod:`.system_lines`),
and its stream to a board that acknowledges lines (GRBL, grblHAL, Marlin): the session, the
streaming core, the runner, a stop located and a resume rebuilt (:mod:`.resume`, :mod:`.resume_point`),
the machine control (:mod:`.control`). The EBB family draws the same jobs, planned on the host."""
