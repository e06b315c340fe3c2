"""The package's warm-up workload: what a first run compiles, for :mod:`repulsionpak._jit.warmup`.

``python -m repulsionpak.warmup`` is the warm-up process a first run starts
(:func:`repulsionpak._jit.warmup.start` with :data:`WORKLOAD`): it compiles the
simulation's specialisations in reverse order of first use, the pocket fill's fitting
kernel and the dents' bump map, the render kernels, then the simulation's parallel
builds (``--parallel``: only those). ``--write-signatures`` records the simulation's
specialisations into ``warmup_signatures.json`` (:mod:`repulsionpak._jit.signatures`).

Which specialisations? The simulation's are recorded by running a few iterations of a
tiny packing with every simulation kernel replaced by its plain Python function (the
argument types are those of the real run: same code, same arrays); the renderer's by
calling its public wrappers on a tiny input; the pocket fill's fitting kernel
(:func:`_warm_misfit`) is compiled between the two.

Notes
-----
This module needs the whole library (the recording packs a tiny scene), so it sits at the
top beside the CLI and hands :data:`WORKLOAD` to the ``_jit`` layer, which imports
nothing of the package. ``tests/test_warmup.py`` fails when the signature file is stale
(it records again and compares) and checks that a packing after a warm-up compiles no
simulation or render kernel.
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from ._jit import warmup as jit
from ._jit.kernels import KERNELS
from ._jit.signatures import SIGNATURES, write_signatures as _write

__all__ = ["WORKLOAD", "simulation_specialisations", "write_signatures"]


def _render_dispatchers() -> list:
    from .geometry import curves
    from .render import deform, fit

    return [deform._solve, fit._fit_chain, curves._flatten, curves._path_bytes]


# -- the simulation's specialisations ---------------------------------------------------

class _Recorder:
    """Stands in for a kernel: notes the argument types of its first top-level call and
    runs its plain Python function instead (nested kernel calls just run)."""

    depth = 0

    def __init__(self, target, calls: list):
        self.target = target
        self.dispatcher = getattr(target, "serial", target)  # a _jit.kernels.Kernel or a dispatcher
        self.calls = calls

    def __call__(self, *args):
        if _Recorder.depth == 0:
            sig = tuple(self.dispatcher.typeof_pyval(a) for a in args)
            if (self.dispatcher, sig) not in self.calls:
                self.calls.append((self.dispatcher, sig))
        _Recorder.depth += 1
        try:
            return self.target.py_func(*args)
        finally:
            _Recorder.depth -= 1


def _tiny_simulator():
    """A Simulator of two small elements in an L-shaped container (a reflex corner, so
    the corner kernels run too), built the way :func:`repulsionpak.pack.pack` builds one;
    both elements count as elongated, so the alignment kernel runs too."""
    import shapely

    from . import examples
    from .io import load_elements
    from .pack import prepare, primary_model
    from .params import Params
    from .sim.runner import Simulator
    from .types import Container

    region = shapely.Polygon([(0, 0), (100, 0), (100, 50), (50, 50), (50, 100), (0, 100)])
    params = Params(gap=2.0, seed=0)
    params = dataclasses.replace(
        params, placement=dataclasses.replace(params.placement, count=2),
        sim=dataclasses.replace(params.sim, max_iterations=2, min_iterations=0, stop_window=2,
                                settle_iterations=2, threads=1)).validate()
    rng = np.random.default_rng(0)
    elements = load_elements([examples.element_files()[0]])
    templates, placement, gap = prepare(Container("warm-up", region), elements, params, rng)
    model, state, _ = primary_model(region, templates, placement, gap, params)
    model.align_weight[:] = 1.0  # every element turns, whatever the example's shape (sim/alignment.py)
    return Simulator(model, state, params.sim)



def simulation_specialisations() -> list:
    """``[(dispatcher, argument types), ...]`` of the preprocessing and simulation kernels
    in the order a run first calls them, recorded on a tiny packing run in plain Python."""
    import importlib
    import pkgutil

    from . import geometry, sim

    for pkg in (geometry, sim):
        for info in pkgutil.iter_modules(pkg.__path__):
            importlib.import_module(f"{pkg.__name__}.{info.name}")
    modules = [m for name, m in list(sys.modules.items()) if m is not None
               and name.startswith(("repulsionpak.sim.", "repulsionpak.geometry."))]
    targets = {id(k) for k in KERNELS}
    calls: list = []
    patched = []
    for mod in modules:
        for name, obj in list(vars(mod).items()):
            if id(obj) in targets or type(obj).__name__ == "CPUDispatcher":
                patched.append((mod, name, obj))
                setattr(mod, name, _Recorder(obj, calls))
    try:
        _tiny_simulator().run(on_snapshot=lambda s: None, every=1)
    finally:
        for mod, name, obj in patched:
            setattr(mod, name, obj)
    return calls


def write_signatures(path=SIGNATURES) -> list[dict]:
    """Record the specialisations (the tiny packing run) and write them to ``path``."""
    return _write(simulation_specialisations(), path)


# -- the render kernels, compiled through the renderer's own functions ------------------

def _warm_tps() -> None:
    from .render.deform import tps_factors

    q, g, _ = _arc()
    tps_factors(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]), q, g)


def _warm_fit() -> None:
    from .render.fit import fit_subpath

    q, g, th = _arc()
    fit_subpath(np.array([3, 1]), np.array([0, 5, 9]), False, q, g, th, 1e-6)


def _warm_flatten() -> None:
    from .geometry.curves import flatten_subpath
    from .types import CurveSubpath

    sub = CurveSubpath(np.array([1, 3], np.int8),
                       np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0]],
                                 [[1.0, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 1.0]]]), False)
    flatten_subpath(sub, 1e-3)


def _warm_path_data() -> None:
    from .geometry.curves import path_data
    from .types import CurveSubpath

    path_data([CurveSubpath(np.array([1, 3], np.int8),
                            np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0]],
                                      [[1.0, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 1.0]]]), True)])


def _warm_misfit() -> None:
    """The fitting kernels of the pocket fill and the size plan
    (:func:`repulsionpak.geometry.pockets.best_fit`, :func:`~repulsionpak.geometry.pockets.fit_scales`),
    between the two simulations."""
    from .geometry.pockets import Pockets, best_fit, fit_scales

    none = np.zeros(0, np.int64)
    pockets = Pockets(np.ones((4, 4)), 0.0, 0.0, 1.0, np.zeros(0), none, none)
    args = (pockets, np.array([2.0, 2.0]), np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.0]), 0.5, 1.0,
            np.array([1.0, 2.0]))
    best_fit(*args)
    fit_scales(*args)


def _warm_dents() -> None:
    """The dents' bump map and its Jacobian (:mod:`repulsionpak.verify.dents`), which the
    verification calls between the simulations and the renderer."""
    from .verify.dents import _bumped, _bumped_with_jacobians

    bumps = [(np.zeros(2), np.array([0.1, 0.0]))]
    pts = np.array([[0.0, 0.0], [1.0, 0.0]])
    _bumped(pts, bumps, 2.0)
    _bumped_with_jacobians(pts, bumps, 2.0)


def _arc():
    th = np.linspace(0.0, 0.5 * np.pi, 9)
    return np.column_stack([np.cos(th), np.sin(th)]), np.column_stack([-np.sin(th), np.cos(th)]), th


#: what the warm-up process compiles (see the module docstring)
WORKLOAD = jit.Workload(
    entry="repulsionpak.warmup",
    modules=("repulsionpak.sim.runner",),  # imports, and so registers, every kernel a run calls
    record=simulation_specialisations,
    after_simulation=(("_warm_misfit", _warm_misfit), ("_warm_dents", _warm_dents)),
    # the curve fitter first (the largest, ~70% of the render kernels' compilation), then
    # the small ones in reverse order of use (jit.wait compiles them from the other end)
    render=(("_warm_fit", _warm_fit), ("_warm_path_data", _warm_path_data), ("_warm_flatten", _warm_flatten),
            ("_warm_tps", _warm_tps)),
    render_kernels=_render_dispatchers,
)


if __name__ == "__main__":
    if sys.argv[1:] == ["--write-signatures"]:
        print(f"{len(write_signatures())} specialisations written to {SIGNATURES}")
    elif sys.argv[1:] == ["--parallel"]:
        jit.warm_up_parallel(WORKLOAD)
    else:
        jit.warm_up(WORKLOAD)
