"""Dilating art by a distance: the room it takes from its neighbours.

The pocket fills (:mod:`repulsionpak.holes`) and the repair's search for room
(:mod:`repulsionpak.verify.repairs`) take every element's art dilated by the gap out of
the free space (:func:`room_left`). Buffers of 4 segments a quarter circle are cheap but
inscribed in the true dilation; :func:`covering` gives the distance to buffer by so that
they cover it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely

from .robust import overlay, union_all

__all__ = ["CROSSINGS", "FIRST_STEP", "MANY_PARTS", "STEP_TOLERANCE", "covering", "crossings", "dilated",
           "dilation", "room_left"]

#: art of more parts than this (dots, lettering) is dilated part by part (:func:`dilated`)
MANY_PARTS = 16

#: a geometry whose buffer would cross its own offset curves more often than this
#: (:func:`crossings`) is dilated in steps (:func:`_dilated_in_steps`): GEOS spends about
#: 12 µs and 3 kB a crossing, and far more where the teeth are long and thin (an outline
#: of 8,000 points in 0.6-deep teeth, ~280,000 crossings at a gap: 3.3 s and 780 MB at
#: once; of 40,000 points: 84 s)
CROSSINGS = 100_000

#: the first of :func:`_dilated_in_steps`'s steps, a share of the distance; each next
#: step doubles the last
FIRST_STEP = 1.0 / 1024

#: what each step's outline is simplified by, a share of the distance
STEP_TOLERANCE = 0.001


def covering(reach: float) -> float:
    """The distance to buffer by, with 4 segments a quarter circle, so that the buffer
    covers the true dilation by ``reach`` (its chords come within cos(π/16) ≈ 0.98 of the
    radius at corners)."""
    return reach / math.cos(math.pi / 16)


def crossings(g, reach: float) -> int:
    """An estimate of how often the offset curves of ``g``'s buffer by ``reach`` cross:
    the pairs of its vertices less than about ``reach`` apart (vertices binned in cells of
    that size; the sum of the squared counts)."""
    xy = shapely.get_coordinates(g)
    if len(xy) == 0 or not reach > 0:
        return 0
    _, counts = np.unique(np.floor(xy / reach).astype(np.int64), axis=0, return_counts=True)
    return int((counts.astype(np.int64) ** 2).sum())


def _dilated_in_steps(g, reach: float):
    """``g`` dilated by at least ``reach`` in doubling steps, from :data:`FIRST_STEP` of
    ``reach`` on, each step's outline simplified (by :data:`STEP_TOLERANCE` of ``reach``)
    before the next, the rest at once when it is at most twice the last step.

    Notes
    -----
    A buffer costs what its offset curves' crossings cost, and the teeth of a finely
    jagged outline (a noisy trace, fur) make them cross by the thousand: one buffer of a
    copy of 20,000 points in long thin teeth took 9 s. A step far below the teeth's size
    only blunts them, cheaply, and each later step, twice the last, meets an outline
    already rounded at half its size, so no step meets teeth much sharper than itself (the
    27 copies of that packing: 170 s in steps sized by :func:`crossings`, 9.7 s doubling). Dilations add up (a disc of radius a, then one of b, is one of a + b), and
    each 4-segment buffer covers the true dilation by cos(π/16) of its distance as one
    buffer does; a simplification may cut up to its tolerance into the outline, which is
    added to the next step, so the result covers what one buffer by ``reach`` would, and
    about 1 % of ``reach`` more (10 steps of 0.1 %)."""
    eps = STEP_TOLERANCE * reach
    left, step = reach, FIRST_STEP * reach
    while step < 0.5 * left:
        g = shapely.simplify(g.buffer(step, quad_segs=4), eps)
        left = left - step + eps
        step *= 2.0
    return g.buffer(left, quad_segs=4)


def _buffered(geoms: np.ndarray, reach: float) -> list:
    """Each of ``geoms`` buffered by ``reach`` (4 segments a quarter circle), at once,
    but for the dense ones (:func:`crossings` above :data:`CROSSINGS`), which are
    dilated in steps."""
    # (the estimate is at most the squared vertex count: only large outlines are binned)
    big = np.flatnonzero(shapely.get_num_coordinates(geoms).astype(np.float64) ** 2 > CROSSINGS)
    dense = [k for k in big.tolist() if crossings(geoms[k], reach) > CROSSINGS]
    if not dense:
        return list(shapely.buffer(geoms, reach, quad_segs=4))
    out = [None] * len(geoms)
    rest = np.setdiff1d(np.arange(len(geoms)), dense)
    for k, b in zip(rest.tolist(), shapely.buffer(geoms[rest], reach, quad_segs=4)):
        out[k] = b
    for k in dense:
        out[k] = _dilated_in_steps(geoms[k], reach)
    return out


def dilated(geoms: Sequence, reach: float) -> list:
    """``geoms`` (the non-empty ones) each dilated by ``reach`` (4 segments per quarter
    circle), to be united. A geometry of more than :data:`MANY_PARTS` polygons is dilated
    part by part, its parts' buffers going into the union one by one: GEOS buffers a
    multipolygon as one outline, noding all its parts' offset curves together, which
    grows much faster than its parts (a copy of 100 dots whose buffers overlap: 80 ms,
    against 5 ms part by part; 20 s of a 253-copy packing's pocket fill). The union is
    the same region; art of few parts is buffered whole (same vertices). A part of
    many vertices close together (a finely jagged outline) is dilated in steps
    (:data:`CROSSINGS`)."""
    whole, parts = [], []
    for g in geoms:
        if g.is_empty:
            continue
        n = shapely.get_num_geometries(g)
        (parts if n > MANY_PARTS else whole).append(g)
    out = _buffered(np.asarray(whole, dtype=object), reach) if whole else []
    if parts:
        pieces = shapely.get_parts(np.asarray(parts, dtype=object))
        pieces = pieces[~shapely.is_empty(pieces)]
        out += _buffered(pieces, reach)
    return out


def dilation(g, reach: float):
    """``g`` dilated by ``reach`` as one geometry (:func:`dilated`: art of many parts
    part by part, then united; else ``g.buffer(reach, quad_segs=4)`` itself)."""
    if shapely.get_num_geometries(g) <= MANY_PARTS:
        return _buffered(np.asarray([g], dtype=object), reach)[0]
    return union_all(dilated([g], reach))


def room_left(space, geoms: Sequence, reach: float):
    """``space`` less every geometry of ``geoms`` dilated by ``reach`` (:func:`dilated`,
    united and subtracted by the robust overlay); ``space`` itself when ``geoms`` has
    nothing to dilate."""
    taken = dilated(geoms, reach)
    if not taken:
        return space
    return overlay(shapely.difference, space, union_all(taken))
