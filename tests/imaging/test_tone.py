"""Pencil tone model and histogram specification (GML per Zhang 1992, SML for comparison)."""

import numpy as np
import pytest
import skimage.data
from hypothesis import given, settings
from hypothesis import strategies as st

from pencilbot.imaging.tone import gml_lut, pencil_histogram, sml_lut, tone_target

# The textbook case: 8 source levels, target mass on levels 3, 5 and 7 only.
SOURCE = np.array([0.19, 0.25, 0.21, 0.16, 0.08, 0.06, 0.03, 0.02])
TARGET = np.zeros(8)
TARGET[[3, 5, 7]] = [0.2, 0.5, 0.3]


def mapped_histogram(mapping, source, n_levels):
    return np.bincount(mapping, weights=source, minlength=n_levels)


def gml_by_the_book(source, target):
    """Zhang's group mapping law written as the loop the paper describes (test oracle)."""
    cs = np.cumsum(source) / np.sum(source)
    ct = np.cumsum(target) / np.sum(target)
    nonempty = [j for j in range(len(target)) if target[j] > 0]
    mapping = np.empty(len(source), dtype=int)
    start = 0
    for j in nonempty:
        end = int(np.argmin(np.abs(cs - ct[j])))
        mapping[start : end + 1] = j
        start = max(start, end + 1)
    mapping[start:] = nonempty[-1]
    return mapping


def test_textbook_case_gml_beats_sml():
    gml, sml = gml_lut(SOURCE, TARGET), sml_lut(SOURCE, TARGET)
    np.testing.assert_array_equal(gml, [3, 5, 5, 7, 7, 7, 7, 7])
    np.testing.assert_array_equal(sml, [3, 3, 5, 5, 7, 7, 7, 7])
    gml_error = np.abs(mapped_histogram(gml, SOURCE, 8) - TARGET).sum()
    sml_error = np.abs(mapped_histogram(sml, SOURCE, 8) - TARGET).sum()
    assert gml_error == pytest.approx(0.10, abs=1e-9)
    assert sml_error == pytest.approx(0.48, abs=1e-9)


histograms = st.integers(2, 64).flatmap(
    lambda n: st.lists(st.integers(0, 50), min_size=n, max_size=n).filter(lambda h: sum(h) > 0)
)


@settings(max_examples=150, deadline=None)
@given(histograms, histograms)
def test_gml_matches_zhangs_loop_and_is_monotone(source, target):
    source, target = np.array(source, float), np.array(target, float)
    gml = gml_lut(source, target)
    np.testing.assert_array_equal(gml, gml_by_the_book(source, target))
    assert np.all(np.diff(gml) >= 0)
    assert np.all(target[gml] > 0)  # groups only go to levels the target uses


@settings(max_examples=150, deadline=None)
@given(histograms, histograms)
def test_sml_is_monotone_and_closest(source, target):
    source, target = np.array(source, float), np.array(target, float)
    sml = sml_lut(source, target)
    assert np.all(np.diff(sml) >= 0)
    assert np.all(target[sml] > 0)  # a tone the model holds no pixels at is never produced
    cs, ct = np.cumsum(source) / source.sum(), np.cumsum(target) / target.sum()
    used = ct[target > 0]
    best = np.abs(cs[:, None] - used[None, :]).min(axis=1)
    np.testing.assert_allclose(np.abs(cs - ct[sml]), best, atol=1e-12)


def test_pencil_histogram_layers():
    levels = np.arange(256)
    bright = pencil_histogram((1, 0, 0))
    assert bright.argmax() == 255 and bright[levels >= 206].sum() > 0.99
    middle = pencil_histogram((0, 1, 0))
    np.testing.assert_allclose(middle[105:206], 1 / 101)
    assert middle[:105].sum() == 0 and middle[206:].sum() == 0
    dark = pencil_histogram((0, 0, 1))
    assert (dark * levels).sum() == pytest.approx(90, abs=0.01)
    assert np.sqrt((dark * (levels - 90) ** 2).sum()) == pytest.approx(11, abs=0.1)
    lu = pencil_histogram((52, 37, 11))
    assert lu.sum() == pytest.approx(1)
    # 52:37:11 — the weights are the layers' pixel shares.
    assert lu[206:].sum() == pytest.approx(0.52, abs=0.01)
    # The dark layer's Gaussian reaches past 104: 0.11 · Φ((104.5 − 90) / 11) ≈ 0.0997.
    assert lu[:105].sum() == pytest.approx(0.0997, abs=0.002)
    default = pencil_histogram()
    assert default[206:].sum() == pytest.approx(0.40, abs=0.01)  # 40:45:15 by default
    # Negligible tails are empty, so GML never sends a dark photo level to near-black.
    assert default[:40].sum() == 0
    np.testing.assert_allclose(pencil_histogram((2, 1, 1)), pencil_histogram((50, 25, 25)))


@pytest.mark.parametrize("weights", [(1, 2), (-1, 1, 1), (0, 0, 0), (np.nan, 1, 1)])
def test_bad_weights(weights):
    with pytest.raises(ValueError, match="weights"):
        pencil_histogram(weights)


def cdf_distance(tone, target_hist):
    levels = np.rint(tone * 255).astype(int).ravel()
    hist = np.bincount(levels, minlength=256) / levels.size
    return np.abs(np.cumsum(hist) - np.cumsum(target_hist)).sum() / 255


@pytest.mark.parametrize("method", ["gml", "sml"])
def test_tone_target_follows_the_model_and_keeps_order(method):
    gray = skimage.data.camera().astype(np.float32) / 255
    # The paper's specification: onto the model alone, darker than the photo where it says so.
    J = tone_target(gray, method=method, photo_share=0.0, never_darker=False)
    assert J.dtype == np.float32 and J.shape == gray.shape
    # Monotone: a brighter photo pixel never gets a darker tone.
    order = np.argsort(gray.ravel(), kind="stable")
    assert np.all(np.diff(J.ravel()[order]) >= 0)
    assert cdf_distance(J, pencil_histogram()) < 0.01
    assert cdf_distance(gray, pencil_histogram()) > 0.05  # the photo itself is far from it
    # By default a fifth of the photo's own histogram is mixed in: J lies between the two.
    mixed = tone_target(gray, method=method, never_darker=False)
    assert np.all(np.diff(mixed.ravel()[order]) >= 0)
    assert (
        cdf_distance(J, pencil_histogram())
        < cdf_distance(mixed, pencil_histogram())
        < cdf_distance(gray, pencil_histogram())
    )


def test_tone_target_on_a_ramp_hits_the_layers():
    ramp = np.tile(np.linspace(0, 1, 1000, dtype=np.float32), (20, 1))
    J = tone_target(ramp, photo_share=0.0)
    # The bright layer's share of the drawing is near paper white (40 % by default), the darkest
    # accents sit near 90/255, not black.
    assert np.mean(J >= 206 / 255) == pytest.approx(0.40, abs=0.02)
    assert 0.15 < J.min() < 0.3 and J.max() == 1.0


def test_tone_target_rejects_bad_arguments():
    with pytest.raises(ValueError, match="method"):
        tone_target(np.zeros((4, 4)), method="zhang")
    with pytest.raises(ValueError, match="2-D"):
        tone_target(np.zeros((4, 4, 3)))
    with pytest.raises(ValueError, match="photo_share"):
        tone_target(np.zeros((4, 4)), photo_share=1.0)
