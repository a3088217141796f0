"""How the hatching families share the darkness: each one's coverage as the tone darkens.

The families share the darkness with overlapping ramps: family j starts before family j − 1 is
full, so cross-hatching fades in continuously instead of appearing as a band. Parallel lines
cover w/s each; families stack as 1 − Π(1 − cⱼ); :meth:`Onset.allocate` inverts that stack, so
a darkness request becomes each family's coverage (:mod:`pencilbot.planning.hatching` draws it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Onset:
    """How the families share the darkness: each one's coverage as the tone darkens.

    Family j's coverage is ``coverage · clip((u − j·stagger) / ramp, 0, 1)`` for an amount u in
    [0, 1]; :meth:`amount` finds the u that gives a wanted total darkness.
    """

    families: int
    coverage: float
    stagger: float
    ramp: float

    @classmethod
    def spread(cls, families: int, coverage: float, overlap: float) -> Onset:
        """Ramps of equal length, each starting when the one before is ``1 − overlap`` on."""
        ramp = 1.0 / (1.0 + (families - 1) * (1.0 - overlap))
        return cls(families, coverage, ramp * (1.0 - overlap), ramp)

    def coverages(self, amount: np.ndarray) -> np.ndarray:
        """(families, N) coverage of each family for amounts u."""
        u = np.asarray(amount, np.float64)
        starts = np.arange(self.families)[:, None] * self.stagger
        return self.coverage * np.clip((u[None, :] - starts) / self.ramp, 0.0, 1.0)

    def darkness(self, amount: np.ndarray) -> np.ndarray:
        """Total darkness 1 − Π(1 − cⱼ) for amounts u."""
        return 1.0 - np.prod(1.0 - self.coverages(np.ravel(amount)), axis=0).reshape(np.shape(amount))

    @property
    def darkest(self) -> float:
        return float(1.0 - (1.0 - self.coverage) ** self.families)

    def amount(self, darkness: np.ndarray) -> np.ndarray:
        """The amount u in [0, 1] whose total darkness is ``darkness`` (clipped to what is reachable)."""
        u = np.linspace(0.0, 1.0, 1025)
        return np.interp(np.clip(darkness, 0.0, self.darkest), self.darkness(u), u)

    def allocate(self, darkness: np.ndarray, capacity: np.ndarray) -> np.ndarray:
        """(families, N) coverage of each family for ``darkness`` (N,) when family j can cover
        at most ``capacity[j]`` there (its lines spread where the field fans out).

        The amount u is raised until the capped families together reach the darkness (or all
        are full), so what one family cannot lay down the next ones do. Bisection on u,
        whole-array.
        """
        d = np.ravel(np.asarray(darkness, np.float64))
        cap = np.asarray(capacity, np.float64).reshape(self.families, -1)
        u = self.amount(d)
        # Where no family's capacity binds, the uncapped amount is exact; elsewhere bisect.
        bound = np.flatnonzero(np.any(self.coverages(u) > cap, axis=0))
        lo, hi = u[bound], np.ones(bound.size)
        for _ in range(10):  # u to 1e-3
            mid = 0.5 * (lo + hi)
            reached = 1.0 - np.prod(1.0 - np.minimum(self.coverages(mid), cap[:, bound]), axis=0)
            short = reached < d[bound]
            lo, hi = np.where(short, mid, lo), np.where(short, hi, mid)
        u[bound] = hi
        u[d <= 0] = 0.0
        return np.minimum(self.coverages(u), cap)
