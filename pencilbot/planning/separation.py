"""Colour separation: how much of each pen a colour sketch needs, and each pen's hatching.

The model is the one the previews and the simulated plot are judged by
(:func:`pencilbot.colors.inks_on_paper`): pen k laying ink of linear reflectance c_k over a
share a_k of the paper multiplies the paper's reflectance by ``1 − a_k (1 − c_k)`` per channel.
Per cell of a blurred, downsampled copy of the colour sketch (:data:`SEPARATION_CELL`, the
1–3 mm scale at which hatching is seen as colour), :func:`separate` finds the amounts a ≥ 0 that
make the stacked inks match the sketch's colour, by projected Levenberg–Marquardt steps on all
cells at once (solved once per pen set on a table of colours, :func:`separation_table`, then
polished per cell).
The metric is CIELAB (cube roots of X, Y, Z), so an error in a shadow counts as much as one in a
highlight and an error of hue as much as the eye sees it. (It was the cube root of each linear
RGB channel: that metric weighs chroma about a quarter as much as CIELAB does, and the ink cost
bought a visible tint with it: grace_hopper's whole plot came out greener and yellower than its
sketch by Δa* −1.3, Δb* +1.5.) A small cost per unit of ink picks, among mixtures that look
alike, the one with least ink: a neutral shadow takes black rather than three colours on top of
each other, which is also how printers separate (grey component replacement).

Each pen's amount then goes through the black plan's own closed loop
(:func:`~pencilbot.planning.shading.shade`): hatch, render with the exact-area rasteriser, blur,
correct. So each pen's coverage response (lines dropped, gaps bridged, lines crowding on bends)
is measured, not modelled, exactly as for the black plan. Each pen hatches at its own angles
(:func:`pen_angles`), so the lines of different pens cross instead of lying on each other and the
colours mix optically; the contours are drawn in the darkest pen, which also carries their share
of its tone.
"""

from __future__ import annotations

import hashlib
import io
from collections.abc import Sequence
from dataclasses import replace
from functools import lru_cache

import cv2
import numpy as np
from scipy import ndimage as ndi
from skimage.color import deltaE_ciede2000, rgb2lab

from pencilbot.colors import inks_on_paper, linear_to_srgb, srgb_to_linear
from pencilbot.configs_io import cache_folder
from pencilbot.errors import PencilbotError
from pencilbot.fileio import write_atomic
from pencilbot.machine.pens import Pen
from pencilbot.paths import Paths
from pencilbot.planning.plan import Layer
from pencilbot.planning.shading import Hatching

