"""The progress listener a front end follows a plot with (the studio page): every record, whatever
the display mode, with the line the machine is running located from its reported position."""

from __future__ import annotations

import numpy as np
import pytest

from pencilbot import api
from pencilbot.driver.gcode.drawn import drawn_paths, drawn_with_lines
from pencilbot.driver.gcode.job import load_job
from pencilbot.driver.gcode.resume import StopLocator
from pencilbot.driver.progress import Progress
from pencilbot.errors import PlotError
from pencilbot.machine.profile import load_profile
from pencilbot.paths import Paths
from pencilbot.planning.plan import Layer, Page, Plan

PROFILE = "grbl-servo-a4"


def zigzag_plan(rows: int = 60) -> Plan:
    """Many short strokes: a plot whose machine trails the answered lines."""
    paths = [np.array([[20.0, 20.0 + 1.2 * i], [120.0, 20.0 + 1.2 * i]]) for i in range(rows)]
    return Plan(Page(210.0, 297.0), (Layer("hatch", Paths.of(paths), 0.5, "hatch"),))


def test_a_quiet_progress_still_tells_its_listener(capsys):
    records = []
    progress = Progress("quiet", 10, 20.0, listener=records.append)
    progress.update(10, 20.0, "Run", where=lambda: {"running": 7})
    progress.close("done")
    assert capsys.readouterr().out == ""
    assert records[0]["event"] == "progress" and records[0]["running"] == 7 and records[0]["line"] == 10
    assert records[-1]["event"] == "done"


def test_records_say_which_line_the_machine_runs_and_where(tmp_path):
    gcode = tmp_path / "zigzag.gcode"
    api.export_gcode(zigzag_plan(), PROFILE, gcode)
    records = []
    api.draw(
        gcode,
        f"sim://listener-records?profile={PROFILE}&realtime=200",
        profile=PROFILE,
        on_progress=records.append,
    )
    assert records[-1]["event"] == "done"
    moving = [r for r in records if r["event"] == "progress" and r.get("running") is not None]
    assert len(moving) >= 2
    job = load_job(gcode, load_profile(PROFILE))
    states = job.states(0, len(job)).columns
    for record in moving:
        index = job.index_of(record["running"])
        assert index <= record["line"] + 1  # never past the line after the last answered
        # The reported position lies on the move of the line located (or at its end).
        start = np.array([states["x"][index - 1], states["y"][index - 1]])
        end = np.array([states["x"][index], states["y"][index]])
        xy = np.array(record["xy"])
        seg = end - start
        t = 0.0 if not seg.any() else float(np.clip((xy - start) @ seg / (seg @ seg), 0, 1))
        assert np.hypot(*(start + t * seg - xy)) < 0.01


def test_drawn_lines_are_the_lines_that_reach_each_point(tmp_path):
    gcode = tmp_path / "zigzag.gcode"
    api.export_gcode(zigzag_plan(5), PROFILE, gcode)
    job = load_job(gcode, load_profile(PROFILE))
    paths, lines = drawn_with_lines(job)
    assert np.array_equal(paths.points, drawn_paths(job).points)
    assert len(lines) == len(paths.points) and np.all(np.diff(lines) > 0)
    states = job.states(0, len(job)).columns
    assert np.allclose(np.column_stack([states["x"][lines], states["y"][lines]]), paths.points)


def test_a_position_off_the_window_is_not_found_rather_than_a_crash(tmp_path):
    gcode = tmp_path / "zigzag.gcode"
    api.export_gcode(zigzag_plan(), PROFILE, gcode)
    profile = load_profile(PROFILE)
    job = load_job(gcode, profile)
    locator = StopLocator(job, profile)
    last = len(job) - 1
    # Where the first stroke is: far before the last 60 lines sent (it used to read a line
    # before the window and raise IndexError, inside the stop sequence of a plot).
    assert locator.locate(last, (20.0, 20.0)) is None
    # Searched over every line, with only the first lines answered (the pen-down dwell answered
    # later would put the machine past it).
    found = locator.locate(last, (20.0, 20.0), window=last, answered=5)
    assert found is not None and found[0] < 20


def test_the_stop_key_stops_a_plot_whose_machine_trails(tmp_path):
    gcode = tmp_path / "zigzag.gcode"
    api.export_gcode(zigzag_plan(200), PROFILE, gcode)

    from sim import protocol_sim

    protocol_sim.forget("listener-stop")

    class StopOnceStreaming:
        """The stop key, pressed once the board has taken 60 lines (not after a wall-clock
        while, in which a loaded host may have sent the whole job or none of it)."""

        def poll(self):
            board = protocol_sim._PLOTTERS.get("listener-stop")  # noqa: SLF001 - the board, once open
            return ["stop"] if board is not None and len(board.firmware.log) > 60 else []

    with pytest.raises(PlotError, match="stopped by the stop key.*pen raised"):
        api.draw(
            gcode,
            f"sim://listener-stop?profile={PROFILE}&realtime=20",
            profile=PROFILE,
            keys=StopOnceStreaming(),
        )


def test_a_job_started_from_a_later_line_counts_its_plot_time_from_that_line(tmp_path):
    # 100 % is the plot time of the lines from the start line on: each record's share is the
    # estimate of the lines done since then over that of all the lines left.
    gcode = tmp_path / "zigzag.gcode"
    api.export_gcode(zigzag_plan(20), PROFILE, gcode)
    job = load_job(gcode, load_profile(PROFILE))
    start = len(job) // 2
    records = []
    api.draw(
        gcode,
        f"sim://listener-start?profile={PROFILE}",
        profile=PROFILE,
        start_line=job.number(start),
        on_progress=records.append,
    )
    before, left = (
        job.seconds_after(start - 1),
        job.seconds_after(len(job) - 1) - job.seconds_after(start - 1),
    )
    shares = [
        (r["percent"], 100.0 * (job.seconds_after(start + r["line"] - 1) - before) / left)
        for r in records
        if r["event"] == "progress"
    ]
    assert len(shares) >= 2 and all(abs(got - want) <= 0.005 for got, want in shares), shares
