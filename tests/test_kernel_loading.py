"""Kernels loaded from numba's cache without its compiler set-up (repulsionpak._jit.loading):
the hash secret's symbols are installed only for machine code that refers to them."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: a kernel that hashes a string, in a module under the package's name (the lean loading
#: applies to the package's kernels only), and one that does not
_KERNELS = '''
from numba import njit

@njit(cache=True)
def string_hash(s):
    return hash(s)

@njit(cache=True)
def plain(x):
    return x + 1
'''

#: a child's start: the lean loading in place, the kernels' module (``sys.argv[1]``) imported
#: as ``mod`` under the package's name
_IMPORT_PROBE = '''
import importlib.util, sys
from repulsionpak._jit import loading
loading.install()
spec = importlib.util.spec_from_file_location("repulsionpak._loading_probe", sys.argv[1])
mod = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = mod
spec.loader.exec_module(mod)
'''

#: loads (or, on a cold cache, compiles) the kernels named on the command line and prints
#: the results, then whether numba's hashing module was imported
_RUN = _IMPORT_PROBE + '''
out = []
for name in sys.argv[2:]:
    out.append(mod.string_hash("packing") == hash("packing") if name == "hash" else mod.plain(1))
print(out, "numba.cpython.hashing" in sys.modules)
'''


def _run(tmp: Path, *names: str) -> str:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp / "cache"), PYTHONPATH=str(ROOT / "src"),
               PYTHONHASHSEED="0")
    proc = subprocess.run([sys.executable, "-c", _RUN, str(tmp / "probe.py"), *names],
                          capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.strip().splitlines()[-1]


def test_hash_secret_is_installed_only_for_kernels_that_use_it(tmp_path):
    (tmp_path / "probe.py").write_text(_KERNELS)
    _run(tmp_path, "hash", "plain")  # compiles both into the cache
    assert _run(tmp_path, "plain") == "[2] False"  # loaded: no hashing import
    assert _run(tmp_path, "plain", "hash") == "[2, True] True"  # loaded, with the symbols


#: three kernels like ``plain``: the first call loads the runtime, the second is loaded as
#: the package loads, the third with llvmlite's lock callbacks left in place
_THREE = _KERNELS + "".join(f"\n@njit(cache=True)\ndef plain{k}(x):\n    return x + {k}\n" for k in (2, 3))

#: calls into LLVM (the lock's callbacks) while each of ``plain2`` and ``plain3`` loads;
#: then whether the lock's callbacks are as they were
_QUIET = _IMPORT_PROBE + '''
import contextlib
from llvmlite.binding import ffi
assert mod.plain(1) == 2  # (numba's runtime set up)
seen = []
def count():
    seen.append(1)
ffi.register_lock_callback(count, count)
before = list(ffi.lib._lock._cblist)
assert mod.plain2(1) == 3
quiet = len(seen)
loading._quiet_llvm_lock = contextlib.nullcontext
assert mod.plain3(1) == 4
print(quiet, len(seen) - quiet, ffi.lib._lock._cblist == before)
'''


def test_loading_a_cached_kernel_skips_the_lock_callbacks_and_restores_them(tmp_path):
    (tmp_path / "probe.py").write_text(_THREE)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(ROOT / "src"))
    for _ in range(2):  # compiles the kernels into the cache, then loads them
        proc = subprocess.run([sys.executable, "-c", _QUIET, str(tmp_path / "probe.py")],
                              capture_output=True, text=True, env=env, timeout=300)
        assert proc.returncode == 0, proc.stderr
    quiet, loud, restored = proc.stdout.split()
    # the rebuild's calls into LLVM (most of a load's) no longer run the callbacks; the
    # dispatcher's own calls around it still do, and the callbacks are back afterwards
    assert int(quiet) < int(loud) / 3, (quiet, loud)
    assert restored == "True"


#: the cached specialisations ``plain(int64)`` and ``plain2(int64)`` and the uncached
#: ``plain3(float64)`` loaded ahead (``sys.argv[2]``: "on" or "off") within a block that
#: lasts until the first two are loaded (at most 30 s; 1 s when off); then what each
#: dispatcher holds and whether the loading thread is still alive
_AHEAD = _IMPORT_PROBE + '''
import threading, time
from numba.core import types
from repulsionpak._jit import kernels, signatures
calls = [(mod.plain, (types.int64,)), (mod.plain2, (types.int64,)), (mod.plain3, (types.float64,))]
signatures.load_signatures = lambda: list(calls)
with loading.loading_ahead(kernels.calls_to_load_ahead(parallel=False) if sys.argv[2] == "on" else []):
    end = time.monotonic() + (30 if sys.argv[2] == "on" else 1)
    while time.monotonic() < end and not (mod.plain.overloads and mod.plain2.overloads):
        time.sleep(0.01)
    time.sleep(0.2)  # (time for a compile of plain3, were it attempted)
alive = any(t.name == "repulsionpak-kernel-loading" for t in threading.enumerate())
print([len(d.overloads) for d, _ in calls], alive)
'''


def test_loading_ahead_loads_the_cached_kernels_and_compiles_none(tmp_path):
    (tmp_path / "probe.py").write_text(_THREE)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(ROOT / "src"))
    warm = _IMPORT_PROBE + "\nmod.plain(1); mod.plain2(1)\n"  # caches plain and plain2 (int64)
    subprocess.run([sys.executable, "-c", warm, str(tmp_path / "probe.py")], check=True, env=env, timeout=300)

    def ahead(mode):
        proc = subprocess.run([sys.executable, "-c", _AHEAD, str(tmp_path / "probe.py"), mode],
                              capture_output=True, text=True, env=env, timeout=300)
        assert proc.returncode == 0, proc.stderr
        return proc.stdout.strip().splitlines()[-1]

    # the thread loaded both cached ones and compiled nothing; the block waited for it
    assert ahead("on") == "[1, 1, 0] False"
    assert ahead("off") == "[0, 0, 0] False"


#: a kernel with a parallel build, in the probe module
_PARALLEL = '''
from numba import prange
from repulsionpak._jit.kernels import parallel_kernel

@parallel_kernel
def twice(x):
    for i in prange(x.shape[0]):
        x[i] *= 2.0
'''

#: ``twice``'s parallel build run (and so cached) with two threads
_RUN_PARALLEL = _IMPORT_PROBE + '''
import numpy as np
from repulsionpak._jit import kernels
kernels.set_threads(2)
x = np.ones(4)
mod.twice(x)
assert x.tolist() == [2.0] * 4
'''

#: the recorded specialisation ``twice(float64[:])``: how many specialisations its parallel
#: build holds after a plain switch to two threads, and after a simulation's
_SWITCH = _IMPORT_PROBE + '''
from numba.core import types
from repulsionpak._jit import kernels, signatures
signatures.load_signatures = lambda: [(mod.twice.serial, (types.Array(types.float64, 1, "C"),))]
kernels.set_threads(2)  # (as a run restoring the thread count it found)
before = len(mod.twice.parallel.overloads)
kernels.set_threads(1)
kernels.set_threads(2, load=True)  # (as a simulation going to two threads)
print(before, len(mod.twice.parallel.overloads))
'''


#: ``twice`` loaded ahead, its parallel build asked for (``sys.argv[2]`` "on") or not: how
#: many specialisations its serial and parallel builds hold after the block, the threads
#: that asked for the threading layer before it was started, and whether the loading
#: thread asked for it at all
_AHEAD_PARALLEL = _IMPORT_PROBE + '''
import threading, time
from numba.core import types
from numba.np.ufunc import parallel as P
from repulsionpak._jit import kernels, signatures
asked = []
launch = P._launch_threads
def recorded():
    asked.append((threading.current_thread().name, bool(P._is_initialized)))
    return launch()
P._launch_threads = recorded
signatures.load_signatures = lambda: [(mod.twice.serial, (types.Array(types.float64, 1, "C"),))]
with loading.loading_ahead(kernels.calls_to_load_ahead(parallel=sys.argv[2] == "on")):
    end = time.monotonic() + (30 if sys.argv[2] == "on" else 1)
    while time.monotonic() < end and not mod.twice.parallel.overloads:
        time.sleep(0.01)
print(len(mod.twice.serial.overloads), len(mod.twice.parallel.overloads),
      sorted(set(name for name, started in asked if not started)),
      any(name == "repulsionpak-kernel-loading" for name, _ in asked))
'''


def test_loading_ahead_loads_the_parallel_builds_with_the_layer_started_here(tmp_path):
    """With two threads allowed the parallel builds are loaded ahead too (the simulation
    loaded them when it first went to two threads: ~45 ms of the heart's primary stage),
    and the threading layer their cache entries start is started on the main thread
    first: the loading thread only finds it running."""
    (tmp_path / "probe.py").write_text(_PARALLEL)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(ROOT / "src"),
               NUMBA_NUM_THREADS="2")
    warm = _IMPORT_PROBE + '''
import numpy as np
from repulsionpak._jit import kernels
x = np.ones(4)
mod.twice(x)  # the serial build
kernels.set_threads(2)
mod.twice(x)  # the parallel one
assert x.tolist() == [4.0] * 4
'''
    subprocess.run([sys.executable, "-c", warm, str(tmp_path / "probe.py")], check=True, env=env, timeout=300)
    def ahead(mode):
        proc = subprocess.run([sys.executable, "-c", _AHEAD_PARALLEL, str(tmp_path / "probe.py"), mode],
                              capture_output=True, text=True, env=env, timeout=300)
        assert proc.returncode == 0, proc.stderr
        return proc.stdout.split()

    # both builds loaded; the layer was started by the main thread, never by the loader
    assert ahead("on") == ["1", "1", "['MainThread']", "True"]
    # one thread allowed (pack asks for the parallel builds when auto_threads() > 1): left alone
    assert ahead("off") == ["1", "0", "[]", "False"]


def test_the_first_switch_to_threads_loads_every_parallel_build(tmp_path):
    """All at once, between two iterations: a kernel loaded on its first call inside the
    thread governor's measurement made two threads look slower than one."""
    (tmp_path / "probe.py").write_text(_PARALLEL)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(ROOT / "src"),
               NUMBA_NUM_THREADS="2")
    for script in (_RUN_PARALLEL, _SWITCH):
        proc = subprocess.run([sys.executable, "-c", script, str(tmp_path / "probe.py")],
                              capture_output=True, text=True, env=env, timeout=300)
        assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["0", "1"]
