"""The flat path type: points + offsets, every path non-empty, read-only, cheap to slice."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.paths import Paths, ramps

point_lists = st.lists(
    st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)), max_size=5), max_size=8
)


@settings(max_examples=100, deadline=None)
@given(point_lists)
def test_of_keeps_every_non_empty_path_in_order(lists):
    arrays = [np.array(p, dtype=float).reshape(-1, 2) for p in lists]
    paths = Paths.of(arrays)
    kept = [a for a in arrays if len(a)]
    assert len(paths) == len(kept)
    assert all(np.array_equal(a, b) for a, b in zip(paths, kept))
    assert [paths[i].tolist() for i in range(-len(kept), 0)] == [a.tolist() for a in kept]
    assert paths.lengths.tolist() == [len(a) for a in kept] and (paths.lengths > 0).all()
    if kept:
        assert np.array_equal(paths.firsts, [a[0] for a in kept])
        assert np.array_equal(paths.lasts, [a[-1] for a in kept])
        assert paths.owners().tolist() == [i for i, a in enumerate(kept) for _ in a]
    assert Paths.of(paths) is paths


@settings(max_examples=60, deadline=None)
@given(point_lists, st.integers(-10, 10), st.integers(-10, 10), st.sampled_from([1, 2, -1]))
def test_slices_and_concatenation_are_the_list_operations(lists, a, b, step):
    arrays = [np.array(p, dtype=float).reshape(-1, 2) for p in lists if p]
    paths = Paths.of(arrays)
    want = arrays[a:b:step]
    got = paths[a:b:step]
    assert isinstance(got, Paths) and len(got) == len(want)
    assert all(np.array_equal(x, y) for x, y in zip(got, want))
    both = Paths.concat([paths, paths[a:b]])
    assert [p.tolist() for p in both] == [p.tolist() for p in arrays + arrays[a:b]]


@settings(max_examples=80, deadline=None)
@given(point_lists, st.data())
def test_take_picks_and_reverses_paths_as_a_list_would(lists, data):
    arrays = [np.array(p, dtype=float).reshape(-1, 2) for p in lists if p]
    paths = Paths.of(arrays)
    order = data.draw(st.lists(st.integers(0, max(len(arrays) - 1, 0)), max_size=10 if arrays else 0))
    reverse = data.draw(st.lists(st.booleans(), min_size=len(order), max_size=len(order)))
    got = paths.take(order, reverse)
    want = [arrays[i][::-1] if r else arrays[i] for i, r in zip(order, reverse)]
    assert len(got) == len(want) and all(np.array_equal(x, y) for x, y in zip(got, want))
    assert paths.take(order) == Paths.of(arrays[i] for i in order)


@settings(max_examples=80, deadline=None)
@given(point_lists)
def test_drawn_lengths_are_each_paths_length_along_its_points(lists):
    arrays = [np.array(p, dtype=float).reshape(-1, 2) for p in lists if p]
    want = [np.hypot(*np.diff(a, axis=0).T).sum() for a in arrays]
    np.testing.assert_allclose(Paths.of(arrays).drawn_lengths(), want, rtol=1e-12, atol=1e-9)


def test_ramps_count_within_each_size():
    assert ramps([3, 1, 0, 2]).tolist() == [0, 1, 2, 0, 0, 1]
    assert ramps([]).tolist() == []


def test_empty_paths_are_refused_and_arrays_are_read_only():
    with pytest.raises(ValueError, match="no empty path"):
        Paths(np.zeros((2, 2)), [0, 0, 2])
    with pytest.raises(ValueError):
        Paths(np.zeros((2, 2)), [0, 1])  # offsets must end at the point count
    paths = Paths.of([np.array([[0.0, 0.0], [1.0, 1.0]])])
    with pytest.raises(ValueError):
        paths.points[0, 0] = 5.0
    with pytest.raises(AttributeError):
        paths.points = np.zeros((1, 2))
    with pytest.raises(IndexError):
        paths[1]
    assert len(Paths.empty()) == 0 and list(Paths.empty()) == []


def test_equality_is_by_value():
    a = Paths.of([np.array([[0.0, 0.0], [1.0, 1.0]]), np.array([[2.0, 2.0]])])
    assert a == Paths(a.points.copy(), a.offsets.copy())
    assert a != a[:1]


def test_paths_and_plans_pickle_for_worker_processes():
    import pickle

    from pencilbot.planning.plan import Layer, Page, Plan

    plan = Plan(
        Page(100, 100),
        [Layer("edges", [np.array([[1.0, 2.0], [3.0, 4.0]])], role="edges")],
        meta={"source": "x"},
    )
    back = pickle.loads(pickle.dumps(plan))
    assert back == plan and back.meta["source"] == "x" and back.paths().points.flags.writeable is False
