"""The studio's background solver of colour-separation tables: what it leaves in the cache is
what a colour plan then reads, without solving."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from pencilbot.machine.pens import load_pens
from pencilbot.planning import separation
from pencilbot.studio import tables


def test_every_pen_set_of_several_pens_is_solved_in_the_order_a_plan_reads_it(tmp_path, monkeypatch):
    env = {**os.environ, "PENCILBOT_CACHE_DIR": str(tmp_path)}
    subprocess.run([sys.executable, "-m", "pencilbot.studio.tables"], env=env, check=True, timeout=600)
    assert len(list((tmp_path / "separation").glob("*.npy"))) == 3  # cmyk, primaries, fineliner6; not black

    monkeypatch.setenv("PENCILBOT_CACHE_DIR", str(tmp_path))
    separation.separation_table.cache_clear()

    def solve(colors):
        raise AssertionError(f"solved again: {colors}")

    monkeypatch.setattr(separation, "_solve_table", solve)
    try:
        for name in ("cmyk", "primaries", "fineliner6"):
            pens = load_pens(name).load_order  # as build passes them to the separation
            table = separation.separation_table(tuple(pen.color for pen in pens))
            assert table.shape[0] == len(pens)
    finally:
        separation.separation_table.cache_clear()


@pytest.mark.parametrize("stop_at_once", [True, False])
def test_the_solver_stops_with_the_studio(tmp_path, monkeypatch, stop_at_once):
    monkeypatch.setenv("PENCILBOT_CACHE_DIR", str(tmp_path))
    process = tables.start()
    assert process is not None
    if not stop_at_once:
        process.wait(timeout=600)  # (a bound only) it ends by itself once every table is there
        assert process.returncode == 0
    tables.stop(process)
    assert process.poll() is not None
    tables.stop(process)  # stopping twice is harmless
