"""`pencilbot simulate` of a drawing (a plan SVG, another tool's SVG) runs its plain program on the
virtual machine at once (sim.bulk), as it does a G-code file: the same PNG, strokes and drawing
time as the full way through the driver, line by line."""

from __future__ import annotations

import contextlib
import io
import re

import numpy as np
import pytest
from PIL import Image

from pencilbot.cli import main
from pencilbot.commands import simulate
from pencilbot.export.svg import write_svg
from pencilbot.planning.plan import Layer, Page, Plan


def _words_and_seconds(said: str) -> tuple[str, float]:
    """What simulate said with its drawing time taken out, and that time (s)."""
    match = re.search(r"time \S+ \(([0-9.]+) s\)", said)
    assert match, said
    return said[: match.start()] + said[match.end() :], float(match.group(1))


def _run(argv, monkeypatch, *, fast: bool):
    taken = []
    original = simulate._fast_plot_blocks
    monkeypatch.setattr(
        simulate,
        "_fast_plot_blocks",
        (lambda *a: taken.append(original(*a)) or taken[-1]) if fast else (lambda *a: None),
    )
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        assert main(argv) == 0
    return out.getvalue(), taken


@pytest.mark.parametrize("foreign", [False, True])
def test_a_drawing_simulated_at_once_is_the_one_drawn_line_by_line(tmp_path, monkeypatch, foreign):
    rng = np.random.default_rng(3)
    starts = rng.uniform([20, 20], [180, 260], (300, 2))
    paths = [np.array([a, a + rng.uniform(-4, 4, 2), a + rng.uniform(-4, 4, 2)]) for a in starts]
    plan = Plan(
        Page(210, 297, 10, "A4"),
        [Layer("a", paths[:200], pen_width=0.4), Layer("b", paths[200:], pen_width=0.4)],
    )
    svg = tmp_path / "d.svg"
    write_svg(plan, svg)
    if foreign:  # the same drawing as another tool's: reordered first
        svg.write_text(svg.read_text().replace(' pencilbot:page="A4"', ""))
    fast_png, slow_png = tmp_path / "fast.png", tmp_path / "slow.png"
    said_fast, taken = _run(
        ["simulate", str(svg), "-o", str(fast_png), "--dpi", "60"], monkeypatch, fast=True
    )
    said_slow, _ = _run(["simulate", str(svg), "-o", str(slow_png), "--dpi", "60"], monkeypatch, fast=False)
    assert taken and taken[0] is not None  # the fast path ran the job
    # The same strokes and the same drawing time. The full way's board takes the blocks as its
    # serial wire delivers them, in wall time, so how far ahead it has planned a junction can
    # depend on the host's load: the time within a second in 260 (a loaded CI run: 0.1 s apart).
    fast_words, fast_seconds = _words_and_seconds(said_fast.replace("fast.png", ""))
    slow_words, slow_seconds = _words_and_seconds(said_slow.replace("slow.png", ""))
    assert fast_words == slow_words and fast_seconds == pytest.approx(slow_seconds, rel=0.004)
    assert "300 pen-down strokes" in said_fast or foreign
    fast, slow = (np.asarray(Image.open(p)) for p in (fast_png, slow_png))
    assert fast.shape == slow.shape and np.array_equal(fast, slow)
    assert (fast < 128).any()  # something was drawn
