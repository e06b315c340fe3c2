"""The threading layer: a run always ends, whatever threading library the machine has.

numba prefers TBB where ``libtbb`` is installed (the test extras install the PyPI ``tbb``
package, so CI has it; its library lands in the environment's ``lib`` folder, which the
children here put on the loader's path, as a conda environment or Debian's ``libtbb12``
would). With TBB, a parallel kernel run on a thread other than the main
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
import numpy as np
import pytest

from repulsionpak._jit import kernels

# a parallel kernel of the simulation, run from a worker thread with two numba threads
_OFF_MAIN_THREAD = textwrap.dedent("""
    import threading
    import numpy as np
    import numba
    from repulsionpak._jit import kernels
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


#: where the PyPI ``tbb`` package puts ``libtbb.so.12``; numba's TBB pool has no run path,
#: so the loader finds it there only when told (a system ``libtbb12`` needs no telling)
_ENV_LIB = os.path.join(sys.prefix, "lib")


def _child_env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_THREADING_LAYER")}
    env["NUMBA_NUM_THREADS"] = "2"
    env["LD_LIBRARY_PATH"] = os.pathsep.join(p for p in (_ENV_LIB, env.get("LD_LIBRARY_PATH")) if p)
    env.update(extra)
    return env


def _one_core():
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})


