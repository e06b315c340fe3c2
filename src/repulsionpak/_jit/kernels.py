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

**Two threads, when they pay.** A run with ``sim.threads = 0`` (the default) uses the
parallel builds on every core once :func:`parallel_ready`: they are in numba's disk cache
(the warm-up process compiles them in the background, :mod:`repulsionpak._jit.warmup`: ~13 CPU
seconds once, against ~6 for the serial builds), and the threading layer hands work
between threads without putting them to sleep. GNU OpenMP's idle threads by default spin
so briefly that on a VM they sleep between two kernels of one iteration, and two threads
ran the heart scene twice as *slowly* as one; :func:`set_threads` therefore sets
``GOMP_SPINCOUNT`` (:data:`GOMP_SPINCOUNT`) before numba starts its threading layer, unless
the user chose ``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` themselves. With it, two threads
run an iteration 1.55× faster at 1,500 vertices and 1.8× at 3,000 (docs/benchmarks.md).

**Which threading layer.** numba prefers TBB where it finds ``libtbb`` (it comes with
OpenCV, CGAL and conda environments). Importing this module makes the order OpenMP, then
numba's own workqueue, then TBB (:func:`choose_threading_layer`), so TBB is never taken
unless the user names it (``NUMBA_THREADING_LAYER`` or ``NUMBA_THREADING_LAYER_PRIORITY``):
TBB's ``finalize`` deadlocks at interpreter exit when a parallel kernel ran on a thread
other than the main one while TBB sees a single core (numba issue #10556), and its idle
workers ran the heart scene at 10–12 ms an iteration against 0.4 ms on one thread.
Neither OpenMP nor the workqueue can hang at exit. Where the layer does not suit the
simulation (the workqueue), an automatic run stays on one thread (:func:`threading_ok`);
while it runs, the simulation's thread governor drops to one thread when
other processes make the second one a burden.
"""

from __future__ import annotations

import functools
import importlib
import os
import types
from collections.abc import Callable, Sequence

import numba
from numba import njit

#: every :class:`Kernel` created so far (a kernel registers itself when its module is imported)
KERNELS: list["Kernel"] = []
_parallel = False

#: the threading layers in the order this package lets numba try them (TBB last: never
#: reached, as the workqueue always loads)
LAYER_PRIORITY = ("omp", "workqueue", "tbb")


def choose_threading_layer() -> bool:
    """Let numba start OpenMP or its workqueue rather than TBB, unless the user chose a
    layer (``NUMBA_THREADING_LAYER`` or ``NUMBA_THREADING_LAYER_PRIORITY`` set).

    Returns
    -------
    bool
        True when this call set the order (then also in ``os.environ``, so that the
        warm-up process and batch workers, which this process starts, choose alike).

    Notes
    -----
    Must run before numba starts its threading layer (the first parallel kernel call or
    :func:`numba.get_num_threads`); it runs when this module is imported. See the module
    docstring for why not TBB.
    """
    if "NUMBA_THREADING_LAYER" in os.environ or "NUMBA_THREADING_LAYER_PRIORITY" in os.environ:
        return False
    os.environ["NUMBA_THREADING_LAYER_PRIORITY"] = " ".join(LAYER_PRIORITY)
    numba.config.THREADING_LAYER_PRIORITY = list(LAYER_PRIORITY)
    return True


choose_threading_layer()


class Kernel:
    """A kernel with a serial and a (lazily compiled) parallel build; calls go to the
    build :func:`set_threads` selected. ``py_func`` is the plain Python function."""

    def __init__(self, func: Callable):
        functools.update_wrapper(self, func)
        self.py_func = func
        self.serial = njit(cache=True)(func)
        self._parallel = None
        self._impl = self.parallel if _parallel else self.serial
        KERNELS.append(self)

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


#: GNU OpenMP's spin count for idle threads (its default lets them sleep between kernels;
#: about a millisecond of spinning keeps them awake through an iteration and lets them
#: sleep soon after the simulation ends)
GOMP_SPINCOUNT = "1000000"
#: whether idle threads spin between kernels (None: the threading layer not prepared yet)
_handover_ok: bool | None = None


def _gomp_loaded() -> bool:
    """Whether GNU OpenMP is loaded in this process already (it reads its environment once,
    when it is loaded). False where that cannot be told (not Linux)."""
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            return "libgomp" in fh.read()
    except OSError:
        return False


def _prepare_threading() -> None:
    """Before numba starts its threading layer: let GNU OpenMP's idle threads spin between
    kernels (``GOMP_SPINCOUNT``) unless the user set a wait policy, and note whether idle
    threads will spin (not with ``OMP_WAIT_POLICY=PASSIVE``, nor when libgomp was loaded
    before this could be set)."""
    global _handover_ok
    if _handover_ok is not None:
        return
    from numba.np.ufunc import parallel

    policy = os.environ.get("OMP_WAIT_POLICY")
    if policy is not None or "GOMP_SPINCOUNT" in os.environ:  # the user's choice
        _handover_ok = policy is None or policy.strip().upper() != "PASSIVE"
    elif parallel._is_initialized or _gomp_loaded():
        _handover_ok = False  # too late: libgomp has read its environment already
    else:
        os.environ["GOMP_SPINCOUNT"] = GOMP_SPINCOUNT
        _handover_ok = True


def threading_ok() -> bool:
    """Whether several threads hand work over fast enough for an automatic run to use them:
    OpenMP (with spinning idle threads where it is GNU's, see :func:`_prepare_threading`) or
    TBB; not numba's fallback workqueue layer (1.3 ms an iteration on the heart scene
    against 0.5 ms on one thread)."""
    _prepare_threading()
    numba.get_num_threads()  # starts the threading layer
    try:
        layer = numba.threading_layer()
    except ValueError:
        return False
    if layer == "omp":
        try:
            from numba.np.ufunc import omppool

            vendor = omppool.openmp_vendor
        except (ImportError, AttributeError):
            vendor = "GNU"
        return vendor != "GNU" or bool(_handover_ok)
    return layer == "tbb"


def is_cached(dispatcher) -> bool:
    """Whether numba's disk cache holds an entry for ``dispatcher`` (reads only its small
    index file; numba's private cache API, so callers guard against its changes)."""
    return bool(dispatcher._cache._cache_file._load_index())


def parallel_cached() -> bool:
    """True when every kernel a default run calls (those recorded in the warm-up's
    signature file, :mod:`repulsionpak._jit.signatures`) has its parallel build cached or compiled in
    this process. Kernels only some runs call (designer controls, the shape force) compile
    their parallel build when first used. Reads only the small cache index files; False
    when that cannot be told."""
    from .signatures import load_signatures

    try:
        calls = load_signatures()
        if calls is None:
            return False
        serial = {id(d) for d, _ in calls}
        used = [k for k in KERNELS if id(k.serial) in serial]
        return bool(used) and all(k.parallel.signatures or is_cached(k.parallel) for k in used)
    except Exception:  # noqa: BLE001  (private numba API: stay with one thread)
        return False


def parallel_ready() -> bool:
    """Whether an automatic run (``sim.threads = 0``) may use the parallel builds: they are
    cached (:func:`parallel_cached`) and the threading layer suits them (:func:`threading_ok`)."""
    return parallel_cached() and threading_ok()


def set_threads(n: int, load: bool = False) -> int:
    """``numba.set_num_threads(n)`` and select the parallel builds when ``n > 1``, the
    serial ones otherwise. Returns the previous thread count.

    Parameters
    ----------
    n
        The thread count.
    load
        With ``n > 1``, load every recorded parallel build now (:func:`load_parallel_builds`,
        once per process): a simulation about to run on several threads asks for it.
    """
    global _parallel
    _prepare_threading()
    old = numba.get_num_threads()
    numba.set_num_threads(n)
    if load and n > 1:
        load_parallel_builds()
    if (n > 1) != _parallel:
        _parallel = n > 1
        for k in KERNELS:
            k._select(_parallel)
    return old


#: whether :func:`load_parallel_builds` ran in this process
_parallel_loaded = False


def load_parallel_builds() -> int:
    """Load the parallel build of every specialisation a run calls (those recorded in the
    warm-up's signature file, :mod:`repulsionpak._jit.signatures`) that numba's disk cache
    holds; compiles none. Once per process; returns the number loaded.

    Notes
    -----
    The simulation asks for this (``set_threads(n, load=True)``) when it first goes to
    several threads, so that all the loads (~60 ms on the heart) fall between two
    iterations. Loaded lazily, the kernels called only at a full neighbour query (every
    ``sim.requery_every`` iterations) were loaded inside the thread governor's first
    window on two threads, and the 6 ms load made two threads lose to one on the heart
    (0.41 against 0.30 ms an iteration, when they take 0.2): the run then stayed on one
    thread for 300-700 iterations.
    """
    global _parallel_loaded
    if _parallel_loaded:
        return 0
    from .loading import load_cached
    from .signatures import load_signatures

    calls = load_signatures()
    if calls is None:  # (not while the warm-up's recording stands in for the kernels)
        return 0
    _parallel_loaded = True
    return load_cached(parallel_calls(calls))


def calls_to_load_ahead(parallel: bool) -> list:
    """What a run's kernels loading thread loads (:func:`repulsionpak._jit.loading.loading_ahead`):
    the recorded specialisations (:mod:`repulsionpak._jit.signatures`), from the last one a
    run calls to the first, and with ``parallel`` (the run may use several threads) their
    parallel builds after them, when those are ready (:func:`parallel_ready`).

    Notes
    -----
    :func:`parallel_ready` starts numba's threading layer on the calling thread, the main
    one: a parallel build's cache entry starts the layer when it is loaded, and on the
    loading thread it would start there. Loaded ahead, the parallel builds cost the
    simulation nothing at its first switch to two threads (~45 ms on the heart).
    """
    from .signatures import load_signatures

    calls = load_signatures()
    if not calls:
        return []
    out = calls[::-1]
    if parallel and parallel_ready():
        out += parallel_calls(calls)[::-1]
    return out


def parallel_calls(calls) -> list:
    """The parallel builds' ``(dispatcher, argument types)`` of the serial ones in ``calls``
    (the package's kernels among them; the others are left out)."""
    builds = {id(k.serial): k for k in KERNELS}
    return [(builds[id(d)].parallel, sig) for d, sig in calls if id(d) in builds]


def uses_parallel_builds() -> bool:
    return _parallel


def cache_is_cold(modules: Sequence[str] = ()) -> bool:
    """Whether the simulation kernels still have to be compiled: True when numba's disk
    cache holds no valid entry for the serial build of any kernel (the first run, or the
    sources changed since). Not *some* kernel: one a run never calls (a force switched
    off by default) is never cached.

    Parameters
    ----------
    modules
        Modules to import first (by name): a kernel registers itself in :data:`KERNELS`
        when its module is imported, and only registered kernels count.

    Returns
    -------
    bool
        Reads only the small cache index files; False when that cannot be told (a numba
        without these internals).
    """
    for name in modules:
        importlib.import_module(name)
    try:
        return not any(is_cached(k.serial) for k in KERNELS)
    except Exception:  # noqa: BLE001  (private numba API: stay silent rather than fail)
        return False


__all__ = ["Kernel", "KERNELS", "parallel_kernel", "set_threads", "load_parallel_builds", "choose_threading_layer",
           "LAYER_PRIORITY", "uses_parallel_builds", "cache_is_cold", "is_cached", "parallel_cached", "parallel_ready",
           "threading_ok", "GOMP_SPINCOUNT"]
