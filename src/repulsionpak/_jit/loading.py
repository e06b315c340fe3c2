"""Loading the package's kernels from numba's disk cache without numba's compiler set-up.

Before it loads a cached kernel, numba "refreshes" its compiler: it imports every module
of typing and lowering implementations it has (``numba.np.arraymath`` among them, which
imports ``scipy.linalg`` to look for BLAS; ``numba.typed``, ``numba.np.random``, the cffi
support ...) and installs their registries. A compiler needs them; machine code read
from the cache does not: it is linked against the C symbols numba installs when its CPU
target is created (its helper library, the Python C API, libm), the runtime's (NRT) and,
for a parallel kernel, the threading layer's (its cache entry starts the layer when
loaded). That refresh took 0.3 s of a warm-cache run's 0.5 s of kernel loading (heart
scene), and every later load took ~5 ms.

:func:`install` makes numba load this package's kernels with only the set-up machine
code needs (:func:`_runtime_ready`); a kernel that has to be compiled still gets the full
refresh (numba's compiler does it before compiling), and so does every other package's
numba function.

Notes
-----
numba's private cache API (``numba.core.caching.Cache``): when it lacks what is used here,
:func:`install` changes nothing and kernels load as before.

Loading a kernel still imports the modules of the numba implementations it calls (their
environments): ``np.empty`` brings ``numba.np.arrayobj`` (~20 ms), ``ndarray.sum``
``numba.np.arraymath`` and with it ``scipy.linalg`` (~0.2 s), so the kernels total by a
loop (``tests/test_kernels.py`` checks that a warm run imports neither).

The hash secret's symbols come from importing ``numba.cpython.hashing`` (and with it
numba's unicode and character-sequence support: ~22 ms of every run). Only machine code
that hashes refers to them, and none of this package's kernels does; so a kernel's cache
entry is read here and the module imported, before the entry's machine code is linked,
only when the entry names the symbols (:func:`_needs_hash_secret`).

:func:`loading_ahead` loads a run's kernels on a second thread while the first reads the
inputs: most of a load is LLVM linking the machine code, which runs without the GIL.
"""

from __future__ import annotations

import contextlib
import pickle
import sys
import threading

__all__ = ["cached", "install", "installed", "load_cached", "loading_ahead"]

#: functions defined in modules under this prefix load without the refresh
_PACKAGE = __name__.split(".")[0] + "."
_original = None
#: the prefix of the hash secret's symbols (``numba.cpython.hashing`` installs them)
_HASH_SECRET = b"_numba_hashsecret_"
_HASHING = "numba.cpython.hashing"


def _runtime_ready(target_context) -> None:
    """What machine code from the cache needs besides the CPU target: numba's runtime
    (NRT) initialised (the hash secret's symbols are installed by :func:`_load_entry`,
    for the entries that need them)."""
    from numba.core.runtime import rtsys

    rtsys.initialize(target_context)


def _needs_hash_secret(raw: bytes) -> bool:
    """Whether a cache entry's bytes (pickled, with the object code) name the hash
    secret's symbols, while they are not installed yet."""
    return _HASHING not in sys.modules and _HASH_SECRET in raw


def _load_entry(cache, sig, target_context):
    """numba's ``Cache._load_overload`` and ``IndexDataCacheFile.load``: the cached
    overload of ``sig``, or None; installs the hash secret's symbols first when the entry
    refers to them (see the module docstring)."""
    if not cache._enabled:
        return None
    files = cache._cache_file
    name = files._load_index().get(cache._index_key(sig, target_context.codegen()))
    if name is None:
        return None
    try:
        with open(files._data_path(name), "rb") as fh:
            raw = fh.read()
    except OSError:  # removed while the index still names it (as numba's load)
        return None
    if _needs_hash_secret(raw):
        import numba.cpython.hashing  # noqa: F401  (installs the symbols)
    with _quiet_llvm_lock():
        return cache._impl.rebuild(target_context, pickle.loads(raw))


