"""The faces' cells improved by direct binary search: a lower blurred error for the lifts paid."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.planning.dither import error_diffuse, row_runs
from pencilbot.planning.run_search import blurred_error, search_runs


def _ramp(rows: int = 40, cols: int = 60, low: float = 0.0, high: float = 0.5) -> np.ndarray:
    return np.tile(np.linspace(low, high, cols), (rows, 1))


def _objective(on, request, region, lift):
    return blurred_error(on, request, region) + lift * row_runs(on)[0].size


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    lift=st.sampled_from([0.0, 0.02, 0.1, 1.0]),
    bias=st.sampled_from([0.0, 0.2, 0.4]),
)
def test_the_search_never_raises_what_it_lowers(seed, lift, bias):
    rng = np.random.default_rng(seed)
    request = np.clip(rng.random((30, 40)) * rng.random() + _ramp(30, 40, 0, 0.3), 0, 1)
    region = rng.random((30, 40)) < 0.9
    start = error_diffuse(request, region, run_bias=bias)
    found = search_runs(start, request, region, lift=lift)
    assert _objective(found, request, region, lift) <= _objective(start, request, region, lift) + 1e-6
    assert not np.any(found & ~region & ~start)  # nothing inked outside the region


def test_a_light_ramp_is_drawn_closer_to_its_tone_than_error_diffusion_draws_it():
    request = _ramp(high=0.35)
    region = np.ones(request.shape, bool)
    start = error_diffuse(request, region, run_bias=0.4)
    found = search_runs(start, request, region, lift=0.0)
    assert blurred_error(found, request, region) < 0.6 * blurred_error(start, request, region)
    # and the ink still follows the ramp: the darker half holds more of it
    half = request.shape[1] // 2
    assert found[:, half:].sum() > 1.5 * found[:, :half].sum()


def test_a_dearer_lift_draws_fewer_runs():
    request = _ramp(high=0.4)
    region = np.ones(request.shape, bool)
    start = error_diffuse(request, region, run_bias=0.2)
    counts = [row_runs(search_runs(start, request, region, lift=lift))[0].size for lift in (0.0, 0.05, 0.5)]
    assert counts[0] > counts[1] > counts[2]


def test_ink_already_there_is_not_drawn_again():
    request = np.full((30, 30), 0.5)
    region = np.ones(request.shape, bool)
    start = error_diffuse(request, region)
    given_ink = np.zeros(request.shape)
    given_ink[:, :15] = 0.5  # a contour's ink over the left half already lays the tone there
    found = search_runs(start, request, region, given_ink, lift=0.0)
    assert found[:, :12].mean() < 0.1 and found[:, 18:].mean() > 0.35


def test_a_white_request_is_left_bare_and_a_black_one_filled():
    region = np.ones((20, 20), bool)
    start = np.random.default_rng(3).random((20, 20)) < 0.5
    assert not search_runs(start, np.zeros((20, 20)), region, lift=0.0).any()
    assert search_runs(start, np.ones((20, 20)), region, lift=0.0).all()