#: Cell (mm) of the grid the separation is solved on: finer than the hatching's 1 mm tone scale.
SEPARATION_CELL = 0.5
#: Gaussian sigma (mm) of the colour the separation matches. Each pen's tone loop blurs its amount
#: by the style's hatch blur (1 mm) again, so what the pens are asked for is the picture blurred
#: twice: 0.5 mm here (was 1 mm) keeps the colour of features a millimetre or two across
#: (bench/colour.py ΔE00 at 1 mm: astronaut 4.10 -> 3.93, grace_hopper 4.18 -> 3.99); none at
#: all follows the sketch's pencil texture into more, shorter dashes (grace_hopper 64 min of
#: plot, against 55).
SEPARATION_BLUR = 0.5
#: Each pen's tone loop matches its amount at this share of the style's blur (``hatch_blur``): a
#: pen's errors at the scale of its hatch pattern are colour errors there, not only darkness.
#: 0.7 (was 1): ΔE00 at 1 mm astronaut 3.93 -> 3.88, grace_hopper 3.99 -> 3.90, messi5 5.13 ->
#: 5.05, coffee 3.70 -> 3.65, for 1-2 minutes more plot; 3 mm within ±0.1.
PEN_TONE_BLUR = 0.7
#: Least coverage a pen is asked for: less is a scatter of stray dashes that reads as specks, not
#: as a tint (dropping it moved no bench photo's ΔE00 by more than 0.02).
LEAST_INK = 0.03
#: Most coverage asked of one pen: all its hatch families at their densest still show some paper.
MOST_INK = 0.95
#: Cost of a unit of ink against a unit of squared colour error (CIELAB / 116). 1e-3 (2e-3 in the
#: old cube-root RGB units, where it cost grace_hopper's plot ΔE00 0.5 at 3 mm): a neutral grey
#: still goes to black; the separation itself (its amounts as exact coverage, stacked) is ΔE00
#: 1.3 / 1.6 from the sketch at 1 mm on astronaut / grace_hopper (was 2.8 / 3.3), for a few
#: per cent more ink (plot 62 -> 64 min, 52 -> 61 min).
INK_COST = 1e-3
#: Keeps the Gauss–Newton system well posed where pens are interchangeable (more pens than channels).
DAMPING = 1e-4
#: Steps from no ink to the optimum (the table's cells converge in 20 to 30).
ROUNDS = 30
#: Samples per sRGB axis of the table :func:`separation_table` solves once per pen set.
TABLE_SIZE = 33
#: Changed whenever :func:`separate` changes in a way its constants do not show: the tables kept
#: in the cache folder (:func:`separation_table`) are then solved again.
TABLE_VERSION = 1
#: Gauss–Newton rounds that take the table's interpolated amounts to each cell's own optimum
#: (interpolation blends neighbouring solutions: a pure cyan would get a trace of other pens).
POLISH_ROUNDS = 5
#: A pen laying less than this share of all the ink is asked whether the picture needs it ...
SPARE_SHARE = 0.02
#: ... and left out if without it no more than this share of the cells (1/200 of an A4 sheet is
#: 3 cm² in all) ...
SPARE_CELLS = 0.005
#: ... change by this CIEDE2000 or more (a difference anyone sees side by side).
SPARE_DELTA_E = 5.0
_FLOOR = 0.01  # cube roots of X, Y, Z, offset: their slope stays finite at black


def separate(
    target: np.ndarray,
    pens: Sequence[Pen],
    *,
    most: float = MOST_INK,
    ink_cost: float = INK_COST,
    rounds: int = ROUNDS,
    start: np.ndarray | None = None,
) -> np.ndarray:
    """The coverage of each pen whose stacked inks best match a colour picture.

    Parameters
    ----------
    target : (H, W, 3) float array
        The colour to match, sRGB in [0, 1] (1 = the paper).
    pens : sequence of Pen
        The inks.
    most : float
        Largest coverage of one pen, in (0, 1].
    ink_cost : float
        Cost per unit of coverage (against squared error in cube-root linear light).
    rounds : int
        Levenberg–Marquardt steps.
    start : (K, H, W) array, optional
        Amounts to start from (default none of any pen): a good guess needs few rounds.

    Returns
    -------
    (K, H, W) float32 array in [0, most]
        Coverage of each pen, in the order of ``pens``.
    """
    shape = target.shape[:2]
    goal = _lab(srgb_to_linear(target).reshape(-1, 3))  # (N, 3)
    absorb = 1.0 - srgb_to_linear(np.array([pen.rgb for pen in pens]))  # (K, 3)
    k = len(pens)
    amount = (
        np.zeros((goal.shape[0], k))
        if start is None
        else np.clip(start.reshape(k, -1).T.astype(np.float64), 0.0, most)
    )

    def cost(a):
        """Per cell: the cost, each pen's filter (N, K, 3), the reflectance and the residual (N, 3)."""
        filters = 1.0 - a[:, :, None] * absorb[None]
        reflect = np.prod(filters, axis=1)
        residual = _lab(reflect) - goal
        spent = (
            0.5 * (residual**2).sum(axis=1) + ink_cost * a.sum(axis=1) + 0.5 * DAMPING * (a**2).sum(axis=1)
        )
        return spent, filters, reflect, residual

    eye = np.eye(k)
    spent, filters, reflect, residual = cost(amount)
    trust = np.full(goal.shape[0], 1e-2)  # Levenberg–Marquardt damping, per cell
    for _ in range(rounds):
        jac = _slope(reflect, -reflect[:, None, :] * absorb[None] / np.maximum(filters, 1e-6))  # (N, K, 3)
        grad = np.einsum("nkc,nc->nk", jac, residual) + ink_cost + DAMPING * amount
        hess = np.einsum("nkc,njc->nkj", jac, jac) + (DAMPING + trust)[:, None, None] * eye
        # Projected Newton: a pen at a bound whose gradient pushes it further out is held there.
        held = ((amount <= 0.0) & (grad > 0)) | ((amount >= most) & (grad < 0))
        hess = np.where(held[:, :, None] | held[:, None, :], 0.0, hess) + held[:, :, None] * eye
        grad = np.where(held, 0.0, grad)
        trial = np.clip(amount - np.linalg.solve(hess, grad[..., None])[..., 0], 0.0, most)
        trial_cost, trial_filters, trial_reflect, trial_residual = cost(trial)
        # A step is kept only where it lowers the cost; elsewhere the next one is shorter.
        better = trial_cost < spent
        amount[better], spent[better] = trial[better], trial_cost[better]
        filters[better], reflect[better], residual[better] = (
            trial_filters[better],
            trial_reflect[better],
            trial_residual[better],
        )
        trust = np.where(better, np.maximum(trust * 0.3, 1e-9), trust * 10.0)
    return amount.T.reshape(k, *shape).astype(np.float32)


