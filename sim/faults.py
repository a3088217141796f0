"""Failures a virtual GRBL board can be made to show, keyed by the line they strike.

:class:`Faults` is parsed from the ``faults=`` option of a ``sim://`` URL (``KIND@LINE[:CODE]``);
:class:`sim.gcode.firmware.Firmware` delivers each as the line with that index arrives.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

FAULT_KINDS = ("error", "alarm", "silent", "drop", "reset", "abort", "garbage", "hold", "interrupt", "unplug")
_TIMED_KINDS = ("hold", "interrupt")  # what can strike between lines, at a moment
_DEFAULT_CODE = {"interrupt": 2}  # SIGINT: Ctrl-C at the sender's terminal
GARBAGE = b"\xfe\x13#~garb\xa7ge\r\n"


@dataclass(frozen=True)
class Faults:
    """Failures to inject, keyed by the 1-based index of the complete line received (blank
    lines count too: the index is the one in :attr:`Firmware.log`).

    ``error@k[:N]`` answers line k with ``error:N`` (default 20) without running it;
    ``alarm@k`` raises ALARM:1 (hard limit) instead of running line k; ``silent@k`` stops
    answering anything from line k on (a hung board); ``drop@k`` drops the link when line k
    arrives (the port raises, the board keeps its state); ``reset@k`` reboots the board instead
    of running line k (a power cut); ``abort@k`` soft-resets it as line k arrives (a Ctrl-X
    from another program: ``ALARM:3`` if it was moving, the position kept if it was idle); ``garbage@k`` sends a line of noise before the reply to line k;
    ``hold@k`` presses the machine's feed-hold button as line k arrives (it runs after ``~``);
    ``unplug@k`` pulls the cable and the board's power with it as line k arrives: the link
    drops, the board restarts (its count from 0, 0 where the carriage stands, as a power cut
    leaves it) and its start-up banner goes to nobody, so a sender that reconnects without
    resetting it (``reset=0``, a pty) finds it idle at 0, 0 with no banner, as a real one;
    ``interrupt@k[:SIGNAL]`` is the person at the sender's terminal: once the board has taken
    the bytes that brought line k, the sender's process gets signal SIGNAL (default 2, SIGINT:
    Ctrl-C; 15 SIGTERM, 1 SIGHUP), so a stop lands at an exact line instead of at a moment of
    the wall clock (the board runs line k as usual).

    ``hold`` and ``interrupt`` may instead strike at a moment of the machine's simulated clock
    (``interrupt@1.25s``: seconds of motion and dwell since power-on): the clock stops there for
    the pump that reaches it, so the machine is at the same point mid-move in every run.
    """

    at: dict[int, tuple[str, int]] = field(default_factory=dict)
    timed: list[tuple[float, str, int]] = field(default_factory=list)  # (seconds, kind, code), in order

    def next_due(self, now: float, until: float) -> tuple[float, str, int] | None:
        """The first timed fault after ``now`` up to ``until`` (s), taken off the list."""
        if self.timed and now < self.timed[0][0] <= until:
            return self.timed.pop(0)
        return None

    @classmethod
    def parse(cls, spec: str) -> Faults:
        """From ``"error@5:22,silent@40"``; raises ``ValueError`` with a readable message."""
        at, timed = {}, []
        for item in filter(None, (s.strip() for s in spec.split(","))):
            m = re.fullmatch(r"([a-z]+)@(?:(\d+)|(\d+(?:\.\d*)?)s)(?::(\d+))?", item)
            if m is None or m.group(1) not in FAULT_KINDS or (m.group(3) and m.group(1) not in _TIMED_KINDS):
                raise ValueError(
                    f"fault {item!r} is not KIND@LINE (KIND one of {', '.join(FAULT_KINDS)}; "
                    "error@LINE:CODE sets the error code) or KIND@SECONDSs (hold or interrupt)"
                )
            kind, code = m.group(1), int(m.group(4) or _DEFAULT_CODE.get(m.group(1), 20))
            if m.group(3):
                seconds = float(m.group(3))
                if not 0 < seconds < math.inf:
                    raise ValueError(
                        f"fault {item!r}: the moment must be a finite number of seconds after "
                        "power-on, more than 0 (the clock starts at 0)"
                    )
                timed.append((seconds, kind, code))
            else:
                at[int(m.group(2))] = (kind, code)
        return cls(at, sorted(timed))