def _tbb_available() -> bool:
    """Whether numba's TBB layer loads in a child started as the tests here start them."""
    res = subprocess.run([sys.executable, "-c", "from numba.np.ufunc import tbbpool"], env=_child_env(),
                         capture_output=True, text=True, timeout=120)
    return res.returncode == 0


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
    code = ("import os, numba; from repulsionpak._jit import kernels; "
            "print(kernels.choose_threading_layer(), numba.config.THREADING_LAYER_PRIORITY)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env=_child_env(NUMBA_THREADING_LAYER_PRIORITY="workqueue omp tbb"))
    assert res.returncode == 0, res.stderr
    assert res.stdout.split()[0] == "False"
    assert "['workqueue', 'omp', 'tbb']" in res.stdout


# -- the thread governor ----------------------------------------------------------------

from repulsionpak.sim import threadgov  # noqa: E402
from repulsionpak.sim.threadgov import ThreadGovernor  # noqa: E402


def _drive(cost, iterations: int, n: int = 2, start: int = 1, window: int = 32):
    """Run a governor over ``iterations`` fake steps; ``cost(i, threads)`` is the seconds
    step ``i`` takes on that many threads. Returns (total seconds, threads per step)."""
    now = [0.0]
    gov = ThreadGovernor(n, start, window=window, clock=lambda: now[0])
    threads, used = start, []
    for i in range(iterations):
        gov.begin()
        now[0] += cost(i, threads)
        used.append(threads)
        switch = gov.end()
        if switch is not None:
            threads = switch
    return now[0], np.array(used)


def _steps(one: float, many: float, query: float = 5.0, every: int = 32):
    """Step costs: ``one``/``many`` seconds on one/several threads, a full neighbour query
    (``query`` times as long) every ``every`` steps."""
    def cost(i, threads):
        base = one if threads == 1 else many
        return base * (query if i % every == 0 else 1.0)
    return cost


def _single(cost, iterations):
    return sum(cost(i, 1) for i in range(iterations))


def test_governor_keeps_the_faster_thread_count_on_an_idle_machine():
    cost = _steps(one=0.5e-3, many=0.33e-3)  # two threads 1.5x faster
    total, used = _drive(cost, 9000)
    assert (used == 2).mean() > 0.97
    assert total < 0.72 * _single(cost, 9000)


def test_governor_does_not_count_the_first_iteration_on_new_threads():
    # the first iteration on two threads loads their kernels (60 ms, once per run): that is
    # no spike, and the run keeps the threads that are 1.5x faster from the first probe on
    base = _steps(one=0.5e-3, many=0.33e-3)
    first = []

    def cost(i, threads):
        if threads > 1 and not first:
            first.append(i)
            return 60e-3
        return base(i, threads)
    total, used = _drive(cost, 3000)
    assert first and first[0] < 100
    assert (used[first[0]:] == 2).mean() > 0.95
    assert total - 60e-3 < 0.75 * _single(base, 3000)


def test_governor_leaves_threads_that_are_slower_than_one():
    # TBB's idle crawl: 10 ms an iteration on two threads, 0.4 ms on one
    cost = _steps(one=0.4e-3, many=10e-3)
    total, used = _drive(cost, 9000)
    assert (used == 2).sum() < 12  # one slow step per probe
    assert total < 1.25 * _single(cost, 9000)


def test_governor_follows_a_neighbour_that_starts_mid_run():
    # idle for the first 1,500 steps, then a busy neighbour makes two threads 100x slower
    def cost(i, threads):
        base = 0.5e-3 if threads == 1 else (0.33e-3 if i < 1500 else 50e-3)
        return base * (5.0 if i % 32 == 0 else 1.0)
    total, used = _drive(cost, 9000)
    after = used[1500:]
    # the first slow step ends the two-thread run; later probes cost one step each
    assert (after == 2).sum() <= 1 + 9000 // threadgov.PROBE_FIRST
    single_beside_neighbour = _single(cost, 9000)
    assert total < 2.0 * single_beside_neighbour
    assert total < 1.3 * single_beside_neighbour


def test_governor_with_one_thread_never_switches():
    total, used = _drive(_steps(one=1e-3, many=1e-4), 500, n=1, start=1)
    assert (used == 1).all()


@pytest.mark.slow
@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two cores")
def test_switching_threads_mid_run_gives_the_same_packing(monkeypatch):
    """Both builds compute the same numbers: a run whose thread count changes every few
    iterations ends where a one-thread run ends, to the bit."""
    from repulsionpak import examples
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.pack import pack
    from repulsionpak.params import params_from_dict
    from repulsionpak.sim import runner

    cont = load_container(examples.container_file("circle"))
    els = load_elements(examples.element_files()[:3])

    def params(threads):
        return params_from_dict({"gap": 12.0, "seed": 3, "placement": {"count": 6},
                                 "sim": {"max_iterations": 300, "settle_iterations": 20,
                                         "threads": threads}})

    one = pack(cont, els, params(1))

    class Flipping(ThreadGovernor):
        def end(self):
            super().end()
            self.k = getattr(self, "k", 0) + 1
            return 2 if self.k % 14 < 7 else 1

    monkeypatch.setattr(runner, "ThreadGovernor", Flipping)
    monkeypatch.setattr(runner.Simulator, "thread_range", lambda self: (1, 2))
    try:
        flipped = pack(cont, els, params(0))
    finally:
        kernels.set_threads(1)
    np.testing.assert_array_equal(flipped.state.x, one.state.x)
    assert flipped.iterations == one.iterations


def test_governor_keeps_threads_while_the_iterations_grow_costlier():
    # an idle machine, two threads 1.7x faster, and iterations that grow three times as
    # costly over the first 1,500 (the packing fills; the poster's doubled in 1,000): a
    # window of two threads soon takes longer than one thread's first window, which is no
    # reason to leave them
    def cost(i, threads):
        grow = 1.0 + 2.0 * min(i, 1500) / 1500
        return (0.5e-3 if threads == 1 else 0.3e-3) * grow * (5.0 if i % 32 == 0 else 1.0)
    total, used = _drive(cost, 9000)
    assert (used == 2).mean() > 0.97
    assert total < 0.66 * _single(cost, 9000)


def test_governor_probes_again_once_one_thread_grows_costlier():
    # an idle machine where two threads lose on the first, cheap iterations (their fixed
    # cost of handing work over outweighs the split work) and win once the packing has
    # filled: one thread 0.4 -> 1.2 ms over the first 1,500 steps, two 0.3 ms + half of
    # that. The first probe loses; waiting out the doubled probe gap (800 steps) would leave
    # two threads unused until ~870; the probe that one thread's growing mean calls for
    # finds them faster by ~350
    def cost(i, threads):
        grow = 1.0 + 2.0 * min(i, 1500) / 1500
        return 0.4e-3 * grow if threads == 1 else 0.3e-3 + 0.15e-3 * grow
    total, used = _drive(cost, 3000)
    assert (used[40:70] == 2).any()  # the first probe, which loses
    assert (used[70:200] == 1).mean() > 0.7
    assert (used[450:1500] == 2).mean() > 0.95
    assert total < 0.8 * _single(cost, 3000)


def test_governor_backs_off_from_threads_a_neighbour_slows_moderately():
    # idle for 1,500 steps, then a neighbour makes two threads 1.5x slower than one: no
    # step is a spike, so each window of two threads must lose a side-by-side check, and
    # the checks come ever more rarely (400, 800, ... 6,400 steps apart): at most five
    # windows of two threads in the 7,500 steps (168 steps without the back-off)
    def cost(i, threads):
        return 0.5e-3 if threads == 1 else (0.3e-3 if i < 1500 else 0.75e-3)
    total, used = _drive(cost, 9000)
    after = used[1500:]
    assert (after == 2).sum() <= 5 * 32
    assert total < 0.96 * _single(cost, 9000)
