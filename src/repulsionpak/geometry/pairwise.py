"""Distances of many pairs of geometries, measured on several threads.

The final verification and the gap statistics measure the distance between the art of
thousands of neighbouring copies (a 1,000-element poster: ~2.5 s in the verification's
repair rounds, ~1 s in the report's gaps). GEOS measures each pair on its own and shapely
releases the interpreter's lock while it does, so :func:`distances` splits a long list of
pairs into one contiguous share per thread: the same values, to the bit, in less time on
a machine with a spare core. Two outlines of many vertices each (art traced to tens of
thousands of points) GEOS compares segment against segment (1 s for a 12,000-point ring
around a disc, 25–43 s for outlines of ~100,000 points around each other);
:func:`dense_distance` measures them piece by piece through an index.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import shapely

from ..threads import warnings_kept, worker_threads

__all__ = ["DENSE", "MIN_PAIRS", "PIECE", "dense_distance", "distances", "near_pairs", "threads"]

#: pairs per thread below which one thread measures them all (starting a thread costs
#: ~0.1 ms; a pair of packed copies' outlines 20–50 µs)
MIN_PAIRS = 256


#: pairs whose vertex counts multiply to more than this are measured by
#: :func:`dense_distance` (GEOS: ~2 ns a pair of segments, ~20 ms here; the pieces win
#: from about 5,000,000 on)
DENSE = 10_000_000

#: segments per indexed piece of a dense outline (:func:`dense_distance`)
PIECE = 16


#: GEOS's type id of a geometry collection, which has no boundary: measured whole
_COLLECTION = 7


def _pieces(g) -> np.ndarray:
    """The boundary of ``g`` cut into linestrings of :data:`PIECE` segments."""
    out = []
    for ring in shapely.get_parts(shapely.boundary(g) if shapely.get_dimensions(g) == 2 else g):
        xy = shapely.get_coordinates(ring)
        for k in range(0, len(xy) - 1, PIECE):
            out.append(xy[k:k + PIECE + 1])
    if not out:
        return np.empty(0, object)
    sizes = np.array([len(q) for q in out])
    return shapely.linestrings(np.concatenate(out), indices=np.repeat(np.arange(len(out)), sizes))


def dense_distance(a, b) -> float:
    """``shapely.distance(a, b)`` of two polygonal or lineal geometries, measured between
    short pieces of their boundaries through an STR tree.

    Parameters
    ----------
    a, b : shapely geometry
        Polygons, linestrings, or multi-part ones of either (a mixed collection is
        measured whole by GEOS).

    Returns
    -------
    float
        The distance, the same value as ``shapely.distance(a, b)`` to the bit.

    Notes
    -----
    Two geometries that intersect are 0 apart; two that do not are as far apart as their
    boundaries. GEOS measures a pair segment against segment, every pair of segments:
    ~40 s for two traced outlines of 100,000 points around each other. Here the boundaries
    are cut into pieces of :data:`PIECE` segments; the pieces that may hold a nearest
    point (no farther from the other's envelope than one pair of pieces is apart) of the
    one with more are put in a tree, and each of the other's finds its nearest through
    it, measured by the same GEOS segment distance: the least of those is the distance.
    """
    if a.is_empty or b.is_empty or _COLLECTION in (shapely.get_type_id(a), shapely.get_type_id(b)):
        return float(shapely.distance(a, b))
    if shapely.intersects(a, b):
        return 0.0
    pa, pb = _pieces(a), _pieces(b)
    if not len(pa) or not len(pb):
        return float(shapely.distance(a, b))
    # a piece farther from the other's envelope than some pair of pieces is apart holds
    # no nearest point: keep the rest (all, for outlines around each other)
    da = shapely.distance(pa, shapely.envelope(b))
    db = shapely.distance(pb, shapely.envelope(a))
    bound = float(shapely.distance(pa[np.argmin(da)], pb[np.argmin(db)]))
    pa, pb = pa[da <= bound], pb[db <= bound]
    if len(pa) > len(pb):
        pa, pb = pb, pa
    _, d = shapely.STRtree(pb).query_nearest(pa, return_distance=True, all_matches=False)
    return float(min(d.min(), bound))


def threads() -> int:
    """Threads for :func:`distances`: :func:`repulsionpak.threads.worker_threads`, an
    unreadable ``$REPULSIONPAK_THREADS`` counting as unset (the simulation refuses it)."""
    return worker_threads(strict=False)


def distances(a: np.ndarray, b: np.ndarray, workers: int | None = None) -> np.ndarray:
    """``shapely.distance(a, b)`` of two equally long arrays of geometries.

    Parameters
    ----------
    a, b : ndarray of shapely geometries, (n,)
    workers : int, optional
        Threads to share the pairs (default :func:`threads`); each takes at least
        :data:`MIN_PAIRS` of them, so a short list is measured on this thread.

    Returns
    -------
    ndarray, (n,)
        The distances, exactly those of ``shapely.distance(a, b)`` (each pair is
        measured by the same GEOS call whichever thread makes it; pairs of many vertices
        by :func:`dense_distance`, to the same bit).
    """
    n = len(a)
    if n:
        dense = np.flatnonzero(shapely.get_num_coordinates(a).astype(np.float64)
                               * shapely.get_num_coordinates(b) > DENSE)
        if len(dense):
            out = np.empty(n)
            rest = np.setdiff1d(np.arange(n), dense)
            out[rest] = distances(a[rest], b[rest], workers)
            out[dense] = [dense_distance(a[k], b[k]) for k in dense]
            return out
    k = min(threads() if workers is None else max(1, int(workers)), n // MIN_PAIRS)
    if k <= 1:
        return shapely.distance(a, b)
    cuts = np.linspace(0, n, k + 1).astype(np.int64)
    out = np.empty(n)

    def share(j: int) -> None:
        lo, hi = cuts[j], cuts[j + 1]
        out[lo:hi] = shapely.distance(a[lo:hi], b[lo:hi])

    with warnings_kept(), ThreadPoolExecutor(k) as pool:  # (shapely swaps the warning filters)
        for done in [pool.submit(share, j) for j in range(k)]:
            done.result()  # (re-raises a thread's error here)
    return out


def near_pairs(arr: np.ndarray, which: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Candidate pairs of geometries within ``reach`` of each other.

    Parameters
    ----------
    arr : (n,) object array of shapely geometries
    which : (m,) int array
        The indices into ``arr`` to find neighbours of.
    reach : float
        The distance of interest.

    Returns
    -------
    k, j : (p,) int arrays
        The pairs whose bounding boxes meet once ``arr[which[k]]``'s is widened by
        ``reach``: every pair closer than ``reach``, and some farther ones (``j`` may be
        ``which[k]`` itself).

    Notes
    -----
    Callers measure the distance of each pair anyway; an STRtree ``dwithin`` query would
    measure it twice (its exact test costs as much as the distance itself).
    """
    lo = shapely.bounds(arr[which])
    boxes = shapely.box(lo[:, 0] - reach, lo[:, 1] - reach, lo[:, 2] + reach, lo[:, 3] + reach)
    return shapely.STRtree(arr).query(boxes)
