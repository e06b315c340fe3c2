"""The threading layer: a run always ends, whatever threading library the machine has.

numba prefers TBB where ``libtbb`` is installed (the test extras install the PyPI ``tbb``
package, so CI has it). With TBB, a parallel kernel run on a thread other than the main
one while TBB sees a single core makes the interpreter hang at exit in ``tbb::finalize``
(numba issue #10556). These tests run that situation in a child process pinned to one
core and require it to exit.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numba
import pytest

from repulsionpak.sim import kernels

# a parallel kernel of the simulation, run from a worker thread with two numba threads
_OFF_MAIN_THREAD = textwrap.dedent("""
    import threading
    import numpy as np
    import numba
    from repulsionpak.sim import kernels
    from repulsionpak.sim.integrate import euler_step

    def work():
        kernels.set_threads(2)
        n = 64
        x = np.zeros((n, 2)); v = np.zeros((n, 2)); F = np.ones((n, 2))
        euler_step(x, v, F, np.arange(n, dtype=np.int64), 0.1, np.full(1, 10.0),
                   np.zeros(n, np.int64))
        assert abs(x[0, 0] - 0.01) < 1e-12, x[0]
        print("layer", numba.threading_layer(), flush=True)

    t = threading.Thread(target=work)
    t.start()
    t.join()
    print("done", flush=True)
""")


def _child_env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_THREADING_LAYER")}
    env["NUMBA_NUM_THREADS"] = "2"
    env.update(extra)
    return env


def _one_core():
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})


def _tbb_available() -> bool:
    try:
        from numba.np.ufunc import tbbpool  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="needs Linux CPU affinity")
def test_parallel_kernel_off_the_main_thread_lets_the_process_exit():
    # 120 s: the child may compile the kernel's parallel build (a few seconds) first
    try:
        res = subprocess.run([sys.executable, "-c", _OFF_MAIN_THREAD], env=_child_env(),
                             preexec_fn=_one_core, capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"the process did not exit (threading layer hang at exit): {exc.stdout!r}")
    assert res.returncode == 0, res.stderr
    assert "done" in res.stdout
    layer = res.stdout.split("layer", 1)[1].split()[0]
    assert layer in ("omp", "workqueue"), f"numba chose the {layer} threading layer"


def test_tbb_is_present_where_the_test_extras_are_installed():
    """The hang above needs TBB to show: the test extras install it (on Linux x86-64)."""
    if sys.platform != "linux" or os.uname().machine != "x86_64":
        pytest.skip("the PyPI tbb package is installed on Linux x86-64 only")
    assert _tbb_available()


def test_layer_order_leaves_tbb_last_unless_the_user_chose():
    assert list(numba.config.THREADING_LAYER_PRIORITY)[-1] == "tbb"
    assert os.environ.get("NUMBA_THREADING_LAYER_PRIORITY", "").split() == list(kernels.LAYER_PRIORITY) \
        or "NUMBA_THREADING_LAYER" in os.environ


def test_the_users_choice_of_layer_is_kept():
    code = ("import os, numba; from repulsionpak.sim import kernels; "
            "print(kernels.choose_threading_layer(), numba.config.THREADING_LAYER_PRIORITY)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env=_child_env(NUMBA_THREADING_LAYER_PRIORITY="workqueue omp tbb"))
    assert res.returncode == 0, res.stderr
    assert res.stdout.split()[0] == "False"
    assert "['workqueue', 'omp', 'tbb']" in res.stdout
