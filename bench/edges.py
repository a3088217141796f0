"""GMED against classic edge operators on images with exact boundaries; prints JSON.

    python bench/edges.py

Protocol (BSDS-style, as close as exact ground truth allows):

* Scenes: the silhouette of ``skimage.data.horse`` and a set of binary shapes (disk, rectangle,
  triangle, ellipse), each rendered flat and with a textured fill (smooth random texture inside
  the objects, which has gradients but no boundaries), each clean and with 0.01 salt-and-pepper
  noise (``skimage.util.random_noise``, fixed seed).
* Ground truth: the one-pixel inner boundary of every object (``find_boundaries(mode="inner")``).
* Operators, each on the same grey image: GMED (:func:`pencilbot.imaging.gmed.edge_map`, which
  includes its own 3×3 median), Sobel, Prewitt, Roberts, |Laplace| (3×3), Canny (σ = 1), and as a
  control Sobel after the same 3×3 median, to show how much of GMED's robustness is the median.
* Thresholds: each strength map is cut at its own quantiles so that 0.2 % … 25 % of pixels are
  "edge" (25 log-spaced steps); this removes every operator's arbitrary scale, and a noise spike
  cannot squash the real edges into the lowest threshold bin. Canny is binary, so its high
  hysteresis threshold is swept over the same quantiles (low = the quantile admitting twice as many).
* Each thresholded map is thinned (``skimage.morphology.thin``, as BSDS thins with bwmorph) and
  matched one-to-one to the ground truth: predicted and true boundary pixels closer than
  0.0075 × image diagonal are paired greedily, closest pairs first. BSDS's ``correspondPixels``
  solves a minimum-cost assignment instead, which can pair a few more pixels where two candidates
  compete; the greedy count is a lower bound on it. Checked against an exact maximum matching
  (scipy's Hopcroft-Karp, seconds per threshold on these boundary chains, too slow for the sweep)
  on the noisy textured horse: greedy finds 99.5-100 % of its matches.
* F = 2PR / (P + R). ``ods``: one threshold per operator for all images of a condition (counts
  summed); ``per_image``: each image's best threshold (OIS).
"""

from __future__ import annotations

import json

import numpy as np
import scipy.ndimage as ndi
import skimage.data
from scipy.spatial import cKDTree
from skimage import draw, feature, filters, morphology, segmentation, util

from pencilbot.imaging.gmed import edge_map

TOLERANCE = 0.0075  # × image diagonal
EDGE_FRACTIONS = np.geomspace(0.002, 0.25, 25)
NOISE_AMOUNT = 0.01
SEED = 7


def horse_labels() -> np.ndarray:
    return (~skimage.data.horse()).astype(np.int32)  # the horse is False on a True background


def shape_labels() -> np.ndarray:
    labels = np.zeros((320, 400), np.int32)
    labels[draw.disk((90, 100), 55, shape=labels.shape)] = 1
    labels[60:140, 210:360] = 2
    labels[draw.polygon([300, 180, 300], [40, 120, 200], shape=labels.shape)] = 3
    labels[draw.ellipse(240, 300, 50, 80, shape=labels.shape, rotation=np.deg2rad(25))] = 4
    return labels


def render(labels: np.ndarray, textured: bool, rng: np.random.Generator) -> np.ndarray:
    """Flat grey objects on a light background; optionally a smooth random texture inside objects."""
    levels = np.array([0.75, 0.3, 0.45, 0.25, 0.4], np.float32)
    image = levels[labels % len(levels)]
    if textured:
        texture = ndi.gaussian_filter(rng.standard_normal(labels.shape), 1.5)
        texture *= 0.08 / texture.std()
        image = image + np.where(labels > 0, texture, 0).astype(np.float32)
    return np.clip(image, 0, 1).astype(np.float32)


def strength_maps(gray: np.ndarray) -> dict[str, np.ndarray]:
    median = ndi.median_filter(gray, size=3, mode="reflect")
    return {
        "gmed": edge_map(gray),
        "sobel": filters.sobel(gray),
        "prewitt": filters.prewitt(gray),
        "roberts": filters.roberts(gray),
        "laplace": np.abs(filters.laplace(gray, ksize=3)),
        "sobel+median3": filters.sobel(median),
    }


def edge_sets(gray: np.ndarray, method: str, strength: np.ndarray | None) -> list[np.ndarray]:
    """Thinned binary edge maps, one per entry of EDGE_FRACTIONS (most strict first)."""
    maps = []
    for fraction in EDGE_FRACTIONS:
        if method == "canny":
            high = 1.0 - fraction
            low = max(0.0, 1.0 - 2 * fraction)
            edges = feature.canny(gray, sigma=1.0, low_threshold=low, high_threshold=high, use_quantiles=True)
        else:
            edges = strength >= np.quantile(strength, 1.0 - fraction)
            edges &= strength > 0
        maps.append(morphology.thin(edges))
    return maps


