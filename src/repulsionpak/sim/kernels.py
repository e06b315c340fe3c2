"""Serial and parallel builds of the simulation kernels, and whether they are compiled yet.

numba compiles a ``parallel=True`` kernel 2–3× slower than the same kernel without it
(the parfor passes and the gufunc around every ``prange`` loop), and below
``SimParams.parallel_threshold`` vertices a run uses one thread anyway. So every kernel
decorated with :func:`parallel_kernel` has two builds of the same Python function:

* the **serial** build (``prange`` runs as ``range``), used by default, compiled on its
  first call and cached on disk like every other kernel;
* the **parallel** build, compiled (or loaded from the cache) only when a run asks for
  more than one thread through :func:`set_threads`.

Both builds run the same code in the same order per element or vertex, so a packing does
not depend on which one ran.
"""

from __future__ import annotations

import functools
import types
from collections.abc import Callable

import numba
from numba import njit

_KERNELS: list["Kernel"] = []
_parallel = False


class Kernel:
    """A kernel with a serial and a (lazily compiled) parallel build; calls go to the
    build :func:`set_threads` selected. ``py_func`` is the plain Python function."""

    def __init__(self, func: Callable):
        functools.update_wrapper(self, func)
        self.py_func = func
        self.serial = njit(cache=True)(func)
        self._parallel = None
        self._impl = self.parallel if _parallel else self.serial
        _KERNELS.append(self)

    @property
    def parallel(self):
        if self._parallel is None:
            f = self.py_func
            twin = types.FunctionType(f.__code__, f.__globals__, f.__name__ + "__parallel",
                                      f.__defaults__, f.__closure__)
            # numba names a kernel's cache files after its qualified name: the twin gets
            # files of its own instead of overwriting the serial build's
            twin.__qualname__ = f.__qualname__ + "__parallel"
            twin.__module__ = f.__module__
            self._parallel = njit(cache=True, parallel=True)(twin)
        return self._parallel

    def __call__(self, *args):
        return self._impl(*args)

    def _select(self, parallel: bool) -> None:
        self._impl = self.parallel if parallel else self.serial


def parallel_kernel(func: Callable) -> Kernel:
    """Decorator for kernels written with ``prange``: ``@njit(cache=True, parallel=True)``
    with a serial build for one-thread runs (see the module docstring)."""
    return Kernel(func)


def set_threads(n: int) -> int:
    """``numba.set_num_threads(n)`` and select the parallel builds when ``n > 1``, the
    serial ones otherwise. Returns the previous thread count."""
    global _parallel
    old = numba.get_num_threads()
    numba.set_num_threads(n)
    if (n > 1) != _parallel:
        _parallel = n > 1
        for k in _KERNELS:
            k._select(_parallel)
    return old


def uses_parallel_builds() -> bool:
    return _parallel


def cache_is_cold() -> bool:
    """Whether the simulation kernels still have to be compiled: True when numba's disk
    cache holds no valid entry for the serial build of any kernel (the first run, or the
    sources changed since). Not *some* kernel: one a run never calls (a force switched
    off by default) is never cached. Reads only the small cache index files; False when
    that cannot be told (a numba without these internals)."""
    from . import runner  # noqa: F401  (imports, and so registers, every kernel a run calls)

    try:
        return not any(k.serial._cache._cache_file._load_index() for k in _KERNELS)
    except Exception:  # noqa: BLE001  (private numba API: stay silent rather than fail)
        return False


__all__ = ["Kernel", "parallel_kernel", "set_threads", "uses_parallel_builds", "cache_is_cold"]
