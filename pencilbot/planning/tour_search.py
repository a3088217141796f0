"""Local search over a pen tour: 2-opt and Or-opt moves between nearby ends, counted in work.

A :class:`Tour` is a linked cycle of the ends of :class:`~pencilbot.planning.tour_ends.Ends`:
a move costs the same whatever its span. 2-opt reverses a run of paths (each path flipped);
Or-opt moves a run of up to ``_MAX_RUN`` paths elsewhere, optionally reversed. Moves are
evaluated with numpy in chunks of ends; the best move of each end is re-checked on the current
tour in float64 and applied if it still gains, best first. Which runs are reversed is kept by
:class:`Intervals`. :func:`descend` spends a :class:`Work` budget, so the same paths always give
the same tour.
"""

from __future__ import annotations

import math
import random
import time
from typing import Any

import numpy as np

from pencilbot.planning.tour_ends import CHUNK, Ends, dist32

_MAX_RUN = 5  # Or-opt moves runs of up to this many paths
_EPS = 1e-9  # mm: gains below this are float noise (decided in float64)
# Work is counted in units that track time (measured): evaluating an end costs 1 (~1.3 µs), a
# float64 check of a move 2, a call's numpy overhead 250.
CALL_COST = 250
_TRY_COST = 2
_REFRESH_HELD = 64  # refresh once 2-opt moves wait at 1/64 of the paths


def _scalars(array: np.ndarray) -> memoryview[Any]:
    """The array's buffer (``array.data``, as ``memoryview(array)``): indexing it gives Python ints
    and floats, for the scalar code; numpy's stubs declare the buffer protocol from Python 3.12."""
    return array.data


class Work:
    """Improvement work left, in the units of ``CALL_COST``; with a ``deadline`` (a
    ``time.process_time()``) also the CPU time."""

    def __init__(self, units: int, deadline: float | None = None) -> None:
        self.left = units
        self.deadline = deadline

    def spend(self, units: int) -> bool:
        """Pay for a call doing ``units`` of work; False (and nothing paid) when the budget is out."""
        if self.left <= 0 or (self.deadline is not None and time.process_time() >= self.deadline):
            self.left = min(self.left, 0)
            return False
        self.left -= units + CALL_COST
        return True


