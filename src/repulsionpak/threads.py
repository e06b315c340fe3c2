"""How many threads this process may use: its cores, and ``$REPULSIONPAK_THREADS``.

The simulation's numba threads (:func:`repulsionpak.sim.runner.auto_threads`), the GEOS
distances of many pairs (:mod:`repulsionpak.geometry.pairwise`) and a report's distortion
fits (:func:`repulsionpak.packing.fit_workers`) all read the same cap, so that packings
run side by side (``REPULSIONPAK_THREADS=1``) keep to one thread each.
"""

from __future__ import annotations

import os

from .errors import ParameterError

__all__ = ["MOST_WORKERS", "THREADS_ENV", "cores", "thread_cap", "worker_threads"]

#: environment variable: the most threads a run uses (e.g. 1 when several packings run
#: side by side on the same cores)
THREADS_ENV = "REPULSIONPAK_THREADS"

#: the most threads that share geometry work (pair distances, distortion fits)
MOST_WORKERS = 4


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
