"""The virtual plotter's G-code interpreter: modal state, offsets, pen, planner, clock.

:class:`Machine` takes one *filtered* line at a time (what GRBL's protocol loop stores: no
whitespace, no comments, upper case — see :func:`sim.gcode.lines.filter_line`). :meth:`Machine.parse`
checks it as GRBL 1.1h's parser does (:mod:`sim.gcode.parser`: the status code of the first
failing check, or a :class:`~sim.gcode.parser.Block`); :meth:`Machine.execute` carries a block
out in GRBL's order of execution (feed, spindle, coolant, dwell, plane, units, tool length,
coordinate system, distance, G10/G28/G30/G92, motion, program flow). Execution is a generator
that yields :data:`~sim.gcode.motion_control.WAIT` wherever GRBL's main loop would block (planner full, a buffer
synchronise for a pen change, dwell, offset change or program stop) and :data:`~sim.gcode.motion_control.PAUSE` for an
``M0``, so the firmware answers ``ok`` when GRBL would.

Motion: G0/G1, G2/G3 arcs cut into chords by ``$12`` (:mod:`sim.gcode.arcs`), G38.2–G38.5 probes
(this plotter has no probe: G38.2/G38.3 run to the target without contact, G38.4/G38.5 fail at
once), G28/G30 via a point to the stored positions, G53 machine moves, G93 inverse time.
G54–G59, G28 and G30 positions live in :attr:`Machine.coord_data` (the board's EEPROM: kept
through resets and power cycles); G92 and G43.1 are cleared by a reset.

The machine is a profile (:mod:`pencilbot.machine`, the neutral description) and its pen is the
profile's :class:`~pencilbot.machine.pen.PenModel`: a *spindle* pen is down while M3/M4 is on
with S closer to the profile's ``down`` than ``up``; a *z* pen while Z is closer to ``down``; a
*servo* pen while the last ``M280`` angle is (``M280`` is refused as by real GRBL unless the machine is made with
``servo=True``). Moves are queued by GRBL's motion control (:mod:`sim.gcode.motion_control`: soft
limits, dwell, homing, stop), planned (:mod:`sim.gcode.planner`) and, as they complete, recorded
(:mod:`sim.recorder`): pen-down moves become :attr:`Machine.strokes` and pen-up moves
:attr:`Machine.travel`. Its ``$`` settings start from the profile's (:mod:`sim.gcode.settings`).

Machine coordinates run from 0 to the bed size (negative if the profile inverts an axis) when
the machine's position is true. Where the carriage really is differs by :attr:`Machine.slip`
once the position is lost: a power cycle restarts the count at 0, 0, 0 wherever the carriage
stands (:meth:`power_on`), a stop in motion lets it coast on (:meth:`stop` with ``lose``);
homing (``$H``) makes the two agree again. Strokes are recorded where the pen really went.
With soft limits on (``$20=1``) a target outside the travel raises :class:`~sim.gcode.motion_control.MachineAlarm`.
"""

from __future__ import annotations

import math

from firmware_protocol import grbl
from pencilbot.machine.profile import Profile
from sim.gcode import parser as gp
from sim.gcode.arcs import arc_chords
from sim.gcode.motion_control import PAUSE, SOFT_LIMIT_ALARM, WAIT, MachineAlarm, MotionControl
from sim.gcode.planner import Block, Planner
from sim.gcode.settings import grbl_settings
from sim.gcode.state import given
from sim.recorder import StrokeRecorder

PROBE_INITIAL_ALARM, PROBE_CONTACT_ALARM = 4, 5
TRAVEL_EXCEEDED = 15


