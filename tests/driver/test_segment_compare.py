"""The drawing comparison itself must see one stroke too many, too few or out of place."""

import numpy as np
import pytest
from test_stream_sim import PROFILE, drawing, drawn, fresh

from pencilbot.driver import draw
from segments import assert_same_drawing, drawing_differences


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


def test_a_stroke_moved_by_two_micrometres_fails(plotted):
    moved = [s + (0.002, 0.0) if i == 7 else s for i, s in enumerate(plotted)]
    problems = drawing_differences(moved, plotted)
    assert any("no stroke" in p for p in problems) and any("missing" in p for p in problems)