@lru_cache(maxsize=8)
def separation_table(colors: tuple[str, ...]) -> np.ndarray:
    """(K, S, S, S): :func:`separate` solved on a grid of S = :data:`TABLE_SIZE` sRGB values per
    axis, for pens of ``colors``; a picture is separated by trilinear interpolation in it (solving
    every cell of an A4 sheet would take seconds, the table a few once per pen set).

    Once solved it is kept in the user's cache folder (:func:`~pencilbot.configs_io.cache_folder`):
    every process (each of the studio's previews, each ``pencilbot plan``) took 2-8 s solving it
    again. A file that is not such a table is solved again; a folder that cannot be written is
    only not used."""
    path = cache_folder() / "separation" / f"{_table_key(colors)}.npy"
    shape = (len(colors), TABLE_SIZE, TABLE_SIZE, TABLE_SIZE)
    try:
        table = np.load(path, allow_pickle=False)
        if table.shape == shape and table.dtype == np.float32 and np.all((table >= 0) & (table <= MOST_INK)):
            return table
    except (OSError, ValueError, EOFError):
        pass
    table = _solve_table(colors)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        saved = io.BytesIO()
        np.save(saved, table, allow_pickle=False)
        write_atomic(path, saved.getvalue())
    except (OSError, PencilbotError):
        pass
    return table


def _table_key(colors: tuple[str, ...]) -> str:
    """The cached table's name: its pens' colours and everything its solution depends on."""
    solver = (
        TABLE_VERSION,
        TABLE_SIZE,
        MOST_INK,
        INK_COST,
        DAMPING,
        ROUNDS,
        _FLOOR,
        _XYZ.tolist(),
        _LAB.tolist(),
    )
    return hashlib.sha256(repr((tuple(colors), solver)).encode()).hexdigest()[:32]


def _solve_table(colors: tuple[str, ...]) -> np.ndarray:
    axis = np.linspace(0.0, 1.0, TABLE_SIZE)
    cube = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 1, 3)
    pens = [Pen(f"pen{k}", color, 0.5) for k, color in enumerate(colors)]
    return separate(cube, pens).reshape(len(colors), TABLE_SIZE, TABLE_SIZE, TABLE_SIZE)


#: Linear sRGB -> CIE XYZ (D65), each row scaled so that white is (1, 1, 1).
_XYZ = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
_XYZ = _XYZ / _XYZ.sum(axis=1, keepdims=True)
#: CIELAB's L*, a*, b* from the cube roots of X, Y, Z, in units of L* / 116.
_LAB = np.array([[0.0, 1.0, 0.0], [500 / 116, -500 / 116, 0.0], [0.0, 200 / 116, -200 / 116]])


