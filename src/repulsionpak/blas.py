"""One BLAS thread while packing and measuring, so that a seed gives the same packing on
every machine.

numpy's matrix products and linear solves run in the BLAS numpy was built with (OpenBLAS
in the wheels), which splits the work over the machine's cores; with another number of
threads the last bits of a result can differ, and the simulation, the verification and
the pocket fill amplify them into another packing. So the packing depended on the
machine: ``repulsionpak batch`` (Dask's workers run with ``OPENBLAS_NUM_THREADS=1``)
wrote other packings than ``repulsionpak pack`` with the same seed on a two-core machine,
and ``OPENBLAS_NUM_THREADS=1 repulsionpak pack`` did too. The matrices here are small
(a mesh's spline, a copy's samples): one thread costs nothing measurable.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Within the block, the BLAS libraries loaded in this process use one thread
    (threadpoolctl); nothing changes where threadpoolctl is not installed."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover  (a dependency; an environment without it still packs)
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield


def with_one_blas_thread(func: Callable) -> Callable:
    """Decorator: ``func`` runs within :func:`one_blas_thread`."""
    @functools.wraps(func)
    def wrapped(*args, **kwargs):
        with one_blas_thread():
            return func(*args, **kwargs)
    return wrapped
