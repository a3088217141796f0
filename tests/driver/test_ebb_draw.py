"""An EBB plotter (AxiDraw V3) driven end to end: a plan of coffee exported as G-code, drawn over
``sim://`` on the virtual EBB; stops, resumes and lost positions."""

import json

import numpy as np
import pytest
from shapely.geometry import LineString
from skimage import data

import pencilbot
from pencilbot.driver.journal import journal_path
from pencilbot.errors import PlotError
from pencilbot.export.gcode import write_gcode
from pencilbot.machine.bed import Placement
from pencilbot.machine.profile import load_profile
from pencilbot.planning.stats import estimate
from sim import protocol_sim

PROFILE = "axidraw-v3"
TOLERANCE = 0.05  # mm: a motor step is 1/80 mm; the issue asks 0.05
STEP = 1 / 80  # mm of X per motor step on an AxiDraw at 16x


def _joined(strokes):
    """Strokes with a stop inside them put back together (the resume starts exactly where the
    stop left the pen, so the pieces meet at the very same point)."""
    out = []
    for stroke in strokes:
        if out and np.array_equal(out[-1][-1], stroke[0]):
            out[-1] = np.vstack([out[-1], stroke[1:]])
        else:
            out.append(np.asarray(stroke))
    return out


def _length(line):
    return float(np.hypot(*np.diff(line, axis=0).T).sum())


def drawing_differences(got, reference, tolerance, clean=None):
    """What differs between the drawn strokes and the plan's, in words (empty: the same).

    Stroke by stroke, in order: as many strokes, each within ``tolerance`` of its planned path
    (Hausdorff distance) and as long (a part left out or drawn twice changes the length; plans
    retrace their own hatching, so coverage by segment cannot tell). Drawn vertices sit on the
    motor-step grid, which may add up to a step's length per vertex; against ``clean`` (the
    strokes of an uninterrupted run, on the same grid) the lengths must agree to ``tolerance``."""
    got = _joined(got)
    if len(got) != len(reference):
        return [f"{len(got)} strokes drawn, {len(reference)} planned"]
    problems = []
    for k, (g, r) in enumerate(zip(got, reference)):
        if len(r) < 2:
            r = np.vstack([r, r])
        far = LineString(g).hausdorff_distance(LineString(r)) if len(g) > 1 else np.inf
        if clean is not None:
            want, slack = _length(clean[k]), tolerance
        else:
            want, slack = _length(r), tolerance + len(r) * STEP
        if far > tolerance or abs(_length(g) - want) > slack:
            problems.append(
                f"stroke {k}: {far:.4f} mm from the plan, {_length(g):.3f} mm drawn of {want:.3f}"
            )
    return problems


@pytest.fixture(scope="module")
def coffee(tmp_path_factory):
    plan = pencilbot.plan(data.coffee()[::8, ::8], page="100x70")
    profile = load_profile(PROFILE)
    path = tmp_path_factory.mktemp("ebb") / "coffee.gcode"
    write_gcode(plan, profile, path)
    placement = Placement.on_bed(plan.page, profile.bed)
    reference = [placement.to_machine(p) for p in plan.paths()]
    return plan, profile, path, reference


@pytest.fixture
def name(request):
    key = "ebb-" + "".join(c if c.isalnum() else "-" for c in request.node.name)
    yield key
    protocol_sim.forget(key)


@pytest.fixture(scope="module")
def clean(coffee):
    """Coffee drawn without interruption: the board after it, finished."""
    _, _, path, _ = coffee
    pencilbot.draw(path, "sim://ebb-clean", profile=PROFILE)
    board = protocol_sim.plotter("ebb-clean")
    board.firmware.finish()
    yield board
    protocol_sim.forget("ebb-clean")


def test_coffee_is_drawn_as_planned_every_stroke_once_in_the_estimated_time(coffee, clean):
    plan, profile, _, reference = coffee
    got = list(clean.drawn())
    assert drawing_differences(got, reference, tolerance=TOLERANCE) == []
    assert len(got) == len(reference)  # one pen-down stroke per planned path
    expected = estimate(plan, profile).total.seconds
    assert abs(clean.seconds / expected - 1) < 0.02
    assert clean.firmware.gaps == []  # the queue never ran dry once the first move ran


