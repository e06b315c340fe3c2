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

__all__ = ["MANY_PARTS", "covering", "dilated", "dilation", "room_left"]

#: art of more parts than this (dots, lettering) is dilated part by part (:func:`dilated`)
MANY_PARTS = 16


def covering(reach: float) -> float:
    """The distance to buffer by, with 4 segments a quarter circle, so that the buffer
    covers the true dilation by ``reach`` (its chords come within cos(π/16) ≈ 0.98 of the
    radius at corners)."""
    return reach / math.cos(math.pi / 16)


def dilated(geoms: Sequence, reach: float) -> list:
    """``geoms`` (the non-empty ones) each dilated by ``reach`` (4 segments per quarter
    circle), to be united. A geometry of more than :data:`MANY_PARTS` polygons is dilated
    part by part, its parts' buffers going into the union one by one: GEOS buffers a
    multipolygon as one outline, noding all its parts' offset curves together, which
    grows much faster than its parts (a copy of 100 dots whose buffers overlap: 80 ms,
    against 5 ms part by part; 20 s of a 253-copy packing's pocket fill). The union is
    the same region; art of few parts is buffered whole (same vertices)."""
    whole, parts = [], []
    for g in geoms:
        if g.is_empty:
            continue
        n = shapely.get_num_geometries(g)
        (parts if n > MANY_PARTS else whole).append(g)
    out = list(shapely.buffer(np.asarray(whole, dtype=object), reach, quad_segs=4)) if whole else []
    if parts:
        pieces = shapely.get_parts(np.asarray(parts, dtype=object))
        pieces = pieces[~shapely.is_empty(pieces)]
        out += list(shapely.buffer(pieces, reach, quad_segs=4))
    return out


def dilation(g, reach: float):
    """``g`` dilated by ``reach`` as one geometry (:func:`dilated`: art of many parts
    part by part, then united; else ``g.buffer(reach, quad_segs=4)`` itself)."""
    if shapely.get_num_geometries(g) <= MANY_PARTS:
        return g.buffer(reach, quad_segs=4)
    return union_all(dilated([g], reach))


def room_left(space, geoms: Sequence, reach: float):
    """``space`` less every geometry of ``geoms`` dilated by ``reach`` (:func:`dilated`,
    united and subtracted by the robust overlay); ``space`` itself when ``geoms`` has
    nothing to dilate."""
    taken = dilated(geoms, reach)
    if not taken:
        return space
    return overlay(shapely.difference, space, union_all(taken))