def descend(tour: Tour, work: Work) -> None:
    """Passes of 2-opt and Or-opt moves until a full pass on a fresh tour finds none.

    Each pass looks at the ends near the last pass's moves. 2-opt moves held back for stale
    records wait for a refresh, made when enough of them wait, when so much has moved that
    most would, or when nothing else is left.
    """
    everything = tour.movable_ends()
    active, fresh, waiting = everything, True, []
    while work.spend(len(active)):
        touched, _ = tour.improve(active)
        work.left -= _TRY_COST * tour.tries
        waiting.append(tour.held)
        held = sum(map(len, waiting))
        if touched.size and held < (tour.n + 1) // _REFRESH_HELD and tour.moved < (tour.n + 1) // 8:
            active, fresh = tour.ends_of(touched), False
            continue
        if not touched.size and not held and fresh and active is everything:
            return  # local optimum
        work.spend(tour.n // 8)  # a refresh: ~1/9 of a pass
        tour.refresh()
        retry = np.concatenate([touched, *waiting])
        active, fresh, waiting = (tour.ends_of(retry) if retry.size else everything), True, []


class Tour:
    """A tour as a cycle of path ends: ``adj[x]`` is the end the pen travels to or from at x.

    Home is node ``n``: its end ``2n + 1`` is the start point and its end ``2n`` (``free``) is
    a point at distance 0 from everything, so the move from the last path to it costs nothing
    and the tour is a cycle: the open tour is read from the start point, away from ``free``.
    2-opt and Or-opt moves are then a few changes of ``adj``, whatever their span.

    Or-opt moves are valid in any cycle. A 2-opt move is valid only between two
    ends that are both exits (or both entries) in one direction of travel. :meth:`refresh`
    walks the cycle and records each node's position and each end's role. Until the next
    refresh, nodes that Or-opt moves carry elsewhere are ``dirty`` (their record is
    stale), and 2-opt moves are accepted only between clean ends and only if, as intervals of
    recorded positions, they nest in or stay apart from the 2-opt moves already made: a run
    between them then turned round together with both ends or with neither, so the recorded
    roles still decide validity.
    """

    def __init__(self, ends: Ends, adj: np.ndarray) -> None:
        self.n = n = ends.n
        self.free, self.home = 2 * n, 2 * n + 1
        self.points32, self.free_gap = ends.points32, ends.free_gap
        self.neighbours, self.distances = ends.neighbours, ends.distances
        self.adj = adj
        self.travel = self._dist(np.arange(2 * (n + 1)), adj)  # end → length of its travel edge
        self.pos = np.zeros(n + 1, np.int32)  # node → position at the last refresh (home: 0)
        self.exits = np.zeros(2 * (n + 1), np.int8)  # end → 1 if its path is left there
        self.dirty = np.zeros(n + 1, np.uint8)  # per node: moved since the last refresh
        # memoryviews give Python ints and floats from the arrays, for the scalar code below
        self._adj, self._pos, self._exits = _scalars(adj), _scalars(self.pos), _scalars(self.exits)
        self._dirty, self._travel = _scalars(self.dirty), _scalars(self.travel)
        self._xy = _scalars(ends.points.ravel())
        self.refresh()

    # -- state ------------------------------------------------------------------------------
    def refresh(self) -> None:
        """Walk the cycle from home: positions and roles for 2-opt, nothing dirty."""
        adj, x = self._adj, self.home
        walk = [x]  # the exit end of each node, in travel order (the loop does only the walk)
        step = walk.append
        for _ in range(self.n):
            x = adj[x] ^ 1
            step(x)
        order = np.array(walk, np.int32)
        self.pos[order >> 1] = np.arange(self.n + 1, dtype=np.int32)
        self.exits[order] = 1
        self.exits[order ^ 1] = 0
        self.dirty[:] = 0
        self.moved = 0
        self.reversed = Intervals(self.n + 1)
        self.held = np.zeros(0, np.int32)  # nodes of the 2-opt moves the last pass held back

    def result(self) -> tuple[np.ndarray, np.ndarray]:
        """``(order, reverse)`` of the open tour from home."""
        self.refresh()
        seq = np.empty(self.n + 1, np.int64)
        seq[self.pos] = np.arange(self.n + 1)
        order = seq[1:]
        return order, self.exits[2 * order] == 1  # left at its first point: drawn reversed

    def movable_ends(self) -> np.ndarray:
        return np.arange(2 * self.n + 2, dtype=np.int32)

    def ends_of(self, nodes: np.ndarray) -> np.ndarray:
        # Sorted and distinct, as np.unique gives them; a mask over the nodes is cheaper.
        nodes = self._distinct_nodes(nodes)
        return np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel().astype(np.int32)

    def _distinct_nodes(self, nodes) -> np.ndarray:
        """Sorted distinct node ids (``np.unique``, by a mask over all nodes: no sort, no hash)."""
        mask = np.zeros(self.n + 1, bool)
        mask[nodes] = True
        return np.flatnonzero(mask).astype(np.int32)

    # -- vectorised candidate moves ---------------------------------------------------------
    def improve(self, ends: np.ndarray) -> tuple[np.ndarray, float]:
        """Apply the improving moves found from ``ends``: the nodes whose edges changed, mm gained."""
        found = [self._candidates(ends[lo : lo + CHUNK]) for lo in range(0, len(ends), CHUNK)]
        found.append(self._candidates(self._near_the_end(), with_free=True))
        kind, e, f, gain = (np.concatenate(x) for x in zip(*found))
        self.held, self.tries = np.zeros(0, np.int32), 0
        if not gain.size:
            return np.zeros(0, np.int32), 0.0
        # The best move of each end, applied best first after a fresh check on the current tour.
        best = np.lexsort((-gain, e))
        best = best[np.r_[True, e[best][1:] != e[best][:-1]]]
        best = best[np.argsort(-gain[best], kind="stable")]
        touched: list[int] = []
        self._held: list[int] = []
        gained, attempt = 0.0, self._try
        for kd, ee, ff in zip(kind[best].tolist(), e[best].tolist(), f[best].tolist()):
            gained += attempt(kd, ee, ff, touched)
        self.held, self.tries = np.array(self._held, np.int32), len(best)
        return self._distinct_nodes(np.array(touched, np.int32)), gained

    def _near_the_end(self) -> np.ndarray:
        """Ends whose moves to or from the tour's free end can gain: around the last exit."""
        last = self.adj[self.free]
        near = self.neighbours[last]
        return np.unique(np.concatenate([[last], near, self.adj[near]]))

    def _dist(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """float32 costs of travel between ends: 0 to or from ``free`` and for joined gaps."""
        d = dist32(self.points32, a, b)
        d[(a == self.free) | (b == self.free) | (d <= self.free_gap)] = 0
        return d

    def _candidates(self, ends: np.ndarray, with_free: bool = False):
        """Improving moves from pairs (end, nearby end): arrays (kind, e, f, gain).

        Each end is paired with its k nearest ends, or with ``free`` both ways round (moves to
        and from the end of the tour). kind 0 is 2-opt, 1 to ``_MAX_RUN`` Or-opt of a run of
        that many paths from f. Gains are float32 estimates; :meth:`_try` decides in float64.
        """
        if with_free:
            free = np.full(len(ends), self.free, np.int32)
            e, f = np.concatenate([ends, free]), np.concatenate([free, ends])
            d = np.zeros(len(e), np.float32)
        else:
            e = np.repeat(ends, self.neighbours.shape[1])
            f = self.neighbours[ends].ravel()
            d = self.distances[ends].ravel()
            d[(e == self.free) | (f == self.free)] = 0  # free is in the tree too, at home
        de, df = self.travel[e], self.travel[f]
        # A move that shortens the tour adds an edge shorter than one it removes next to it
        # (the gain criterion of Lin–Kernighan), so other pairs cannot start an improving move.
        # (Masks as indices: converted once, then taken from every array.)
        m = np.flatnonzero((d < np.maximum(de, df)) & ((e >> 1) != (f >> 1)))
        e, f, d, de, df = e[m], f[m], d[m], de[m], df[m]
        adj = self.adj
        ae, af = adj[e], adj[f]
        m = np.flatnonzero(f != ae)
        e, f, ae, af, d, de, df = e[m], f[m], ae[m], af[m], d[m], de[m], df[m]
        kinds, es, fs, gains = [], [], [], []

        def keep(kind, sel, gain):
            good = gain > 1e-6
            kinds.append(np.full(int(good.sum()), kind, np.int8))
            es.append(e[sel][good])
            fs.append(f[sel][good])
            gains.append(gain[good])

        # 2-opt: travel e–f and ae–af instead of e–ae and f–af (a run between them turns round).
        s = self.exits[e] == self.exits[f]
        keep(0, s, de[s] + df[s] - d[s] - self._dist(ae[s], af[s]))
        # Or-opt: the run of `length` paths from f (away from af) goes between e and ae, f to e.
        g, inside = f ^ 1, (f >> 1) == (e >> 1)
        for length in range(1, _MAX_RUN + 1):
            if length > 1:
                g = adj[g] ^ 1
                inside |= (g >> 1) == (e >> 1)
            ag = adj[g]
            removed = df + self.travel[g] + de - d  # minus the two other new edges: a bound first
            ok = ~inside & (e != af) & (e != ag) & (g != af) & (removed > 1e-6)
            gain = removed[ok] - self._dist(af[ok], ag[ok]) - self._dist(g[ok], ae[ok])
            keep(length, ok, gain)
        return tuple(np.concatenate(x) for x in (kinds, es, fs, gains))

    # -- scalar check and application --------------------------------------------------------
    def _gap(self, a: int, b: int) -> float:
        free = self.free
        if a == free or b == free:
            return 0.0
        xy, a, b = self._xy, 2 * a, 2 * b
        d = math.hypot(xy[a] - xy[b], xy[a + 1] - xy[b + 1])
        return d if d > self.free_gap else 0.0

    def _link(self, a: int, b: int) -> None:
        """Make a and b travel partners."""
        adj = self._adj
        adj[a] = b
        adj[b] = a
        self._travel[a] = self._travel[b] = self._gap(a, b)

    def _mark(self, node: int) -> None:
        if not self._dirty[node]:
            self._dirty[node] = 1
            self.moved += 1

    def _try(self, kind: int, e: int, f: int, touched: list[int]) -> float:
        """Recompute move (kind, e, f) on the current tour in float64; apply it if it gains.

        Returns the gain in mm (0 when not applied); the nodes around the changed edges are
        added to ``touched``.
        """
        adj, gap = self._adj, self._gap  # (locals: this runs about once per path and pass)
        ae, af = adj[e], adj[f]
        if (e >> 1) == (f >> 1) or f == ae:
            return 0.0
        if kind == 0:
            exits = self._exits
            if exits[e] != exits[f]:
                return 0.0
            # Recorded positions of the two travel edges (edge t leaves position t), in order.
            pos, dirty = self._pos, self._dirty
            a, b = pos[e >> 1], pos[f >> 1]
            if not exits[e]:
                a, b = (a - 1) % (self.n + 1), (b - 1) % (self.n + 1)
            if a > b:
                a, b = b, a
            if dirty[e >> 1] or dirty[f >> 1] or not self.reversed.fits(a, b):
                self._held.append(e >> 1)  # may be valid: retried after a refresh
                return 0.0
            gain = gap(e, ae) + gap(f, af) - gap(e, f) - gap(ae, af)
            if gain <= _EPS:
                return 0.0
            self.reversed.add(a, b)
            self._link(e, f)
            self._link(ae, af)
            touched += (e >> 1, ae >> 1, f >> 1, af >> 1)
            return gain
        run = [f >> 1]
        g = f ^ 1
        for _ in range(kind - 1):
            g = adj[g] ^ 1
            run.append(g >> 1)
        ag = adj[g]
        if (e >> 1) in run or e in (af, ag) or g == af or len(set(run)) < kind:
            return 0.0
        gain = gap(f, af) + gap(g, ag) + gap(e, ae)
        gain -= gap(af, ag) + gap(e, f) + gap(g, ae)
        if gain <= _EPS:
            return 0.0
        for node in run:
            self._mark(node)
        self._link(af, ag)
        self._link(e, f)
        self._link(g, ae)
        touched += (e >> 1, ae >> 1, af >> 1, ag >> 1, *run)
        return gain


class Intervals:
    """A laminar set of intervals [a, b] of 0..size-1: does a new one nest or stay apart?

    Each interval XORs a random 62-bit tag into a cell at both ends, so the XOR of the cells
    a < t < b is 0 exactly when every interval with an end inside has both ends inside (up to a
    2^-62 chance of a false match per test). Ends are never shared. Tests far outnumber
    intervals, so prefix XORs are kept in blocks of ``2^shift`` cells: a test reads four
    numbers, an interval rewrites two slices of about √size each.
    """

    def __init__(self, size: int) -> None:
        self.shift = max(4, (max(size, 1).bit_length() + 1) // 2)
        self.within = np.zeros(size, np.uint64)  # XOR of the cells from the block start to t
        self.before = np.zeros((size >> self.shift) + 2, np.uint64)  # XOR of the blocks before
        self._within, self._before = _scalars(self.within), _scalars(self.before)
        self.used = bytearray(size)
        self.rng = random.Random(size)

    def _toggle(self, t: int, tag: int) -> None:
        block = t >> self.shift
        self.within[t : (block + 1) << self.shift] ^= tag
        self.before[block + 1 :] ^= tag

    def fits(self, a: int, b: int) -> bool:
        if self.used[a] or self.used[b]:
            return False
        # XOR of the cells a+1..b-1: (XOR of 0..b-1) ^ (XOR of 0..a).
        within, before, shift = self._within, self._before, self.shift
        x = before[a >> shift] ^ within[a]
        if b:
            x ^= before[(b - 1) >> shift] ^ within[b - 1]
        return x == 0

    def add(self, a: int, b: int) -> None:
        tag = self.rng.getrandbits(62)
        self._toggle(a, tag)
        self._toggle(b, tag)
        self.used[a] = self.used[b] = 1