def _lab(linear: np.ndarray) -> np.ndarray:
    """(N, 3) linear RGB -> CIELAB / 116 (the cube roots offset by ``_FLOOR``: finite slope at black)."""
    return np.cbrt(linear @ _XYZ.T + _FLOOR) @ _LAB.T


def _slope(linear: np.ndarray, change: np.ndarray) -> np.ndarray:
    """(N, K, 3): how :func:`_lab` of ``linear`` (N, 3) moves along each of K ``change`` (N, K, 3)."""
    cube = (linear @ _XYZ.T + _FLOOR) ** (-2.0 / 3.0) / 3.0
    return (cube[:, None, :] * (change @ _XYZ.T)) @ _LAB.T


def pen_angles(base: Sequence[float], index: int, count: int) -> tuple[float, ...]:
    """The hatch angles (degrees to the form) of the ``index``-th of ``count`` pens.

    The family angles of a pen come in 45° steps, so pens are told apart by their offset modulo
    45°: spread evenly over it, the lines of two pens always cross at ``45 / count`` degrees or
    more. Each pen's first family, the one light tones get alone, also turns by a further 45° per
    pen, so the lightest tones of different pens cross at a wide angle.
    """
    offset = index * 45.0 / max(count, 1) + 45.0 * (index % 4)
    return tuple((angle + offset + 90.0) % 180.0 - 90.0 for angle in base)


def color_hatching(
    target: np.ndarray,
    layout,
    pens: Sequence[Pen],
    edges: Paths,
    *,
    form: np.ndarray,
    paper: np.ndarray,
    hatching: Hatching,
    draft: bool = False,
) -> list[Layer]:
    """Hatch layers of every pen whose stacked inks follow a colour picture.

    Parameters
    ----------
    target : (H, W, 3) float array
        The colour sketch, sRGB in [0, 1], on the layout's image grid.
    layout : Layout
    pens : sequence of Pen
        In load order (lightest first); the last draws the contours ``edges`` and carries their ink.
    edges : Paths
        Contour strokes (page mm) drawn in the last pen.
    form : (H, W) float array
        Tone whose forms every pen's hatching follows (the black plan's darkness).
    paper : (H, W) float array
        The photo's darkness (see :func:`~pencilbot.planning.shading.shade`).
    hatching : Hatching
        The style's hatching; each pen draws it with its own width, turns its angles by
        :func:`pen_angles`, its seed by 101 a pen, and matches its tone at :data:`PEN_TONE_BLUR`
        of its ``blur``.
    draft : bool
        For a quick preview: the separation read from :func:`separation_table` alone, not
        polished per cell (see :func:`separation`).

    Returns
    -------
    list of Layer
        Each pen's hatch layers (lightest family first), pens in the given order; every layer
        carries its pen's name, colour and width.
    """
    amounts = separation(target, layout, pens, polish=0 if draft else POLISH_ROUNDS)
    layers = []
    for index, (pen, amount) in enumerate(zip(pens, amounts)):
        if not np.any(amount > 0.0):
            continue
        last = index == len(pens) - 1
        pen_hatching = replace(
            hatching,
            pen_width=pen.width,
            angles=pen_angles(hatching.angles, index, len(pens)),
            seed=hatching.seed + 101 * index,
            blur=PEN_TONE_BLUR * hatching.blur,
        )
        hatches = pen_hatching.shade(amount, layout, edges if last else Paths.empty(), paper=paper, form=form)
        layers += [
            Layer(
                f"{pen.name}-{layer.name}",
                layer.paths,
                pen_width=pen.width,
                role="hatch",
                pen=pen.name,
                color=pen.color,
            )
            for layer in hatches
            if layer.paths
        ]
    return layers


