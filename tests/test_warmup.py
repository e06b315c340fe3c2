"""The first run's background warm-up compiles exactly the render kernels a packing uses."""

import os
import subprocess
import sys
import textwrap

import pytest

from repulsionpak import examples

RENDER = textwrap.dedent("""
    import sys
    import numpy as np
    from numba.core import event
    compiled = []
    class L(event.Listener):
        def on_start(self, ev):
            compiled.append(ev.data["dispatcher"].py_func.__module__)
        def on_end(self, ev):
            pass
    event.register("numba:compile", L())
    from repulsionpak.preprocess import outline_of
    from repulsionpak.io import load_elements
    from repulsionpak.preprocess import build_template
    from repulsionpak.render.placed import render_copy
    from repulsionpak.render import warmup
    cold = warmup.is_cold()
    t = build_template(outline_of(load_elements([sys.argv[1]])[0]), 1.0, 2.0)
    shear = np.array([[1.0, 0.3], [0.0, 1.1]])
    paths, tol = render_copy(t, t.verts @ shear.T, gap=2.0)
    assert paths and tol > 0
    print("COLD", cold)
    print("RENDER", sorted({m for m in compiled if m.startswith("repulsionpak.render")}))
""")


def _run(code_or_module, cache, *args, module=False):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    cmd = [sys.executable, "-m", code_or_module] if module else [sys.executable, "-c", code_or_module]
    return subprocess.run([*cmd, *args], env=env, capture_output=True, text=True, check=True).stdout


@pytest.mark.slow
def test_render_after_warm_up_compiles_no_render_kernel(tmp_path):
    element = str(examples.element_files()[0])
    cold_cache = tmp_path / "cold"
    out = _run(RENDER, cold_cache, element)  # without a warm-up, rendering compiles them
    assert "COLD True" in out
    assert "repulsionpak.render.fit" in out and "repulsionpak.render.deform" in out
    warm_cache = tmp_path / "warm"
    _run("repulsionpak.render.warmup", warm_cache, module=True)
    out = _run(RENDER, warm_cache, element)
    assert "COLD False" in out
    assert "RENDER []" in out, out


def test_start_does_nothing_when_cached():
    from repulsionpak.render import warmup

    warmup.warm_up()  # compiles or loads in this process: the cache now holds the kernels
    assert not warmup.is_cold()
    assert warmup.start() is None
    warmup.stop(None)