def test_a_board_left_in_future_syntax_draws_the_same(coffee, name):
    _, _, path, reference = coffee
    port = f"sim://{name}?profile={PROFILE}"
    with protocol_sim.Serial(port) as link:  # another program left it in future syntax
        link.write(b"CU,10,1\r")
        assert link.read(1) == b"\n"
    pencilbot.draw(path, port, profile=PROFILE)
    board = protocol_sim.plotter(name)
    assert board.firmware.future
    assert drawing_differences(list(board.drawn()), reference, tolerance=TOLERANCE) == []


def _journal(path):
    where = journal_path(path)
    assert where.exists(), "no journal written"
    return where, json.loads(where.read_text())


def test_a_stop_mid_job_resumes_exactly_once(coffee, clean, name, tmp_path):
    _, _, path, reference = coffee
    job = tmp_path / "coffee.gcode"
    job.write_bytes(path.read_bytes())
    port = f"sim://{name}?profile={PROFILE}&faults=error@700"
    with pytest.raises(PlotError) as stopped:
        pencilbot.draw(job, port, profile=PROFILE)
    assert "Resume with: pencilbot draw --resume" in str(stopped.value)
    assert "the pen stopped at X" in str(stopped.value)
    board = protocol_sim.plotter(name)
    partial = board.drawn()
    assert 0 < len(partial) < len(reference)
    journal, record = _journal(job)
    assert record["status"] == "stopped" and len(record["options"]["ebb_resume"]) == 1
    pencilbot.draw(job, f"sim://{name}", resume=journal)
    board.firmware.finish()
    assert drawing_differences(list(board.drawn()), reference, TOLERANCE, clean=list(clean.drawn())) == []


def test_a_lost_cable_resumes_exactly_once_from_the_step_counters(coffee, clean, name, tmp_path):
    _, _, path, reference = coffee
    job = tmp_path / "coffee.gcode"
    job.write_bytes(path.read_bytes())
    with pytest.raises(PlotError) as stopped:
        pencilbot.draw(job, f"sim://{name}?profile={PROFILE}&faults=drop@900", profile=PROFILE)
    assert "did not report where the pen stopped" in str(stopped.value)
    journal, record = _journal(job)
    assert len(record["options"]["ebb_resume"]) >= 2  # the ends of the commands in flight
    pencilbot.draw(job, f"sim://{name}", resume=journal)
    board = protocol_sim.plotter(name)
    board.firmware.finish()
    assert drawing_differences(list(board.drawn()), reference, TOLERANCE, clean=list(clean.drawn())) == []


def test_a_power_cut_is_refused_until_the_position_is_known_again(coffee, name, tmp_path):
    _, _, path, _reference = coffee
    job = tmp_path / "coffee.gcode"
    job.write_bytes(path.read_bytes())
    port = f"sim://{name}?profile={PROFILE}&faults=reset@700"
    with pytest.raises(PlotError) as stopped:
        pencilbot.draw(job, port, profile=PROFILE, timeout=1.0)
    assert "position is lost" in str(stopped.value)
    board = protocol_sim.plotter(name)
    drawn_before = len(board.drawn().points)
    journal, _ = _journal(job)
    with pytest.raises(PlotError) as refused:
        pencilbot.draw(job, f"sim://{name}", resume=journal, timeout=1.0)
    assert "position is lost" in str(refused.value) and "nothing was sent" in str(refused.value)
    assert len(board.drawn().points) == drawn_before  # the refusal moved nothing


def test_a_supply_dip_mid_job_stops_it_and_the_resume_is_refused(coffee, name, tmp_path):
    _, _, path, _ = coffee
    job = tmp_path / "coffee.gcode"
    job.write_bytes(path.read_bytes())
    with pytest.raises(PlotError) as stopped:  # the dip comes at command 700; QG finds it soon after
        pencilbot.draw(job, f"sim://{name}?profile={PROFILE}&faults=abort@700", profile=PROFILE)
    assert "supply dropped" in str(stopped.value) and "position is lost" in str(stopped.value)
    journal, _ = _journal(job)
    with pytest.raises(PlotError) as refused:
        pencilbot.draw(job, f"sim://{name}", resume=journal)
    assert "position is lost" in str(refused.value)


