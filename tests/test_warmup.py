"""The first run's background warm-up compiles exactly the kernels a packing uses."""

import os
import subprocess
import sys
import textwrap

import pytest

from repulsionpak import examples

# a small packing (simulation, verification, rendering) in a fresh process: prints the
# repulsionpak kernels it had to compile
PACK = textwrap.dedent("""
    import sys
    from numba.core import event
    compiled = []
    class L(event.Listener):
        def on_start(self, ev):
            f = ev.data["dispatcher"].py_func
            compiled.append(f.__module__ + "." + f.__name__)
        def on_end(self, ev):
            pass
    event.register("numba:compile", L())
    from repulsionpak import examples, warmup
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.pack import pack
    from repulsionpak.params import params_from_dict
    cold = warmup.is_cold()
    cont = load_container(examples.container_file(examples.DEFAULT_CONTAINER))
    elems = load_elements(examples.element_files()[:3])
    params = params_from_dict({"gap": examples.DEFAULT_GAP, "seed": 3,
                               "placement": {"count": 6}, "sim": {"max_iterations": 150}})
    p = pack(cont, elems, params)
    assert p.placed
    print("COLD", cold)
    print("COMPILED", sorted({c for c in compiled if c.startswith("repulsionpak.")}))
""")


def _run(args, cache):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    return subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True,
                          check=True).stdout


def _compiled(out: str) -> list[str]:
    line = next(ln for ln in out.splitlines() if ln.startswith("COMPILED"))
    return eval(line.split(" ", 1)[1])  # noqa: S307  (our own printed list)


@pytest.mark.slow
def test_packing_after_warm_up_compiles_no_kernel(tmp_path):
    cache = tmp_path / "cache"
    _run(["-m", "repulsionpak.warmup"], cache)
    out = _run(["-c", PACK], cache)
    assert "COLD False" in out
    assert _compiled(out) == [], out


def test_specialisations_cover_the_simulation_kernels():
    from repulsionpak import warmup
    from repulsionpak.sim import kernels

    calls = warmup.simulation_specialisations()
    names = [d.py_func.__name__ for d, _ in calls]
    assert len(names) == len(set(names))  # one specialisation each
    # every force of Eq. 1 and the integrator, in the order one iteration calls them
    order = ["contact_query", "repulsion_force", "edge_force", "boundary_force", "overlap_force",
             "euler_step", "grow", "skin_areas", "contact_update", "project_inside"]
    assert [n for n in names if n in order] == order
    serial = {k.serial for k in kernels._KERNELS}
    assert sum(d in serial for d, _ in calls) >= 8
    # recording ran the plain Python functions: the real kernels are back in place
    from repulsionpak.sim import forces, runner
    assert runner.contact_query is forces.contact_query
    assert type(runner.grow).__name__ == "CPUDispatcher"


def test_start_does_nothing_when_cached():
    from repulsionpak import warmup

    warmup.warm_up()  # compiles or loads in this process: the cache now holds the kernels
    assert not warmup.is_cold()
    assert warmup.start() is None
    warmup.stop(None)
    warmup.wait()  # nothing running: returns at once


def test_start_can_be_turned_off(monkeypatch):
    from repulsionpak import warmup

    monkeypatch.setattr(warmup, "is_cold", lambda: True)
    monkeypatch.setattr(warmup, "_spare_cores", lambda: 1)
    monkeypatch.setenv("REPULSIONPAK_NO_WARMUP", "1")
    assert warmup.start() is None
