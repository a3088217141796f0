"""What a plot did, whichever family drew it."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class DrawResult:
    """What :func:`~pencilbot.driver.plot.draw` did: lines sent, rejected line numbers
    (``--on-error continue``), time. (A finished job's journal is removed: there is nothing left
    to resume.)"""

    lines_sent: int
    rejected: list[int] = field(default_factory=list)
    seconds: float = 0.0
