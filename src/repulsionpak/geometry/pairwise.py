"""Distances of many pairs of geometries, measured on several threads.

The final verification and the gap statistics measure the distance between the art of
thousands of neighbouring copies (a 1,000-element poster: ~2.5 s in the verification's
repair rounds, ~1 s in the report's gaps). GEOS measures each pair on its own and shapely
releases the interpreter's lock while it does, so :func:`distances` splits a long list of
pairs into one contiguous share per thread: the same values, to the bit, in less time on
a machine with a spare core.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import shapely

from ..threads import worker_threads

__all__ = ["MIN_PAIRS", "distances", "threads"]

#: pairs per thread below which one thread measures them all (starting a thread costs
#: ~0.1 ms; a pair of packed copies' outlines 20–50 µs)
MIN_PAIRS = 256


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
        measured by the same GEOS call whichever thread makes it).
    """
    n = len(a)
    k = min(threads() if workers is None else max(1, int(workers)), n // MIN_PAIRS)
    if k <= 1:
        return shapely.distance(a, b)
    cuts = np.linspace(0, n, k + 1).astype(np.int64)
    out = np.empty(n)

    def share(j: int) -> None:
        lo, hi = cuts[j], cuts[j + 1]
        out[lo:hi] = shapely.distance(a[lo:hi], b[lo:hi])

    with ThreadPoolExecutor(k) as pool:
        for done in [pool.submit(share, j) for j in range(k)]:
            done.result()  # (re-raises a thread's error here)
    return out
