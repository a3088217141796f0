"""The drawing comparison itself must see one stroke too many, too few or out of place."""

import numpy as np
import pytest
from real_plan import plan_lines
from segments import assert_same_drawing, drawing_differences
from test_stream_sim import PROFILE, drawing, drawn, fresh

from pencilbot.driver import draw


@pytest.fixture(scope="module")
def plotted():
    url, name = fresh()
    draw(drawing(), url, profile=PROFILE, wake_wait=0.2)
    return drawn(name)


def test_a_drawing_is_the_same_as_itself_and_as_its_pieces_split_anywhere(plotted):
    assert_same_drawing(plotted, plotted)
    # A resume draws a move in two pieces: up to the stop and from it.
    first = plotted[3]
    stop = first[1] + 0.37 * (first[2] - first[1])
    split = [*plotted[:3], np.vstack([first[:2], stop]), np.vstack([stop, first[2:]]), *plotted[4:]]
    assert_same_drawing(split, plotted)


def test_one_stroke_drawn_twice_fails(plotted):
    with pytest.raises(AssertionError, match="drawn 2 times"):
        assert_same_drawing([*plotted, plotted[5]], plotted)


def test_one_stroke_missing_fails(plotted):
    with pytest.raises(AssertionError, match="missing"):
        assert_same_drawing(plotted[:4] + plotted[5:], plotted)


def test_part_of_a_segment_drawn_twice_or_missing_fails(plotted):
    stroke = plotted[2]
    overlap = stroke[0] + 0.6 * (stroke[1] - stroke[0])
    redrawn = [*plotted, np.vstack([overlap, stroke[1]])]
    assert any("drawn 2 times" in p for p in drawing_differences(redrawn, plotted))
    short = [*plotted[:2], np.vstack([overlap, stroke[1:]]), *plotted[3:]]
    assert any("missing" in p for p in drawing_differences(short, plotted))


def test_a_micrometre_jog_where_a_resume_starts_is_the_same_but_a_stray_stroke_is_caught():
    # GRBL reports where a stop left the pen to the micrometre: the resume's first move may be a
    # 1.0 µm jog across the line it goes on along (as long as the tolerance, but for the float's
    # last bit: this one is 1.0000000000012 µm).
    line = np.array([[26.8401 - 6.0, 19.6805 - 8.0], [26.8401, 19.6805], [26.8401 + 3.0, 19.6805 + 4.0]])
    jog = np.array([[26.8401, 19.6805], [26.8401, 19.6805 - 0.001]])
    assert np.linalg.norm(jog[1] - jog[0]) > 0.001
    assert drawing_differences([line[:2], jog, line[1:]], [line]) == []
    # Ten micrometres of it, or the same micrometre a few micrometres off the line, are strokes
    # the reference does not have.
    long_jog = np.array([[26.8401, 19.6805], [26.8401, 19.6705]])
    assert any("no stroke" in p for p in drawing_differences([line, long_jog], [line]))
    assert any("no stroke" in p for p in drawing_differences([line, jog + (0.004, -0.003)], [line]))


def test_a_stroke_moved_by_two_micrometres_fails(plotted):
    moved = [s + (0.002, 0.0) if i == 7 else s for i, s in enumerate(plotted)]
    problems = drawing_differences(moved, plotted)
    assert any("no stroke" in p for p in problems) and any("missing" in p for p in problems)


# --- on a real plan: multi-segment paths, collinear segments that overlap, points passed twice


@pytest.fixture(scope="module")
def real():
    """A real plan's plot (coffee, 40 × 30 mm), drawn on the instant and the real-time clock."""
    lines = list(plan_lines())
    url, name = fresh()
    draw(lines, url, profile=PROFILE, wake_wait=0.2)
    instant = drawn(name)
    url, name = fresh("realtime=400")
    draw(lines, url, profile=PROFILE, wake_wait=0.2)
    return instant, drawn(name)


def overlapping(strokes):
    """(stroke, segment) of a segment that a collinear segment elsewhere in ``strokes`` overlaps."""
    from segments import _lying_on

    where = [
        (k, s)
        for k, stroke in enumerate(strokes)
        for s in range(len(stroke) - 1)
        if np.linalg.norm(stroke[s + 1, :2] - stroke[s, :2]) > 1e-3
    ]
    flat = np.array([[strokes[k][s, :2], strokes[k][s + 1, :2]] for k, s in where])
    i, j, _ = _lying_on(flat, flat, 1e-3, touch=False)
    return [where[n] for n in i[i != j]]


def test_a_real_plot_is_the_same_as_itself_and_as_its_real_time_run(real):
    instant, realtime = real
    assert (
        sum(len(s) - 1 for s in instant) > 400 and max(len(s) for s in instant) > 10
    )  # a real, multi-segment plan
    assert drawing_differences(instant, instant) == []
    assert drawing_differences(realtime, instant) == []
    assert drawing_differences(instant, realtime) == []


def test_a_real_plot_passes_some_points_twice_and_each_pass_counts(real):
    instant, _ = real
    twice = overlapping(instant)
    assert twice  # the plan draws collinear segments over each other
    k, s = twice[0]
    # Leave out that one segment: the stretch drawn twice by the reference is drawn once.
    cut = [*instant[:k], instant[k][: s + 1], instant[k][s + 1 :], *instant[k + 1 :]]
    problems = drawing_differences(cut, instant)
    assert any("missing (reference: 2, drawn: 1)" in p for p in problems), problems
    assert all("missing" in p for p in problems), problems


@pytest.mark.parametrize("which", [0, 17, -1])
def test_a_real_plot_with_one_stroke_changed_is_caught(real, which):
    instant, _ = real
    k = which % len(instant)
    stroke = instant[k]
    assert any("drawn 2 times" in p for p in drawing_differences([*instant, stroke], instant))
    assert any("missing" in p for p in drawing_differences([*instant[:k], *instant[k + 1 :]], instant))
    moved = [s + (0.002, 0.0) if n == k else s for n, s in enumerate(instant)]
    assert drawing_differences(moved, instant)
    across = [s + (0.0, 0.002) if n == k else s for n, s in enumerate(instant)]
    assert any("missing" in p for p in drawing_differences(across, instant))


def test_a_real_stroke_split_where_the_resume_splits_it_is_the_same_but_a_gap_is_caught(real):
    instant, _ = real
    k = max(range(len(instant)), key=lambda n: len(instant[n]))
    stroke = instant[k]
    at = stroke[4] + 0.37 * (stroke[5] - stroke[4])
    split = [*instant[:k], np.vstack([stroke[:5], at]), np.vstack([at, stroke[5:]]), *instant[k + 1 :]]
    assert drawing_differences(split, instant) == []
    unit = (stroke[5] - stroke[4]) / np.linalg.norm(stroke[5] - stroke[4])
    gap = [
        *instant[:k],
        np.vstack([stroke[:5], at]),
        np.vstack([at + 0.002 * unit, stroke[5:]]),
        *instant[k + 1 :],
    ]
    assert any("0.0020 mm" in p and "missing" in p for p in drawing_differences(gap, instant))
    overlap = [
        *instant[:k],
        np.vstack([stroke[:5], at]),
        np.vstack([at - 0.002 * unit, stroke[5:]]),
        *instant[k + 1 :],
    ]
    assert any("drawn 2 times" in p for p in drawing_differences(overlap, instant))