def match_counts(pred: np.ndarray, truth_points: np.ndarray, truth_tree: cKDTree, radius: float) -> int:
    """Number of one-to-one matches between predicted and true pixels closer than ``radius``.

    Greedy in order of distance: the closest remaining (pred, truth) pair is matched first. It is
    computed as rounds of mutual nearest neighbours (every pair that is the nearest free partner
    of both its ends is matched at once), which gives the same matching as the sequential greedy
    and stays vectorised.
    """
    pred_points = np.argwhere(pred)
    if len(pred_points) == 0 or len(truth_points) == 0:
        return 0
    pairs = cKDTree(pred_points).sparse_distance_matrix(truth_tree, radius, output_type="ndarray")
    order = np.lexsort((pairs["j"], pairs["i"], pairs["v"]))  # by distance, ties broken stably
    pred_idx, true_idx = pairs["i"][order], pairs["j"][order]
    pred_free = np.ones(len(pred_points), bool)
    true_free = np.ones(len(truth_points), bool)
    matched = 0
    while True:
        live = pred_free[pred_idx] & true_free[true_idx]
        pred_idx, true_idx = pred_idx[live], true_idx[live]
        if len(pred_idx) == 0:
            return matched
        # Each free prediction's nearest free truth pixel (first occurrence in distance order) ...
        _, first = np.unique(pred_idx, return_index=True)
        first.sort()
        # ... kept only where that truth pixel has no nearer proposer.
        _, winners = np.unique(true_idx[first], return_index=True)
        chosen = first[winners]
        pred_free[pred_idx[chosen]] = False
        true_free[true_idx[chosen]] = False
        matched += len(chosen)


def f_measure(matched: np.ndarray, n_pred: np.ndarray, n_true: np.ndarray) -> tuple[np.ndarray, ...]:
    precision = np.divide(matched, n_pred, out=np.zeros(len(matched)), where=n_pred > 0)
    recall = np.divide(matched, n_true, out=np.zeros(len(matched)), where=n_true > 0)
    total = precision + recall
    f = np.divide(2 * precision * recall, total, out=np.zeros(len(matched)), where=total > 0)
    return f, precision, recall


def evaluate(gray: np.ndarray, truth: np.ndarray) -> dict[str, np.ndarray]:
    """Per method: (matched, n_pred, n_true) counts at every threshold, shape (3, n_thresholds)."""
    radius = TOLERANCE * float(np.hypot(*gray.shape))
    truth_points = np.argwhere(truth)
    tree = cKDTree(truth_points)
    strengths = strength_maps(gray)
    counts = {}
    for method in [*strengths, "canny"]:
        maps = edge_sets(gray, method, strengths.get(method))
        matched = [match_counts(m, truth_points, tree, radius) for m in maps]
        counts[method] = np.array([matched, [m.sum() for m in maps], [len(truth_points)] * len(maps)], float)
    return counts


def main() -> None:
    rng = np.random.default_rng(SEED)
    scenes = {"horse": horse_labels(), "shapes": shape_labels()}
    per_image, totals = [], {}
    for scene, labels in scenes.items():
        truth = segmentation.find_boundaries(labels, mode="inner")
        for textured in (False, True):
            clean = render(labels, textured, rng)
            noisy = util.random_noise(clean, mode="s&p", amount=NOISE_AMOUNT, rng=SEED).astype(np.float32)
            for noise, gray in (("clean", clean), ("salt_pepper_0.01", noisy)):
                for method, c in evaluate(gray, truth).items():
                    f, precision, recall = f_measure(*c)
                    best = int(np.argmax(f))
                    per_image.append(
                        {
                            "image": scene + ("+texture" if textured else ""),
                            "noise": noise,
                            "method": method,
                            "f": round(float(f[best]), 3),
                            "precision": round(float(precision[best]), 3),
                            "recall": round(float(recall[best]), 3),
                            "edge_fraction": round(float(EDGE_FRACTIONS[best]), 4),
                        }
                    )
                    totals.setdefault(noise, {}).setdefault(method, []).append(c)
    ods = {
        noise: {method: round(float(f_measure(*sum(cs))[0].max()), 3) for method, cs in methods.items()}
        for noise, methods in totals.items()
    }
    print(
        json.dumps(
            {
                "protocol": {
                    "tolerance": f"{TOLERANCE} × diagonal",
                    "matching": "greedy one-to-one by distance within tolerance, predictions thinned",
                    "thresholds": f"{len(EDGE_FRACTIONS)} quantiles, edge fraction 0.002..0.25",
                    "noise": f"salt and pepper, amount {NOISE_AMOUNT}",
                },
                "ods": ods,
                "per_image": per_image,
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