@contextlib.contextmanager
def _quiet_llvm_lock():
    """llvmlite's lock without the callbacks numba registers on it (for the duration of a
    load): every call into LLVM takes that lock, and numba's callbacks broadcast a start
    and an end event through its event system each time. Rebuilding a cached kernel makes
    150–180 such calls (reading the kernel's module, listing the symbols it defines); the
    events cost a few µs a call, about a tenth of the loading (no listener waits for
    them here: they time compilations, and nothing is compiled)."""
    from llvmlite.binding import ffi  # (numba's own dependency)

    lock = getattr(getattr(ffi, "lib", None), "_lock", None)
    callbacks = getattr(lock, "_cblist", None)
    if not isinstance(callbacks, list) or not callbacks:
        yield
        return
    lock._cblist = []
    try:
        yield
    finally:
        lock._cblist = callbacks


def _load_overload(self, sig, target_context):
    """``numba.core.caching.Cache.load_overload``, without the registry refresh for this
    package's kernels (see the module docstring)."""
    if not getattr(getattr(self, "_py_func", None), "__module__", "").startswith(_PACKAGE):
        return _original(self, sig, target_context)
    _runtime_ready(target_context)
    with self._guard_against_spurious_io_errors():
        return _load_entry(self, sig, target_context)


def install() -> bool:
    """Make numba load this package's cached kernels without its compiler's set-up; once
    per process, before the first kernel is called.

    Returns
    -------
    bool
        Whether the lean loading is in place (False where numba's cache lacks the private
        methods it relies on: kernels then load as numba does by default).
    """
    global _original
    if _original is not None:
        return True
    try:
        from numba.core.caching import Cache, IndexDataCacheFile
        from numba.core.runtime import rtsys  # noqa: F401
    except ImportError:
        return False
    needed = ("load_overload", "_index_key", "_guard_against_spurious_io_errors")
    if not all(callable(getattr(Cache, name, None)) for name in needed) or not all(
            callable(getattr(IndexDataCacheFile, name, None)) for name in ("_load_index", "_data_path")):
        return False
    _original = Cache.load_overload
    Cache.load_overload = _load_overload
    return True


def installed() -> bool:
    """Whether :func:`install` put the lean loading in place."""
    return _original is not None


def cached(dispatcher, sig) -> bool:
    """Whether numba's disk cache holds ``dispatcher``'s specialisation ``sig`` (reads
    only its small index file)."""
    cache = dispatcher._cache
    return cache._index_key(sig, dispatcher.targetctx.codegen()) in cache._cache_file._load_index()


def load_cached(calls, stop: threading.Event | None = None) -> int:
    """Load each specialisation ``(dispatcher, argument types)`` of ``calls`` that numba's
    disk cache holds and the dispatcher lacks; compile none (a kernel the cache lacks is
    compiled where it is first called). Stops early once ``stop`` is set. Returns the
    number loaded."""
    loaded = 0
    try:
        for dispatcher, sig in calls:
            if stop is not None and stop.is_set():
                break
            if sig not in dispatcher.overloads and cached(dispatcher, sig):
                dispatcher.compile(sig)  # a load: numba looks in its cache first
                loaded += 1
    except Exception:  # noqa: BLE001  (private numba API: the run loads what it needs)
        pass
    return loaded


@contextlib.contextmanager
def loading_ahead(calls):
    """Within the block, a second thread loads ``calls`` from numba's disk cache while this
    thread reads and meshes the inputs (and loads the first kernels itself as it calls them).

    Parameters
    ----------
    calls : list of (dispatcher, argument types)
        What to load, in order
        (:func:`~repulsionpak._jit.kernels.calls_to_load_ahead`); empty: nothing (beside a
        warm-up process, which compiles the kernels and shares that work with this one by
        claims, :mod:`repulsionpak._jit.warmup`).

    Notes
    -----
    Loading the ~35 specialisations of a packing takes ~0.15 s (65 ms of it the first
    load, which sets up numba's runtime), most of it in LLVM, which releases the GIL, so
    on a second core it overlaps the reading of the inputs.
    numba's compiler lock orders the two threads: a kernel is loaded once, by whichever
    comes first. A parallel build's cache entry starts numba's threading layer when it is
    loaded: ``calls`` holds parallel builds only once the layer runs (started on the main
    thread: with TBB a layer started elsewhere can hang the exit). The block waits for the
    thread at its end, however it ends.
    """
    thread = stop = None
    if calls:
        stop = threading.Event()
        thread = threading.Thread(target=load_cached, args=(list(calls), stop),
                                  name="repulsionpak-kernel-loading", daemon=True)
        thread.start()
    try:
        yield
    finally:
        if thread is not None:
            stop.set()
            thread.join()
