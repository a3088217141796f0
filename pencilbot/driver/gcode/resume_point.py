"""Where a stopped job continues: the board's position checked against what the stop proved.

A resume trusts the board only when it reports the proven stop position; a board that restarted
at 0, 0 where it stood gets the stop point back as its origin; with homing it homes; otherwise a
guided re-zero with the operator (:mod:`pencilbot.driver.position`) finds the stop on the lines
sent, or the resume is refused with what to do.
"""

from __future__ import annotations

import shlex

from pencilbot.driver import position
from pencilbot.driver.gcode.stream import Stream
from pencilbot.driver.messages import resume_command
from pencilbot.errors import PlotError
from pencilbot.units import MM_PER_INCH


class ResumePointFinder:
    """Finds the first line to send and the stop point of a resumed job, re-zeroing if need be.

    Parameters
    ----------
    job : Job
        The job being resumed.
    profile : Profile
        The plotter's profile (firmware, pen, bed, motion).
    port : str
        The port the job draws on (named in a refusal's command).
    operator : pencilbot.driver.position.Operator or None
        Someone at the machine to guide a re-zero; without one a lost position is a refusal.
    locator : pencilbot.driver.gcode.resume.StopLocator
        Locates a position on the job's lines.
    setup_command : callable
        ``setup_command(stream, line, doing)`` sends a line and refuses the job if the board
        refuses it.
    """

    def __init__(self, job, profile, port, operator, locator, setup_command):
        self.job, self.profile, self.port, self.operator = job, profile, port, operator
        self.firmware = profile.firmware
        self.pen = profile.pen_model
        self.locator, self.setup_command = locator, setup_command
        self._mark = None  # the mark of a hand re-zero

    def find(self, stream: Stream, journal) -> tuple[int, tuple[float, float] | None]:
        """The first line to send and the stop point, once the board's position is trusted."""
        fw, job = self.firmware, self.job
        status = stream.status
        alarm = status is not None and fw.is_alarm(status)
        mpos = stream.machine_position()
        restarted_at_zero = stream.restarted and position.near(mpos, (0.0, 0.0))
        recorded = job.index_of(journal.next_line), (tuple(journal.stop_xy) if journal.stop_xy else None)
        if not fw.capabilities.status_reports:
            # A board that cannot say where it is (Marlin) leaves only the acknowledgements: it
            # runs every move it acknowledged (it has no feed hold), so the first unanswered is next.
            return recorded
        sent = job.index_of(journal.sent_line) if journal.sent_line else recorded[0] - 1
        if journal.stop_work is not None:  # the stop proved where the pen stood
            if not alarm and position.near(mpos, journal.stop_mpos):
                return recorded
            if not alarm and restarted_at_zero:
                # The board restarted (DTR reset on open, power cut) and counts from 0, 0 where
                # the pen stood: that spot is the proven stop point.
                x, y = journal.stop_work
                # A Z pen's count restarted too; the stop raised it to its up height.
                z = f"Z{self.pen.up:.4f}" if self.pen.kind == "z" else ""
                self.setup_command(
                    stream, self.firmware.set_origin(x, y, z), "restoring the origin at the stop point"
                )
                return recorded
            if alarm and self.profile.bed.homing:
                self.setup_command(stream, self.firmware.home_command, "homing")
                return recorded
            why = (
                "the plotter is in alarm"
                if alarm
                else f"the plotter reports X{mpos[0]:.3f} Y{mpos[1]:.3f}, not where the job stopped"
                if mpos
                else "the plotter does not report its position"
            )
            here = self._reestablish(stream, why, alarm, recorded[0], journal)
            self._origin_from_stop(stream, here, tuple(journal.stop_work))
            return recorded
        if mpos is not None and not alarm and not restarted_at_zero:
            # The stop could not read the position; a board that kept its count tells it now.
            acked = job.index_of(journal.acked_line) if journal.acked_line else -1
            located = self.locator.locate(
                sent, self.locator.job_units(stream.work_position(), sent), answered=acked
            )
            if located is not None:
                return located
        return self._from_the_hand(stream, journal, sent, alarm)

    def _from_the_hand(self, stream: Stream, journal, sent: int, alarm: bool):
        """A stop whose position was not proven: re-zeroed by hand, the stop found on the lines in
        flight (by the board's count where the hand agrees with it, else by the hand)."""
        job = self.job
        why = (
            f"the job stopped where the plotter could not prove its position ({journal.message or 'unknown'})"
        )
        acked = job.index_of(journal.acked_line) if journal.acked_line else -1
        here = self._reestablish(stream, why, alarm, self.locator.flight_start(max(sent, acked)), journal)
        tolerance = self._rezero_tolerance()
        count = tuple(journal.count_work) if journal.count_work else None
        located = None
        if position.near(here, count, tolerance):
            # The hand agrees with the board's count at the stop: its motors did not slip, and
            # the count is exact where a hand is only as good as its finest step.
            located = self.locator.locate(sent, self.locator.job_units(count, sent), answered=acked)
        elif count is not None:
            # The count is where the motors stopped (on the move they ran: the board's own
            # path); the hand, where the carriage coasted to along that move.
            at = self.locator.locate(sent, self.locator.job_units(count, sent), answered=acked)
            if at is not None:
                located = self.locator.coasted(
                    at, self.locator.job_units(count, at[0]), self.locator.job_units(here, at[0]), tolerance
                )
        if located is None:
            # Found by the hand, after a carriage that may have run on past a move's end.
            located = self.locator.locate(
                sent,
                self.locator.job_units(here, sent),
                answered=acked,
                tolerance=tolerance,
                coast=position.coast_limit(self.profile.motion),
            )
        if located is None:
            raise PlotError(
                f"after the re-zero, the pen had stopped at X{here[0]:.3f} Y{here[1]:.3f}, which is not on the "
                f"last lines the plotter was sent (file lines {job.number(self.locator.flight_start(sent))}-"
                f"{job.number(sent)}); the origin is set again, so continue from the line you see drawn last "
                f"with: pencilbot draw {shlex.quote(str(journal.gcode))} --port {shlex.quote(self.port)} "
                "--start-line N"
            )
        index, stop_xy = located
        on_path = (
            stop_xy if stop_xy is not None else (job.state_after(index - 1).x, job.state_after(index - 1).y)
        )
        to_mm = MM_PER_INCH if job.state_after(max(index - 1, 0)).inches else 1.0
        self._origin_from_stop(stream, here, (on_path[0] * to_mm, on_path[1] * to_mm))
        return located

    def _rezero_tolerance(self) -> float:
        """How close to the stop a re-zero by this operator puts it (its finest jog step)."""
        return position.rezero_tolerance(step=getattr(self.operator, "jog_step", position.FINE_JOG_STEP))

    def _origin_from_stop(self, stream: Stream, here, stop) -> None:
        """After a hand re-zero that put the stop at ``here`` (work mm): if the stop point on the
        job's path (``stop``, mm: proven by the board, or the move the hand's point lies on) is
        within the hand's tolerance of it, it is the better of the two (a vertex exactly, a
        move across its width), so the origin is set again from it and the jog."""
        if not position.near(here, stop, self._rezero_tolerance()) or self._mark is None:
            return
        mark = self._mark.xy
        x, y = stop[0] + mark[0] - here[0], stop[1] + mark[1] - here[1]
        self.setup_command(stream, self.firmware.set_origin(x, y), "setting the origin from the stop point")

    def _reestablish(
        self, stream: Stream, why: str, alarm: bool, certain: int, journal
    ) -> tuple[float, float]:
        """Re-zero with the user (or refuse without one); where the pen stood, work mm."""
        to_mm = MM_PER_INCH if self.job.state_after(max(certain - 1, 0)).inches else 1.0
        mark = position.mark_before(self.job, certain, to_mm)
        if self.pen.kind == "z":
            # Its height is lost with the count: raising it by a number could plunge it.
            raise PlotError(
                f"{why}: the plotter's position cannot be trusted, and with a Z pen its height is lost too. "
                f"Raise the pen, home the machine or set its origin by hand at {mark.text} (with Z at the "
                "pen's up height), then continue with --start-line N from the line you see drawn last"
            )
        if self.operator is None or not self.firmware.capabilities.realtime_protocol:
            raise position.refusal(why, mark, resume_command(self.job, journal), self.profile.bed.homing)
        self._mark = mark
        return position.jog_to_mark(stream, self.profile, self.operator, mark, why, alarm)