class Machine(StrokeRecorder):
    """A GRBL 1.1h interpreter driving a planner and a virtual clock.

    Parameters
    ----------
    profile : pencilbot.machine.profile.Profile
        The machine: bed and switches, pen model and motion limits (which seed GRBL's settings).
    instant : bool
        True: whenever the machine has to wait for motion (planner full, a pen change, a
        dwell) the clock jumps ahead at once. False: the caller advances the clock with
        :meth:`advance` and resumes an execution that yielded :data:`WAIT`.
    servo : bool
        Accept ``M280 P S`` servo-angle commands (a servo-pen extension; GRBL answers error 23).
    """

    def __init__(self, profile: Profile, *, instant: bool = True, servo: bool = False):
        super().__init__()
        self.profile = profile
        self.pen = profile.pen_model
        self.instant = instant
        self.servo = servo
        self.settings = grbl_settings(profile)
        self.coord_data: list[tuple[float, ...]] = [(0.0, 0.0, 0.0)] * 8  # G54..G59, G28, G30
        self.planner = Planner(profile.firmware.protocol.BLOCK_BUFFER_SIZE - 1)
        self.motion = MotionControl(self.planner, profile.bed, instant=instant, complete=self._complete)
        self.settings_changed()
        self.pauses = 0  # M0 pauses the program has reached (a colour job: its pen changes)
        self.messages: list[str] = []  # lines for the firmware to print, in order
        self.alarm = 0  # a non-critical alarm (probe) raised while executing, for the firmware
        self.offsets_changed = False  # a WCO change the next status report must show
        self.slip: tuple[float, ...] = (0.0,) * 3  # where the carriage is minus where GRBL counts it (mm)
        #: Pen-down ink a coasting carriage laid past the end of its move (start, end X, Y in mm):
        #: off the job's path, where no sender can take it back.
        self.overruns: list[tuple[tuple[float, ...], tuple[float, ...]]] = []
        self.probe_position: tuple[float, ...] = (0.0, 0.0, 0.0)
        self.probe_succeeded = False
        self.servo_angle = self.pen.up
        self.check_mode = False
        self.state = gp.ParserState(self.coord_data)
        self.reset_modes()

    # --- modal state ------------------------------------------------------------------------

    def settings_changed(self) -> None:
        """Take what the motion reads from the settings: the stepper idle lock, ``$1`` ms, on a
        firmware that waits it out (GRBL 1.1; 255 keeps the motors on and waits nothing)."""
        lock = self.settings[1]
        self.planner.idle_lock = lock / 1000.0 if self.profile.firmware.idle_lock and lock != 255 else 0.0

    def reset_modes(self) -> None:
        """A reset's parser state (GRBL's gc_init): default modes, G54 loaded, G92, tool length
        and probe cleared, the parser's position synced to the machine's."""
        here = self.machine_position()
        self.state = gp.ParserState(self.coord_data, position=here, coord_system=self.coord_data[0])
        self.probe_position, self.probe_succeeded = (0.0, 0.0, 0.0), False
        self.check_mode = False
        self.offsets_changed = True

    def power_on(self, *, zero: bool) -> None:
        """The board restarts (power or DTR reset): motion gone, modes reset; ``zero``: its
        position count restarts at 0, 0, 0 wherever the carriage is, as an AVR's RAM does."""
        self.stop()
        if zero:
            here = self.machine_position()
            self.slip = tuple(s + h for s, h in zip(self.slip, here))
            self.state.position = (0.0, 0.0, 0.0)
        self.servo_angle = self.pen.up  # the servo signal stops; the pen lifts
        self.reset_modes()

    @property
    def position(self) -> tuple[float, ...]:
        """Where the parser believes the tool is (machine mm)."""
        return self.state.position

    @position.setter
    def position(self, value) -> None:
        self.state.position = tuple(value)

    @property
    def pen_down(self) -> bool:
        pen = self.pen
        if pen.kind == "z":
            return pen.is_down(self.position[2] + self.slip[2])
        if pen.kind == "servo":
            return pen.is_down(self.servo_angle)
        return self.state.modal.spindle in (3, 4) and pen.is_down(self.spindle_output())

    def spindle_output(self) -> float:
        """The speed the PWM delivers for S (GRBL's spindle_compute_pwm_value): 0 for S0,
        else clamped to ``$31``..``$30``."""
        s, low, high = self.state.spindle_speed, self.settings[31], self.settings[30]
        if low >= high or s >= high:
            return high
        if s <= low:
            return 0.0 if s == 0 else low
        return s

    def work_offset(self) -> tuple[float, ...]:
        """WCO (mm): the active coordinate system + G92 + tool length offset."""
        return self.state.work_offset()

    def work_position(self) -> tuple[float, ...]:
        """Machine position minus the work offset (mm)."""
        return tuple(m - o for m, o in zip(self.machine_position(), self.work_offset()))

    def machine_position(self) -> tuple[float, ...]:
        """Where GRBL counts the tool now (mid-move in real-time mode)."""
        p = self.planner
        if p.executing is not None:
            return p.executing.point_at(p.elapsed)
        if p.queue:
            return p.queue[0].start
        return self.position

    def carriage_position(self) -> tuple[float, ...]:
        """Where the carriage really is: the machine position plus :attr:`slip`."""
        return tuple(m + s for m, s in zip(self.machine_position(), self.slip))

    def limit_pins(self) -> str:
        """Limit switches pressed (``Pn:`` letters): with homing, a switch sits just outside the
        origin corner's edges (where ``$H`` pulls off from) and closes when the carriage is
        pushed past it."""
        if not self.profile.bed.homing:
            return ""
        pulloff = self.settings[27]
        here = self.carriage_position()
        pressed = ""
        for axis, inverted in (("X", self.profile.bed.invert_x), ("Y", self.profile.bed.invert_y)):
            value = here["XY".index(axis)]
            if (value > 1e-9) if inverted else (value < -pulloff - 1e-9):
                pressed += axis
        return pressed

    def current_speed(self) -> float:
        """Speed along the executing move (mm/s), 0 at rest."""
        p = self.planner
        return p.executing.speed_at(p.elapsed) if p.executing is not None else 0.0

    # --- motion (GRBL's motion_control.c, on :attr:`motion`) ---------------------------------

    def _soft_limit_exceeded(self, target) -> bool:
        return self.motion.soft_limit_exceeded(target, self.settings)

    def _queue_line(self, target, *, rapid: bool, feed: float | None = None, checked: bool = False):
        """GRBL's mc_line: soft limits, check mode, wait for a planner slot, plan the move."""
        if not checked and self._soft_limit_exceeded(target):
            self.stop()
            raise MachineAlarm(SOFT_LIMIT_ALARM)
        if self.check_mode:
            self.position = target
            return
        yield from self.motion.room()
        start, pen_before = self.position, self.pen_down
        self.position = target
        length = math.dist(start, target)
        if length >= 1e-9:
            nominal = None if rapid else (self.state.feed if feed is None else feed) / 60.0
            pen = pen_before and (self.pen.kind != "z" or self.pen_down)
            self.motion.plan(start, target, length, nominal=nominal, pen_down=pen, settings=self.settings)

    def _dwell(self, seconds: float):
        if not self.check_mode:
            yield from self.motion.dwell(seconds)

    def _synchronize(self):
        yield from self.motion.synchronize()

    def advance(self, seconds: float) -> None:
        """Real-time mode: let ``seconds`` of machine time pass."""
        self.motion.advance(seconds)

    def finish(self) -> None:
        """Complete all queued motion (instant mode)."""
        if not self.check_mode:
            self.motion.finish()

    def home(self):
        """``$H``: seek the switches at ``$25``, locate at ``$24``, pull off ``$27`` (a generator).

        The carriage ends at the origin corner (X and Y; a pen plotter homes no Z) and GRBL's
        count agrees with it again. Non-inverted axes read 0 there (a positive work space needs
        HOMING_FORCE_SET_ORIGIN), inverted ones −``$27`` (GRBL's negative space).
        """
        pulloff, seek, feed = self.settings[27], self.settings[25], self.settings[24]
        start = self.carriage_position()
        bed = self.profile.bed
        home = (-pulloff if bed.invert_x else 0.0, -pulloff if bed.invert_y else 0.0, start[2])
        distance = math.dist(start[:2], home[:2])
        seconds = (distance + pulloff) / (seek / 60.0) + 2 * pulloff / (feed / 60.0)
        yield from self._dwell(seconds)
        self._record(start, home, self.pen_down)
        self.close_stroke()
        self.slip = (0.0, 0.0, self.slip[2])
        self.position = (home[0], home[1], start[2] - self.slip[2])

    def stop(self, *, lose: bool = False) -> bool:
        """Halt at once (reset, alarm): drop planned moves. True if the machine was moving.

        ``lose``: the motors stop dead but the carriage coasts on for its stopping distance
        (v²/2a along the move), so GRBL's count no longer says where it is.
        """
        p = self.planner
        moving = p.busy
        first = p.executing or (p.queue[0] if p.queue else None)
        # In instant mode the machine stands at the start of the first queued move, at the speed
        # the planner entered it with (never more than it can stop from by the move's end).
        speed = self.current_speed() if p.executing is not None else (first.entry if first else 0.0)
        here = self.machine_position()  # moves not yet started are dropped, not reached
        self.motion.discard()
        self.position = here
        if lose and first is not None and speed > 0:
            coast = speed * speed / (2.0 * first.accel)
            start = self.carriage_position()
            self.slip = tuple(s + u * coast for s, u in zip(self.slip, first.unit))
            self._record(start, self.carriage_position(), first.pen_down)
            left = math.dist(here, first.end)  # of the move, before it runs past its end
            if first.pen_down and coast > left:
                end = self.carriage_position()
                self.overruns.append(
                    (tuple(e - u * (coast - left) for e, u in zip(end, first.unit))[:2], end[:2])
                )
        self.close_stroke()
        return moving

    # --- parsing and execution --------------------------------------------------------------

    def _complete(self, blocks: list[Block]) -> None:
        """Blocks the planner finished: where the carriage really went (count plus slip), recorded."""
        slip = self.slip
        for b in blocks:
            start = (b.start[0] + slip[0], b.start[1] + slip[1])
            end = (b.end[0] + slip[0], b.end[1] + slip[1])
            self._record(start, end, b.pen_down)

    def parse(self, line: str, *, jog: bool = False) -> gp.Block | int:
        """Check one filtered line against the current state (see :func:`sim.gcode.parser.parse_block`)."""
        return gp.parse_block(line, self.state, jog=jog, servo=self.servo)

    def execute(self, block: gp.Block):
        """Carry out a checked block in GRBL's order; a generator (see the module docstring).

        Raises
        ------
        MachineAlarm
            A target lies outside the soft limits; the planner has been stopped.
        """
        s, m = self.state, block.modal
        was_down = self.pen_down
        s.line_number = block.line_number
        s.modal.inverse_time = m.inverse_time
        s.feed = block.feed
        if block.spindle_speed != s.spindle_speed:
            if s.modal.spindle != 5:
                yield from self._synchronize()  # GRBL's spindle_sync: the pen moves when motion ends
            s.spindle_speed = block.spindle_speed
        s.tool = block.tool
        if m.spindle != s.modal.spindle:
            yield from self._synchronize()
            s.modal.spindle = m.spindle
        if m.coolant != s.modal.coolant:
            yield from self._synchronize()
            s.modal.coolant = m.coolant
        if block.servo_angle is not None:
            yield from self._synchronize()
            self.servo_angle = block.servo_angle
        if block.non_modal == 4:
            yield from self._dwell(block.dwell)
        s.modal.plane, s.modal.units_mm = m.plane, m.units_mm
        if block.axis_command == gp.TOOL_LENGTH_AXES:
            s.modal.tool_length = m.tool_length
            if block.tool_length_offset != s.tool_length_offset:
                s.tool_length_offset = given(block.tool_length_offset)
                yield from self._offsets_changed()
        if m.coord_select != s.modal.coord_select:
            s.modal.coord_select, s.coord_system = m.coord_select, block.coord_system
            yield from self._offsets_changed()
        s.modal.absolute = m.absolute
        yield from self._non_modal(block)
        s.modal.motion = m.motion
        if m.motion != gp.NO_MOTION and block.axis_command == gp.MOTION_AXES:
            yield from self._motion(block)
        if was_down and not self.pen_down and not self.planner.busy:
            self.close_stroke()  # lifted in place: a later pen-down starts a new stroke
        if m.program_flow:
            yield from self._synchronize()
            if m.program_flow == gp.PAUSE:
                if not self.check_mode:
                    self.pauses += 1
                    yield PAUSE
            else:
                self._program_end()

    def apply(self, block: gp.Block) -> None:
        """Execute ``block`` to its end with no firmware in front: where GRBL would wait, the
        clock runs on (real-time mode); an ``M0`` pause is passed at once."""
        for signal in self.execute(block):
            if signal == WAIT:
                self.advance(0.001)

    def _non_modal(self, block: gp.Block):
        s, code = self.state, block.non_modal
        if code == 10:
            index, offset = given(block.coord_write)
            yield from self._synchronize()  # an EEPROM write
            self.coord_data[index] = offset
            if s.modal.coord_select == index:
                s.coord_system = offset
                yield from self._offsets_changed()
        elif code in (28, 30):
            if block.axis_command:
                yield from self._queue_line(block.target, rapid=True)
            yield from self._queue_line(block.home, rapid=True)
        elif code in (28.1, 30.1):
            yield from self._synchronize()
            self.coord_data[gp.G28_INDEX if code == 28.1 else gp.G30_INDEX] = s.position
        elif code == 92:
            s.coord_offset = given(block.coord_offset)
            yield from self._offsets_changed()
        elif code == 92.1:
            s.coord_offset = (0.0, 0.0, 0.0)
            yield from self._offsets_changed()

    def _motion(self, block: gp.Block):
        motion, target = block.modal.motion, block.target
        if motion in (gp.SEEK, gp.LINEAR):
            feed = block.feed
            if block.modal.inverse_time and motion == gp.LINEAR:
                feed *= math.dist(self.position, given(target))  # F is 1/minutes for the whole move
            yield from self._queue_line(target, rapid=motion == gp.SEEK, feed=feed)
        elif motion in (gp.CW_ARC, gp.CCW_ARC):
            offset, radius, clockwise = given(block.arc)
            chords, count = arc_chords(
                self.position, target, offset, radius, block.axes, clockwise, self.settings[12]
            )
            feed = block.feed
            if block.modal.inverse_time:
                # As GRBL's mc_arc: F times the chord count, then taken as mm/min for each chord
                # (an arc too small for a chord stays one inverse-time move).
                feed *= count if count else math.dist(self.position, given(target))
            for point in chords:
                yield from self._queue_line(tuple(point), rapid=False, feed=feed)
        else:
            yield from self._probe(block)

    def _probe(self, block: gp.Block):
        """G38.x on a plotter without a probe input: nothing ever touches."""
        if self.check_mode:
            self.position = block.target
            return
        yield from self._synchronize()
        away, no_error = block.modal.motion in (38.4, 38.5), block.modal.motion in (38.3, 38.5)
        self.probe_succeeded = False
        if away:  # "away" needs the probe touching at the start
            self._raise(PROBE_INITIAL_ALARM)
            return
        yield from self._queue_line(block.target, rapid=False, feed=block.feed)
        yield from self._synchronize()
        if no_error:
            self.probe_position = self.machine_position()
        else:
            self._raise(PROBE_CONTACT_ALARM)
        coords = grbl.format_coords(self.probe_position, inches=bool(self.settings[13]))
        self.messages.append(f"[PRB:{coords}:0]")

    def _raise(self, code: int) -> None:
        """A non-critical alarm: the firmware prints it and locks G-code; the line still ends ``ok``."""
        self.alarm = code
        self.messages.append(f"ALARM:{code}")

    def _program_end(self) -> None:
        """M2 / M30: GRBL resets G1 G17 G90 G94 G54 M5 M9 (units, tool length, G92, F S T stay)."""
        s = self.state
        m = s.modal
        m.motion, m.plane, m.absolute, m.inverse_time = gp.LINEAR, 0, True, False
        m.coord_select, m.spindle, m.coolant = 0, 5, 9
        if not self.check_mode:
            s.coord_system = self.coord_data[0]
            self.offsets_changed = True
        self.messages.append("[MSG:Pgm End]")

    def _offsets_changed(self):
        """A WCO change: GRBL (FORCE_BUFFER_SYNC_DURING_WCO_CHANGE) waits for motion to end."""
        self.offsets_changed = True
        yield from self._synchronize()

    def jog_target_allowed(self, block: gp.Block) -> int:
        """0, or 15 when soft limits are on and a jog's target is outside the travel."""
        return TRAVEL_EXCEEDED if self._soft_limit_exceeded(block.target) else 0

    def jog(self, block: gp.Block):
        """A ``$J=`` move at its own F that leaves the parser's modes untouched (a generator)."""
        yield from self._queue_line(block.target, rapid=False, feed=block.feed, checked=True)

    @property
    def clock(self) -> float:
        """Simulated seconds of motion and dwell since power-on."""
        return self.planner.clock
