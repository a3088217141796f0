"""GRBL 1.1: character counting against a 128-byte buffer, realtime status, feed hold, ``$C``, ``$X``."""

from __future__ import annotations

import numpy as np

from firmware_protocol import grbl as protocol
from pencilbot.firmware import grbl_system
from pencilbot.firmware.base import ALARM, ERROR, OK, OTHER, RESET, STATUS, Capabilities, Firmware, Reply

_STILL = ("Idle", "Alarm", "Check", "Sleep")  # states in which nothing moves
# Byte tables: what GRBL's line buffer drops (whitespace, control characters, block delete), and
# what a line may not hold at all (non-ASCII, realtime commands).
_DROPPED = np.zeros(256, dtype=bool)
_DROPPED[list(protocol.DROPPED_BYTES)] = True
_ODD = np.zeros(256, dtype=bool)
_ODD[128:] = True
_ODD[list(protocol.REALTIME_BYTES)] = True


class Grbl(Firmware):
    """GRBL 1.1 (and firmware that speaks its protocol with other limits, see grblHAL)."""

    name = "grbl"
    title = "GRBL"
    protocol = protocol
    capabilities = Capabilities(
        status_reports=True,
        feed_hold=True,
        soft_reset=True,
        check_mode=True,
        unlock=True,
        realtime_protocol=True,
    )
    receive_buffer = protocol.RX_BUFFER_SIZE
    line_limit = protocol.LINE_BUFFER_SIZE - 1  # significant characters; the NUL takes the last
    planner_blocks = protocol.BLOCK_BUFFER_SIZE - 1  # the ring keeps one slot empty
    dwell_units = 1.0  # G4 P is seconds
    idle_lock = 0.025  # $1's default, 25 ms: st_go_idle's delay_ms, in the stepper interrupt
    # A board that just reset on port open ignores its first bytes: line ends wake it harmlessly.
    wake_bytes = b"\r\n\r\n"
    status_query = protocol.STATUS_QUERY
    feed_hold = protocol.FEED_HOLD
    cycle_start = protocol.CYCLE_START
    soft_reset = protocol.SOFT_RESET
    unlock_command = "$X"
    check_command = "$C"
    home_command = "$H"
    moving_states = ("Run", "Jog", "Home")
    paused_states: tuple[str, ...] = ("Hold", "Door")

    def frame(self, command: str, number: int = 0) -> bytes:
        return self.protocol.encode_line(command)

    def set_origin(self, x: float, y: float, z: str = "") -> str:
        return f"G10L20P0X{x:.4f}Y{y:.4f}{z}"  # the active system's offset, from the position

    def jog(self, dx: float, dy: float, feed: float) -> str:
        return f"$J=G91G21X{dx:.4f}Y{dy:.4f}F{feed:g}"  # relative, mm: the job's G90/G20 untouched

    idle_hold_setting = 1  # $1, step idle delay: 255 keeps the motors on at rest

    def origin_move(self, feed: float) -> str:
        return f"$J=G53G21X0Y0F{feed:g}"  # machine coordinates, the job's modal state untouched

    def check_lines(self, job) -> tuple[int, str] | None:
        a = np.frombuffer(job.frames, dtype=np.uint8)
        line_of = lambda at: np.searchsorted(job.offsets, at, side="right") - 1  # noqa: E731
        # What the line buffer keeps: no whitespace, control characters or block delete (the
        # newline of each line is one of those).
        dropped = np.bincount(line_of(np.flatnonzero(_DROPPED[a])), minlength=len(job))
        significant = np.diff(job.offsets) - dropped
        odd = np.flatnonzero(_ODD[a])
        suspects = np.union1d(np.flatnonzero(significant > self.line_limit), line_of(odd))
        return self._first_refused(job, suspects.tolist())

    def system_command(self, line: str) -> str | None:
        return grbl_system.command_name(line)

    def system_effect(self, name: str) -> tuple[str, str | None, bool]:
        ends = next((what for key, what in grbl_system.ENDS_JOB.items() if name.startswith(key)), None)
        return grbl_system.effect(name), ends, name == grbl_system.CHECK_MODE

    def waits_after(self, line: str) -> bool:
        return grbl_system.moves_alone(line)

    def system_covers(self, allowed: str, name: str) -> bool:
        return grbl_system.covers(allowed, name)

    def parse(self, text: str) -> Reply:
        message = self.protocol.parse_line(text)
        if isinstance(message, protocol.Ok):
            return Reply(OK, text)
        if isinstance(message, protocol.Error):
            return Reply(ERROR, text, f"error:{message.code} {message.text}: {message.explanation}")
        if isinstance(message, protocol.Alarm):
            return Reply(ALARM, text, f"ALARM:{message.code} {message.text}: {message.explanation}")
        if isinstance(message, protocol.Status):
            return Reply(STATUS, text, status=message)
        if isinstance(message, protocol.Welcome):
            return Reply(RESET, text, f"banner '{text.strip().split(' [')[0]}'")
        return Reply(OTHER, text)

    def is_moving(self, status) -> bool:
        # Hold:1: a feed hold still slowing the machine along its path.
        return status.state in self.moving_states or (status.state == "Hold" and status.substate == 1)

    def is_finished(self, status) -> bool:
        return status.state in ("Idle", "Check", "Sleep")  # asleep ($SLP, a job's last line): it runs no more

    def is_paused(self, status) -> bool:
        return status.state in self.paused_states

    def is_alarm(self, status) -> bool:
        return status.state == "Alarm"

    def is_at_rest(self, status) -> bool:
        return status.state in _STILL or (status.state == "Hold" and status.substate == 0)


GRBL = Grbl()