def separation(target: np.ndarray, layout, pens: Sequence[Pen], *, polish: int = POLISH_ROUNDS) -> np.ndarray:
    """(K, H, W): the separation of ``target`` blurred by :data:`SEPARATION_BLUR` on cells of
    :data:`SEPARATION_CELL` mm (:func:`separate_cells`, its table's amounts polished by ``polish``
    rounds: 0 for a quick preview, whose amounts are then a blend of the table's neighbouring
    solutions), brought back to the layout's image grid.

    A pen the picture can do without (:func:`unneeded_pens`) gets no ink at all: its pen change
    would cost the person at the plotter more than its ink gives the picture.
    """
    height, width = target.shape[:2]
    linear = srgb_to_linear(target).astype(np.float32)
    # Blurred in linear light: that is how the eye averages ink and paper.
    blurred = (
        cv2.GaussianBlur(linear, (0, 0), SEPARATION_BLUR / layout.mm_per_px, borderType=cv2.BORDER_REPLICATE)
        if SEPARATION_BLUR > 0
        else linear
    )
    factor = max(1.0, SEPARATION_CELL / layout.mm_per_px)
    small = linear_to_srgb(
        cv2.resize(
            blurred,
            (max(1, round(width / factor)), max(1, round(height / factor))),
            interpolation=cv2.INTER_AREA,
        )
    )
    amounts = separate_cells(small, pens, polish)
    dropped = unneeded_pens(small, pens, amounts, polish)
    if dropped:
        kept = [k for k in range(len(pens)) if k not in dropped]
        amounts = np.zeros_like(amounts)
        amounts[kept] = separate_cells(small, [pens[k] for k in kept], polish)
    return np.stack([cv2.resize(a, (width, height), interpolation=cv2.INTER_LINEAR) for a in amounts])


def separate_cells(colors: np.ndarray, pens: Sequence[Pen], polish: int = POLISH_ROUNDS) -> np.ndarray:
    """(K, h, w): :func:`separate` of an sRGB picture by interpolation in :func:`separation_table`,
    polished by ``polish`` rounds (none: the interpolation as it is); coverage under
    :data:`LEAST_INK` left out."""
    table = separation_table(tuple(pen.color for pen in pens))
    at = colors.reshape(-1, 3).T * (TABLE_SIZE - 1)
    guess = np.stack(
        [ndi.map_coordinates(t, at, order=1, mode="nearest").reshape(colors.shape[:2]) for t in table]
    )
    amounts = (
        separate(colors, pens, rounds=polish, start=guess) if polish > 0 else np.clip(guess, 0.0, MOST_INK)
    )
    amounts[amounts < LEAST_INK] = 0.0
    return amounts


def unneeded_pens(
    colors: np.ndarray, pens: Sequence[Pen], amounts: np.ndarray, polish: int = POLISH_ROUNDS
) -> list[int]:
    """Pens (indices; never the last, which draws the contours) whose ink the picture can do without.

    A pen is a candidate when it lays under :data:`SPARE_SHARE` of all the ink; it is dropped when
    separating without it makes no more than :data:`SPARE_CELLS` of the cells worse by
    :data:`SPARE_DELTA_E` or more (CIEDE2000 on the separation's grid). Measured: rocket's yellow
    lamps (3.5 % of its cells change that much without yellow) keep their pen; coffee's trace of
    cyan (0.4 %) and chelsea's (0.2 %) lose it, and its pen change.
    """
    total = float(amounts.sum()) or 1.0
    candidates = [k for k in range(len(pens) - 1) if 0 < amounts[k].sum() < SPARE_SHARE * total]
    if not candidates:
        return []
    goal = rgb2lab(colors)
    before = deltaE_ciede2000(goal, rgb2lab(_stacked(amounts, pens)))
    dropped = []
    # One at a time, the least used first, each judged with the ones before it gone: pens that
    # could stand in for each other (yellow and orange) are not all dropped at once.
    for k in sorted(candidates, key=lambda k: amounts[k].sum()):
        others = [pens[j] for j in range(len(pens)) if j != k and j not in dropped]
        without = deltaE_ciede2000(goal, rgb2lab(_stacked(separate_cells(colors, others, polish), others)))
        if np.mean(without - before >= SPARE_DELTA_E) <= SPARE_CELLS:
            dropped.append(k)
    return dropped


def _stacked(amounts: np.ndarray, pens: Sequence[Pen]) -> np.ndarray:
    return inks_on_paper(list(amounts), [pen.color for pen in pens]).astype(np.float64)
