"""The serial/parallel kernel builds (repulsionpak._jit.kernels) and the CLI's first-run
message."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest

from repulsionpak.errors import ParameterError
from repulsionpak._jit import kernels
from repulsionpak.sim.forces import edge_force
from repulsionpak.sim.integrate import euler_step

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "src" / "repulsionpak" / "examples"


def _springs_scene(seed: int = 0):
    rng = np.random.default_rng(seed)
    n_el, per = 6, 12
    x = rng.normal(size=(n_el * per, 2))
    springs, sp_ptr = [], [0]
    for e in range(n_el):
        base = e * per
        for i in range(per):
            springs.append((base + i, base + (i + 1) % per))
            springs.append((base + i, base + (i + 5) % per))
        sp_ptr.append(len(springs))
    springs = np.array(springs, np.int32)
    rest0 = rng.uniform(0.5, 1.5, len(springs))
    growth = rng.uniform(1.0, 1.3, n_el)
    moving = np.array([True, True, False, True, True, True])
    return x, springs, rest0, np.array(sp_ptr, np.int64), growth, moving


def test_set_threads_switches_builds_and_both_give_the_same_forces():
    x, springs, rest0, sp_ptr, growth, moving = _springs_scene()
    f_serial = np.zeros_like(x)
    old = kernels.set_threads(1)
    try:
        assert not kernels.uses_parallel_builds()
        edge_force(x, springs, rest0, sp_ptr, growth, moving, 3.0, f_serial)
        assert edge_force.serial.signatures  # the serial build ran
        kernels.set_threads(2)
        assert kernels.uses_parallel_builds() and numba.get_num_threads() == 2
        f_par = np.zeros_like(x)
        edge_force(x, springs, rest0, sp_ptr, growth, moving, 3.0, f_par)
        assert edge_force.parallel.signatures  # the parallel build ran
    finally:
        kernels.set_threads(old if old > 0 else 1)
    assert not np.allclose(f_serial, 0.0)
    np.testing.assert_array_equal(f_serial, f_par)  # bit-identical, element by element
    # frozen element 2 (vertices 24..35) gets no force
    assert np.all(f_serial[24:36] == 0.0)


def test_parallel_build_has_its_own_cache_files():
    ser = euler_step.serial._cache._cache_file._index_name
    par = euler_step.parallel._cache._cache_file._index_name
    assert ser != par and "euler_step" in ser and "euler_step__parallel" in par


def test_kernels_keep_the_python_function():
    # tests and tools read the parameter names of the Python function
    assert edge_force.py_func.__name__ == "edge_force"
    assert edge_force.__doc__ == edge_force.py_func.__doc__


def _range(n_vertices: int, threads: int = 0, threshold: int = 1000) -> tuple[int, int]:
    """Simulator.thread_range() of a run with ``n_vertices`` vertices (no simulator needed)."""
    from types import SimpleNamespace

    from repulsionpak.sim.runner import Simulator

    fake = SimpleNamespace(params=SimpleNamespace(threads=threads, parallel_threshold=threshold),
                           model=SimpleNamespace(n_vertices=n_vertices))
    return Simulator.thread_range(fake)


def test_automatic_threads_need_the_parallel_builds_cached_and_enough_vertices(monkeypatch):
    from repulsionpak.sim import runner

    monkeypatch.delenv("REPULSIONPAK_THREADS", raising=False)
    monkeypatch.setattr(numba.config, "NUMBA_NUM_THREADS", 4)
    monkeypatch.setattr(runner, "parallel_ready", lambda: True)
    assert _range(5000) == (1, 4)  # starts on one; the governor may use four
    assert _range(999) == (1, 1)  # below parallel_threshold: handing work over costs more
    assert _range(5000, threads=2) == (2, 2) and _range(10, threads=3) == (3, 3)  # set explicitly
    monkeypatch.setenv("REPULSIONPAK_THREADS", "2")
    assert _range(5000) == (1, 2)
    monkeypatch.setenv("REPULSIONPAK_THREADS", "1")  # packings side by side: one thread each
    assert _range(5000) == (1, 1)
    monkeypatch.setenv("REPULSIONPAK_THREADS", "two")
    with pytest.raises(ParameterError, match="REPULSIONPAK_THREADS"):
        _range(5000)
    monkeypatch.delenv("REPULSIONPAK_THREADS")
    monkeypatch.setattr(runner, "parallel_ready", lambda: False)  # not compiled yet: one thread
    assert _range(5000) == (1, 1)


@pytest.mark.parametrize("env, loaded, ok, spin", [
    ({}, False, True, kernels.GOMP_SPINCOUNT),  # ours to set: idle threads spin
    ({}, True, False, None),  # libgomp read its environment before: it would not take effect
    ({"OMP_WAIT_POLICY": "passive"}, False, False, None),  # the user's choice: no spinning
    ({"OMP_WAIT_POLICY": "ACTIVE"}, False, True, None),
    ({"GOMP_SPINCOUNT": "5000000"}, False, True, "5000000"),
])
def test_threading_is_prepared_for_fast_handovers_unless_the_user_chose(monkeypatch, env, loaded, ok, spin):
    from numba.np.ufunc import parallel

    for k in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT"):
        monkeypatch.setenv(k, "")  # recorded, so that what the test sets is undone after it
        monkeypatch.delenv(k)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    monkeypatch.setattr(kernels, "_handover_ok", None)
    monkeypatch.setattr(parallel, "_is_initialized", False)
    monkeypatch.setattr(kernels, "_gomp_loaded", lambda: loaded)
    kernels._prepare_threading()
    assert kernels._handover_ok is ok
    assert os.environ.get("GOMP_SPINCOUNT") == spin


def test_parallel_cached_wants_every_recorded_kernel(monkeypatch):
    from repulsionpak._jit.signatures import load_signatures

    recorded = {id(d) for d, _ in load_signatures()}
    used = [k for k in kernels.KERNELS if id(k.serial) in recorded]
    assert used
    monkeypatch.setattr(kernels, "is_cached", lambda d: True)
    assert kernels.parallel_cached()
    missing = used[-1].parallel
    monkeypatch.setattr(kernels, "is_cached", lambda d: d is not missing)
    assert kernels.parallel_cached() == bool(missing.signatures)  # compiled in this process counts


#: runs the command, then prints the modules of numba's compiler it imported (see below)
_REPORT_MODULES = ("import atexit, runpy, sys; atexit.register(lambda: print(sorted(m for m in sys.modules "
                   "if m in ('numba.np.arraymath', 'scipy.linalg')))); "
                   "runpy.run_module('repulsionpak.cli', run_name='__main__', alter_sys=True)")


def _pack(tmp: Path, cache: Path, report_modules: bool = False, **env_extra) -> subprocess.CompletedProcess:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT / "src"), **env_extra)
    entry = ["-c", _REPORT_MODULES] if report_modules else ["-m", "repulsionpak.cli"]
    cmd = [sys.executable, *entry, "pack", str(EXAMPLES / "containers" / "circle.svg"),
           str(EXAMPLES / "elements" / "apple.svg"), "-o", str(tmp / "o.svg"), "--seed", "1",
           "--count", "3", "--max-iterations", "60"]
    return subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900)


@pytest.mark.slow
def test_cli_says_once_that_it_compiles_on_a_cold_cache_only(tmp_path):
    """An empty numba cache: the message appears once on stderr (nothing on stdout);
    with the cache filled by that run it does not appear again, and a run then imports
    none of numba's compiler modules."""
    cache = tmp_path / "numba-cache"
    msg = "compiling the simulation kernels, first run only"
    first = _pack(tmp_path, cache)
    assert first.returncode == 0, first.stderr
    assert first.stderr.count(msg) == 1 and msg not in first.stdout
    second = _pack(tmp_path, cache)
    assert second.returncode == 0, second.stderr
    assert msg not in second.stderr
    assert any(cache.rglob("*.nbi"))
    if len(os.sched_getaffinity(0)) > 1:  # a spare core: the two-thread builds compile meanwhile
        assert second.stderr.count("two-thread simulation kernels in the background") == 1
    # a warm run loads its kernels without numba's compiler (repulsionpak._jit.loading), and
    # no kernel calls a numba implementation from numba.np.arraymath (ndarray.sum ...), whose
    # import, with scipy.linalg's, took 0.2 s of every run
    third = _pack(tmp_path, cache, report_modules=True, REPULSIONPAK_NO_WARMUP="1")
    assert third.returncode == 0, third.stderr
    assert third.stdout.strip().splitlines()[-1] == "[]", third.stdout
