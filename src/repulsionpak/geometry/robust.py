"""Overlay operations that do not fail on nearly degenerate art.

GEOS's overlay (intersection, difference, union ...) can raise a ``TopologyException``
("Ring edge missing", "found non-noded intersection") on valid polygons whose edges are
nearly coincident — deformed, simplified or rescaled art produces them now and then, and
one such pair stopped a whole packing with a traceback. :func:`overlay` runs the operation
as it is; if GEOS refuses, on the inputs made valid; if it still refuses, with GEOS's
snap-rounding noder on a grid of 10⁻⁹ of the inputs' extent (robust by construction, and
far below any distance the packing cares about).
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.errors import GEOSException

__all__ = ["overlay", "union_all"]


def _grid(*geoms) -> float:
    bounds = np.asarray([shapely.total_bounds(g) for g in geoms], dtype=float)
    bounds = bounds[np.all(np.isfinite(bounds), axis=1)]
    if len(bounds) == 0:
        return 1e-12
    extent = float(max(np.ptp(bounds[:, [0, 2]]), np.ptp(bounds[:, [1, 3]])))
    return 1e-9 * extent if extent > 0 else 1e-12


def overlay(op, a, b, **kw):
    """``op(a, b, **kw)`` (``shapely.intersection``, ``difference``, ...; arrays too),
    retried on valid inputs, then on a snap-rounding grid, when GEOS raises."""
    try:
        return op(a, b, **kw)
    except GEOSException:
        pass
    va, vb = shapely.make_valid(a), shapely.make_valid(b)
    try:
        return op(va, vb, **kw)
    except GEOSException:
        return op(va, vb, grid_size=_grid(va, vb), **kw)


def union_all(geoms, **kw):
    """``shapely.union_all`` with the same fallbacks as :func:`overlay`."""
    try:
        return shapely.union_all(geoms, **kw)
    except GEOSException:
        pass
    valid = shapely.make_valid(np.asarray(list(geoms), dtype=object))
    try:
        return shapely.union_all(valid, **kw)
    except GEOSException:
        return shapely.union_all(valid, grid_size=_grid(*valid), **kw)