@pytest.mark.parametrize("fault, stops", [("garbage@700", False), ("silent@700", True)])
def test_noise_is_ignored_and_a_lost_answer_stops_exactly(coffee, clean, name, tmp_path, fault, stops):
    _, _, path, reference = coffee
    job = tmp_path / "coffee.gcode"
    job.write_bytes(path.read_bytes())
    port = f"sim://{name}?profile={PROFILE}&faults={fault}"
    if stops:
        with pytest.raises(PlotError) as stopped:
            pencilbot.draw(job, port, profile=PROFILE, timeout=0.5)
        assert "did not answer" in str(stopped.value) and "the pen stopped at X" in str(stopped.value)
        journal, _ = _journal(job)
        pencilbot.draw(job, f"sim://{name}", resume=journal)
    else:
        pencilbot.draw(job, port, profile=PROFILE)
    board = protocol_sim.plotter(name)
    board.firmware.finish()
    assert drawing_differences(list(board.drawn()), reference, TOLERANCE, clean=list(clean.drawn())) == []


def test_plan_moves_never_shorter_than_the_boards_minimum(coffee):
    from pencilbot.driver.ebb.moves import rows as _rows
    from pencilbot.driver.gcode.job import load_job
    from pencilbot.machine.ebb_motion import plan_ebb

    _, profile, path, _ = coffee
    job = load_job(path, profile)
    xy, down, lines = _rows(job)
    moves = plan_ebb(xy, down, lines, profile)
    lm = [m.seconds for m in moves if m.command.startswith("LM")]
    assert min(lm) >= profile.ebb.min_move_ms / 1000 - 1e-9


class _Operator:
    """Someone at the plotter: notes each pause and where the pen was when it came."""

    def __init__(self, name):
        self.name, self.seen = name, []

    def pause(self, prompt):
        board = protocol_sim.plotter(self.name)
        self.seen.append(
            (prompt, board.firmware.pen_up, board.firmware.running is None and not board.firmware.fifo)
        )


def _colour_job(path):
    from pencilbot.machine.pens import load_pens
    from pencilbot.planning.plan import Layer, Page, Plan

    inks = {pen.name: pen for pen in load_pens("cmyk").pens}
    layers = []
    for k, pen in enumerate(("yellow", "magenta", "black")):
        x = 20.0 + 30.0 * k
        lines = [np.array([[x, 20.0 + y], [x + 20.0, 20.0 + y]]) for y in np.arange(0.0, 6.0, 1.0)]
        layers.append(
            Layer(f"{pen}-hatch", lines, pen_width=0.5, role="hatch", pen=pen, color=inks[pen].color)
        )
    plan = Plan(Page(120.0, 80.0, margin=5.0, name="test"), tuple(layers))
    profile = load_profile(PROFILE)
    write_gcode(plan, profile, path)
    placement = Placement.on_bed(plan.page, profile.bed)
    return [placement.to_machine(p) for p in plan.paths()]


def test_pen_changes_pause_at_rest_with_the_pen_up_and_name_the_pen(name, tmp_path):
    job = tmp_path / "colour.gcode"
    reference = _colour_job(job)
    operator = _Operator(name)
    pencilbot.draw(job, f"sim://{name}", profile=PROFILE, operator=operator)
    prompts = [prompt for prompt, _, _ in operator.seen]
    assert [p.split("insert ")[-1] for p in prompts] == ["yellow", "magenta", "black"]
    assert all(pen_up and idle for _, pen_up, idle in operator.seen)
    board = protocol_sim.plotter(name)
    assert drawing_differences(list(board.drawn()), reference, TOLERANCE) == []


def test_without_an_operator_a_pause_waits_for_the_prg_button(name, tmp_path):
    job = tmp_path / "colour.gcode"
    reference = _colour_job(job)
    pencilbot.draw(job, f"sim://{name}?profile={PROFILE}&operator=auto", profile=PROFILE)
    board = protocol_sim.plotter(name)
    assert board.firmware.log.count("QB") >= 2 * 3  # each pause: forget old presses, then wait for one
    assert drawing_differences(list(board.drawn()), reference, TOLERANCE) == []


