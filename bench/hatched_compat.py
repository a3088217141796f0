"""hatched 0.2 under shapely 2, for the benches that run it as a peer (fidelity, optimize)."""

import numpy as np
from shapely.geometry import MultiLineString


def lines_of(geometry=None) -> MultiLineString:
    """What hatched 0.2 expects of ``MultiLineString(...)``: it builds empty levels from an empty
    numpy array, which shapely 2 refuses, and wraps intersection results that may be
    collections: take their line parts."""
    if geometry is None or (isinstance(geometry, np.ndarray) and geometry.size == 0):
        return MultiLineString()
    if hasattr(geometry, "geoms") and not isinstance(geometry, MultiLineString):
        return MultiLineString([g for g in geometry.geoms if g.geom_type == "LineString"])
    return MultiLineString(geometry)


def patch_hatched():
    """Import hatched with :func:`lines_of` in place of its ``MultiLineString``; returns it."""
    import hatched

    hatched.hatched.MultiLineString = lines_of
    return hatched
