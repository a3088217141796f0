"""The studio's planner: a coarse preview, then the full plan (the library's, unchanged); a newer
change drops the older one's results and ends its process."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from PIL import Image

from pencilbot import api
from pencilbot.studio.options import DrawingOptions
from pencilbot.studio.planner import LivePlanner


class Results:
    def __init__(self):
        self.got, self.cond = [], threading.Condition()

    def __call__(self, result):
        with self.cond:
            self.got.append(result)
            self.cond.notify_all()

    def wait(self, predicate, timeout=120.0):
        with self.cond:
            assert self.cond.wait_for(lambda: predicate(self.got), timeout=timeout), [
                (r.generation, r.stage, r.error) for r in self.got
            ]


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    path = tmp_path_factory.mktemp("photo") / "ramp.png"
    y, x = np.mgrid[0:120, 0:160]
    picture = (127 + 100 * np.sin(x / 9.0) * np.cos(y / 13.0)).astype(np.uint8)
    Image.fromarray(picture).save(path)
    return path


@pytest.fixture(scope="module")
def planner():
    results = Results()
    made = LivePlanner(lambda result: made.sink(result))
    made.sink = results
    made.warm_up()
    yield made
    made.cancel()


def fresh(planner) -> Results:
    planner.sink = Results()
    return planner.sink


def test_coarse_first_then_the_full_plan_of_the_library(planner, photo):
    results = fresh(planner)
    options = DrawingOptions(page="A5", pen_width=0.7)
    generation = planner.submit(photo, options)
    results.wait(lambda got: any(r.stage == "full" for r in got))
    assert [r.stage for r in results.got] == ["coarse", "full"]
    coarse, full = results.got
    assert {coarse.generation, full.generation} == {generation}
    assert coarse.preview_png.startswith(b"\x89PNG") and full.sketch_png.startswith(b"\x89PNG")
    assert coarse.plan is None and full.figures["lifts"] > 0 and 0 < full.figures["likeness"] <= 1
    expected = api.plan(photo, page="A5", pen_width=0.7)
    assert [layer.name for layer in full.plan.layers] == [layer.name for layer in expected.layers]
    assert all(
        np.array_equal(a.paths.points, b.paths.points) for a, b in zip(full.plan.layers, expected.layers)
    )


def test_a_newer_change_drops_the_older_one(planner, photo):
    results = fresh(planner)
    older = planner.submit(photo, DrawingOptions(pen_width=0.5))
    process = planner._process
    newer = planner.submit(photo, DrawingOptions(pen_width=0.9))
    process.join(timeout=10)
    assert not process.is_alive()  # ended, not left to finish
    results.wait(lambda got: any(r.stage == "full" for r in got))
    assert newer == older + 1
    assert {r.generation for r in results.got} == {newer}
    assert results.got[-1].plan.layers[0].pen_width == 0.9


def test_cancel_drops_the_change_in_flight(planner, photo):
    results = fresh(planner)
    planner.submit(photo, DrawingOptions(pen_width=0.6))
    process = planner._process
    planner.cancel()
    process.join(timeout=10)
    assert not process.is_alive() and results.got == []


def test_a_refused_value_is_one_message(planner, photo):
    results = fresh(planner)
    planner.submit(photo, DrawingOptions(page="3000x3000"))
    results.wait(lambda got: bool(got))
    assert "larger than the studio plans" in results.got[0].error


def test_the_coarse_stage_is_a_draft_nothing_ordered_or_polished(monkeypatch):
    # The first preview is only looked at: with several pens its plan orders and joins no path
    # and solves no cell's separation (the table's amounts as they are); the full stage does both.
    from pencilbot.machine.pens import load_pens
    from pencilbot.planning import build, separation
    from pencilbot.studio.planner import plan_stage

    y, x = np.mgrid[0:90, 0:120]
    picture = np.stack([0.5 + 0.4 * np.sin(x / 7.0), 0.5 + 0.4 * np.cos(y / 9.0), 0.6 + 0 * x], -1)
    calls: dict[str, int] = {"order_paths": 0, "separate": 0}
    for module, name in ((build, "order_paths"), (separation, "separate")):
        real = getattr(module, name)

        def counted(*args, _real=real, _name=name, **kwargs):
            calls[_name] += 1
            return _real(*args, **kwargs)

        monkeypatch.setattr(module, name, counted)
    separation.separation_table(tuple(pen.color for pen in load_pens("cmyk").load_order))  # (solved once)
    calls["separate"] = 0
    options = DrawingOptions(page="A5", pens="cmyk")
    coarse = plan_stage(picture, options, "coarse")
    assert coarse["preview_png"].startswith(b"\x89PNG") and calls == {"order_paths": 0, "separate": 0}
    full = plan_stage(picture, options, "full")
    assert full["plan"].layers and calls["order_paths"] > 0 and calls["separate"] > 0