def test_sigterm_mid_plot_over_a_pty_stops_and_resumes_exactly_once(tmp_path):
    """The real CLI in another process, the board on a pseudo-terminal at 20x real time."""
    import signal
    import subprocess
    import sys
    import time

    from pencilbot.planning.plan import Layer, Page, Plan
    from sim.ebb.plotter import VirtualEbb
    from sim.pty_server import PtyServer

    profile = load_profile(PROFILE)
    lines = [np.array([[10.0, 10.0 + 2 * k], [40.0, 11.0 + 2 * k], [70.0, 10.0 + 2 * k]]) for k in range(12)]
    plan = Plan(
        Page(100.0, 80.0, margin=5.0, name="test"), (Layer("hatch", lines, pen_width=0.5, role="hatch"),)
    )
    job = tmp_path / "lines.gcode"
    write_gcode(plan, profile, job)
    placement = Placement.on_bed(plan.page, profile.bed)
    reference = [placement.to_machine(p) for p in plan.paths()]
    pencilbot.draw(job, "sim://ebb-sigterm-clean", profile=PROFILE)
    clean = protocol_sim.plotter("ebb-sigterm-clean")
    clean.firmware.finish()
    protocol_sim.forget("ebb-sigterm-clean")
    plotter = VirtualEbb(profile, realtime=20)
    cli = [sys.executable, "-m", "pencilbot.cli", "draw"]
    with PtyServer(plotter, reset_on_open=False) as server:
        proc = subprocess.Popen(
            [*cli, str(job), "--profile", PROFILE, "-q", "--port", server.path],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + 60
        while len(plotter.drawn()) < 4 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode != 0 and "stopped by SIGTERM" in err and "the pen stopped at X" in err, err
        journal, _ = _journal(job)
        done = subprocess.run(
            [*cli, "--resume", str(journal), "-q"], capture_output=True, text=True, timeout=120
        )
        assert done.returncode == 0, done.stderr
    plotter.firmware.finish()
    assert drawing_differences(list(plotter.drawn()), reference, TOLERANCE, clean=list(clean.drawn())) == []


def test_arcs_from_other_tools_are_drawn_as_arcs(name, tmp_path):
    """G2/G3 by I J and by R, as another tool writes them: the pen follows the circle."""
    job = tmp_path / "arcs.gcode"
    job.write_text(
        "G21\nG90\nM280 P0 S60\nG0 X60 Y50\nM280 P0 S30\nG2 X60 Y50 I20 J0 F3000\n"
        "G3 X100 Y50 R20\nM280 P0 S60\nG0 X0 Y0\n"
    )
    pencilbot.draw(job, f"sim://{name}", profile=PROFILE)
    board = protocol_sim.plotter(name)
    board.firmware.finish()
    (stroke,) = list(board.drawn())
    # Both arcs lie on the circle of centre (80, 50), radius 20 (the R arc's centre computed as GRBL does).
    assert np.allclose(np.hypot(stroke[:, 0] - 80, stroke[:, 1] - 50), 20, atol=0.02)
    angles = np.degrees(np.arctan2(stroke[:, 1] - 50, stroke[:, 0] - 80))
    assert np.ptp(angles) > 350 and len(stroke) > 100  # all the way round, in many chords
    length = float(np.hypot(*np.diff(stroke, axis=0).T).sum())
    assert length == pytest.approx(2 * np.pi * 20 + np.pi * 20, abs=0.1)  # a circle, then half of one


class _Keys:
    """The terminal's keys: the pause key pressed once, at the ``at``-th look."""

    def __init__(self, at):
        self.at, self.looks = at, 0

    def poll(self):
        self.looks += 1
        return ["pause"] if self.looks == self.at else []


def test_the_pause_key_holds_mid_stroke_and_goes_on_from_the_very_point(coffee, clean, name):
    _, _, path, reference = coffee
    operator = _Operator(name)
    pencilbot.draw(
        path, f"sim://{name}?profile={PROFILE}", profile=PROFILE, operator=operator, keys=_Keys(900)
    )
    assert [prompt for prompt, _, _ in operator.seen] == ["paused: the pause key"]
    assert all(pen_up and idle for _, pen_up, idle in operator.seen)  # held: the pen up, nothing moving
    board = protocol_sim.plotter(name)
    board.firmware.finish()
    assert drawing_differences(list(board.drawn()), reference, TOLERANCE, clean=list(clean.drawn())) == []
