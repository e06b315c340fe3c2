"""How many threads this process may use: its cores, and ``$REPULSIONPAK_THREADS``.

The simulation's numba threads (:func:`repulsionpak.sim.runner.auto_threads`), the GEOS
distances of many pairs (:mod:`repulsionpak.geometry.pairwise`), a report's distortion
fits (:func:`repulsionpak.packing.fit_workers`) and the per-copy work after the simulation
(:func:`thread_map`: mapping the art, measuring and bending it) all read the same cap, so
that packings run side by side (``REPULSIONPAK_THREADS=1``) keep to one thread each.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

from .errors import ParameterError

__all__ = ["MIN_ITEMS", "MOST_WORKERS", "THREADS_ENV", "cores", "thread_cap", "thread_map", "warnings_kept",
           "worker_threads"]

T = TypeVar("T")
R = TypeVar("R")

#: environment variable: the most threads a run uses (e.g. 1 when several packings run
#: side by side on the same cores)
THREADS_ENV = "REPULSIONPAK_THREADS"

#: the most threads that share geometry work (pair distances, distortion fits)
MOST_WORKERS = 4
#: :func:`thread_map` runs shorter lists in the calling thread (a pool costs ~0.1 ms)
MIN_ITEMS = 8


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        return os.cpu_count() or 1


def thread_cap() -> int | None:
    """``$REPULSIONPAK_THREADS`` as a number of threads; None when it is unset.

    Raises
    ------
    ParameterError
        When it is set to anything but a positive whole number.
    """
    text = os.environ.get(THREADS_ENV, "").strip()
    if not text:
        return None
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise ParameterError(f"{THREADS_ENV} must be a positive whole number of threads, got {text!r}")
    return n


def worker_threads(strict: bool = True) -> int:
    """Threads for geometry work shared over threads: this process's cores, at most
    :data:`MOST_WORKERS` and at most :func:`thread_cap`.

    Parameters
    ----------
    strict : bool
        False: an unreadable ``$REPULSIONPAK_THREADS`` counts as unset (for work that runs
        after the simulation has refused it, or without one) instead of raising.
    """
    try:
        cap = thread_cap()
    except ParameterError:
        if strict:
            raise
        cap = None
    n = cores() if cap is None else min(cores(), cap)
    return max(1, min(MOST_WORKERS, n))


def thread_map(fn: Callable[[T], R], items: Iterable[T], workers: int | None = None) -> list[R]:
    """``[fn(x) for x in items]``, shared over threads.

    Parameters
    ----------
    fn : callable
        Work on one item that does not depend on the others (one copy's art: its
        mapping, its area, its bends). Its heavy parts must release the GIL (GEOS through
        shapely, numpy's linear algebra, numba kernels compiled with ``nogil=True``) for
        the threads to gain anything; it must not call the simulation's parallel kernels,
        which run on the main thread only (docs/algorithm.md, "Threads").
    items : iterable
        The items, in order.
    workers : int, optional
        Threads to use; default :func:`worker_threads` (the cores, at most
        :data:`MOST_WORKERS` and ``$REPULSIONPAK_THREADS``).

    Returns
    -------
    list
        The results in the order of ``items``: the same values on any number of threads.

    Notes
    -----
    Lists shorter than :data:`MIN_ITEMS` run in the calling thread. An exception raised
    by ``fn`` is raised here (the first one in the order of ``items``). The warning
    filters are put back as they were when the threads are done (:func:`warnings_kept`).
    """
    items = list(items)
    n = worker_threads(strict=False) if workers is None else max(1, int(workers))
    n = min(n, len(items))
    if n <= 1 or len(items) < MIN_ITEMS:
        return [fn(x) for x in items]
    with warnings_kept(), ThreadPoolExecutor(n) as pool:
        return list(pool.map(fn, items))


#: what ``warnings.catch_warnings`` swaps in and out of the warnings module
_WARNING_STATE = ("filters", "showwarning", "_showwarnmsg_impl")


@contextlib.contextmanager
def warnings_kept():
    """The warnings module's filters and display as they are on entry, put back on exit.

    Notes
    -----
    ``warnings.catch_warnings`` (before Python 3.14) swaps process-wide state, and
    shapely enters it on every ``is_valid``: two threads inside it at once can leave one
    thread's "ignore" filter in place when both are done, which silenced every later
    warning of the run (the verification's "element dropped", a test's
    ``pytest.warns``). Threads started inside this block must be done when it ends.
    """
    saved = {name: getattr(warnings, name) for name in _WARNING_STATE}
    try:
        yield
    finally:
        for name, value in saved.items():
            setattr(warnings, name, value)
        mutated = getattr(warnings, "_filters_mutated", None)  # (what catch_warnings calls)
        if callable(mutated):
            mutated()
