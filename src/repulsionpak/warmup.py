"""The first run: compile numba kernels on the spare core, from the far end of the run.

A fresh install compiles every numba kernel the first time it is called: about 11 CPU
seconds for a packing, more than the packing itself takes. The run calls its kernels in a
fixed order (preprocessing, then the simulation kernels in the order one iteration calls
them, then the renderer's curve fitting). On a machine with a spare core :func:`start`
launches ``python -m repulsionpak.warmup`` (the CLI does so before it reads its inputs),
which compiles the same specialisations in **reverse** order into numba's disk cache: the
packing compiles forward from the start (lazily, then :func:`compile_forward` just
before its simulation starts), the warm-up backward from the end, and each finds in the
cache what the other has done (numba looks there before compiling a new specialisation).
Each process claims a kernel before compiling it (an atomic file creation in a temporary
folder the two share), so they meet in the middle without compiling any kernel twice:
the packing waits for the one kernel the warm-up is still compiling when they meet, the
warm-up stops at the packing's first claim. Before rendering, the packing waits for a
warm-up that is still compiling the render kernels (:func:`wait`), compiling meanwhile the
small ones the warm-up has not claimed yet.

Which specialisations? The simulation's are recorded by running a few iterations of a
tiny packing with every simulation kernel replaced by its plain Python function (the
argument types are those of the real run: same code, same arrays); the renderer's by
calling its public wrappers on a tiny input; the pocket fill's fitting kernel
(:func:`_warm_misfit`) is compiled between the two. The recording (imports and the tiny run:
~2 s before anything compiles) is done once, at development time, into
``warmup_signatures.json`` beside this module (``python -m repulsionpak.warmup
--write-signatures``); the warm-up reads that file and starts compiling at once. It falls
back to the recording run when the file does not match the kernels (a kernel missing or
its parameters renamed); ``tests/test_warmup.py`` fails when the file is stale (it
records again and compares) and checks that a packing after a warm-up compiles no
simulation or render kernel.

**The parallel builds.** Runs use both cores once the simulation kernels' parallel builds
(:mod:`repulsionpak.sim.kernels`) are cached; they take ~13 CPU seconds to compile, more
than a run lasts. So the warm-up compiles them last, after the render kernels, and a
later run whose parallel builds are still missing starts it for them alone
(``--parallel``) while the run itself goes on one thread: the spare core would idle
anyway. A run that ends stops its warm-up; numba has cached every kernel finished by
then, and the next run's warm-up goes on from there (on the heart scene, the second to
fourth runs compile them; the fifth uses both cores).

Later runs find everything cached and start nothing.
"""

from __future__ import annotations

import dataclasses
import importlib
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from .sim.kernels import _cached  # whether numba's disk cache holds a dispatcher's code

__all__ = ["warm_up", "warm_up_parallel", "parallel_missing", "is_cold", "start", "stop", "wait",
           "running", "compiles_parallel_only", "compile_forward",
           "simulation_specialisations",
           "specialisations", "load_signatures", "write_signatures", "SIGNATURES"]

#: the simulation's specialisations, recorded at development time (see the module docstring)
SIGNATURES = Path(__file__).with_name("warmup_signatures.json")

#: the warm-up process of this run, if one was started (see :func:`wait`)
_current: subprocess.Popen | None = None
#: whether that process compiles only the parallel builds (a later run's warm-up)
_parallel_only = False


def _render_dispatchers() -> list:
    from .render import curves, deform, fit

    return [deform._solve, fit._fit_chain, curves._flatten]


def is_cold() -> bool:
    """True when numba's disk cache holds no entry for any render kernel or for any
    simulation kernel (:func:`repulsionpak.sim.kernels.cache_is_cold`): the first run, or
    the sources changed since. False when that cannot be told."""
    from .sim.kernels import cache_is_cold

    try:
        render = not any(_cached(d) for d in _render_dispatchers())
    except Exception:  # noqa: BLE001  (private numba API: stay silent rather than fail)
        return False
    return render or cache_is_cold()


# -- the simulation's specialisations ---------------------------------------------------

class _Recorder:
    """Stands in for a kernel: notes the argument types of its first top-level call and
    runs its plain Python function instead (nested kernel calls just run)."""

    depth = 0

    def __init__(self, target, calls: list):
        self.target = target
        self.dispatcher = getattr(target, "serial", target)  # a sim.kernels.Kernel or a dispatcher
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
    the corner kernels run too), built the way :func:`repulsionpak.pack.pack` builds one."""
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
    return Simulator(model, state, params.sim)


def simulation_specialisations() -> list:
    """``[(dispatcher, argument types), ...]`` of the preprocessing and simulation kernels
    in the order a run first calls them, recorded on a tiny packing run in plain Python."""
    import importlib
    import pkgutil

    from . import geometry, sim
    from .sim import kernels

    for pkg in (geometry, sim):
        for info in pkgutil.iter_modules(pkg.__path__):
            importlib.import_module(f"{pkg.__name__}.{info.name}")
    modules = [m for name, m in list(sys.modules.items()) if m is not None
               and name.startswith(("repulsionpak.sim.", "repulsionpak.geometry."))]
    targets = {id(k) for k in kernels._KERNELS}
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


# -- the recorded specialisations, shipped as a data file ------------------------------

def _params(dispatcher) -> list[str]:
    code = dispatcher.py_func.__code__
    return list(code.co_varnames[:code.co_argcount])


_ARRAY = re.compile(r"array\((\w+), (\d)d, ([CFA])\)")


def _parse_type(text: str):
    """A numba type from its ``str``: ``array(float64, 2d, C)``, ``int64``, ``float64``,
    ``bool``; ValueError for anything else (the file is then not used)."""
    from numba.core import types

    m = _ARRAY.fullmatch(text)
    if m:
        return types.Array(_parse_type(m[1]), int(m[2]), m[3])
    if text == "bool":
        return types.boolean
    t = getattr(types, text, None)
    if not isinstance(t, (types.Integer, types.Float)):
        raise ValueError(f"unsupported argument type {text!r}")
    return t


def _encode(calls: list) -> list[dict]:
    out = []
    for dispatcher, sig in calls:
        f = dispatcher.py_func
        args = [str(t) for t in sig]
        if [_parse_type(a) for a in args] != list(sig):
            raise ValueError(f"{f.__qualname__}: argument types {args} do not read back")
        out.append({"kernel": f"{f.__module__}.{f.__qualname__}", "params": _params(dispatcher),
                    "args": args})
    return out


def write_signatures(path: Path = SIGNATURES) -> list[dict]:
    """Record the specialisations (the tiny packing run) and write them to ``path``."""
    entries = _encode(simulation_specialisations())
    about = ("argument types of the kernels a packing calls, in the order of first use; "
             "regenerate: python -m repulsionpak.warmup --write-signatures")
    lines = ",\n  ".join(json.dumps(e) for e in entries)  # one kernel a line
    Path(path).write_text(f'{{"about": {json.dumps(about)},\n "kernels": [\n  {lines}\n ]}}\n',
                          encoding="utf-8")
    return entries


def load_signatures(path: Path = SIGNATURES) -> list | None:
    """The specialisations recorded in ``path`` as ``[(dispatcher, argument types), ...]``;
    None when the file is missing or does not match the kernels (a kernel gone, its
    parameters changed, a type it cannot read)."""
    try:
        entries = json.loads(Path(path).read_text(encoding="utf-8"))["kernels"]
        calls = []
        for e in entries:
            module, name = e["kernel"].rsplit(".", 1)
            target = getattr(importlib.import_module(module), name)
            dispatcher = getattr(target, "serial", target)  # a sim.kernels.Kernel or a dispatcher
            if type(dispatcher).__name__ != "CPUDispatcher" or _params(dispatcher) != e["params"]:
                return None
            calls.append((dispatcher, tuple(_parse_type(a) for a in e["args"])))
        return calls
    except Exception:  # noqa: BLE001  (any mismatch: record instead)
        return None


def specialisations() -> list:
    """The shipped specialisations (:func:`load_signatures`), or recorded now when the file
    does not match the kernels (:func:`simulation_specialisations`)."""
    calls = load_signatures()
    return calls if calls is not None else simulation_specialisations()


# -- who compiles what: one claim file per kernel --------------------------------------

_CLAIMS_ENV = "REPULSIONPAK_WARMUP_CLAIMS"
#: this process's claim folder (shared with the warm-up process), while one runs
_claims: str | None = os.environ.get(_CLAIMS_ENV)


def _claim(name: str) -> bool:
    """Claim the compilation of kernel ``name`` for this process: True when no process
    claimed it before (an atomic file creation). Always True without a claim folder."""
    if _claims is None:
        return True
    try:
        os.close(os.open(os.path.join(_claims, name), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        return True
    except FileExistsError:
        return False
    except OSError:
        return True


def _name(dispatcher) -> str:
    f = dispatcher.py_func
    return f"{f.__module__}.{f.__qualname__}"


def compile_forward(serial: bool = True) -> None:
    """While a warm-up process runs (:func:`start`), compile the kernels a packing calls in
    the order it calls them (those not compiled in this process yet), each one only after
    claiming it, until reaching one the warm-up claimed (it works from the other end): wait
    until that one is in the cache, and stop — the warm-up has done the rest. So no kernel
    is compiled twice, and the packing never compiles one the warm-up is compiling. Nothing
    to do without a warm-up process, or when the run uses the parallel builds (``serial``
    False: the warm-up compiles the serial ones, as before, but not on the critical path)."""
    import time

    proc = _current
    if not serial or proc is None or proc.poll() is not None or _claims is None:
        return
    calls = load_signatures()
    if calls is None:  # the shipped file does not match: compile lazily, as without a warm-up
        return
    try:
        for dispatcher, sig in calls:
            if sig in dispatcher.overloads:
                continue  # compiled (or loaded) in this process already
            if _claim(_name(dispatcher)):
                dispatcher.compile(sig)  # or loads it, if the cache has it
                continue
            while not _cached(dispatcher) and proc.poll() is None:
                time.sleep(0.01)
            return
    except Exception:  # noqa: BLE001  (private numba API: the run compiles what it needs)
        return


# -- the warm-up ---------------------------------------------------------------------

def _warm_tps() -> None:
    from .render.deform import tps_factors

    q, g, _ = _arc()
    tps_factors(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]), q, g)


def _warm_fit() -> None:
    from .render.fit import fit_subpath

    q, g, th = _arc()
    fit_subpath(np.array([3, 1]), np.array([0, 5, 9]), False, q, g, th, 1e-6)


def _warm_flatten() -> None:
    from .render.curves import flatten_subpath
    from .types import CurveSubpath

    sub = CurveSubpath(np.array([1, 3], np.int8),
                       np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0]],
                                 [[1.0, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 1.0]]]), False)
    flatten_subpath(sub, 1e-3)


def _warm_misfit() -> None:
    """The pocket fill's fitting kernel (:func:`repulsionpak.secondary.fit_scales`), between
    the two simulations."""
    from .secondary import Pockets, fit_scales

    none = np.zeros(0, np.int64)
    pockets = Pockets(np.ones((4, 4)), 0.0, 0.0, 1.0, np.zeros(0), none, none)
    fit_scales(pockets, np.array([2.0, 2.0]), np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.0]), 0.5, 1.0,
               np.array([1.0, 2.0]))


def _arc():
    th = np.linspace(0.0, 0.5 * np.pi, 9)
    return np.column_stack([np.cos(th), np.sin(th)]), np.column_stack([-np.sin(th), np.cos(th)]), th


def _warm_render() -> None:
    """Compile (or load) the render kernels through the renderer's own wrappers: the curve
    fitter first (the largest, ~70% of the render kernels' compilation), then the two small
    ones in reverse order of use (:func:`wait` compiles them from the other end)."""
    for name in ("_warm_fit", "_warm_flatten", "_warm_tps"):
        if _claim(name):
            globals()[name]()


def warm_up_parallel() -> None:
    """Compile (or load) the parallel builds of the simulation kernels
    (:mod:`repulsionpak.sim.kernels`), in the order a run first calls them, for the same
    argument types as the serial ones. Runs use them, on every core, once all are cached."""
    from .sim import kernels

    builds = {id(k.serial): k for k in kernels._KERNELS}
    for dispatcher, sig in specialisations():
        k = builds.get(id(dispatcher))
        if k is not None and _claim(_name(dispatcher) + "__parallel"):
            k.parallel.compile(sig)


def warm_up(simulation: bool = True, render: bool = True, parallel: bool = True) -> None:
    """Compile (or load from the cache) the kernels a packing uses: the simulation's in
    reverse order of first use, then the renderer's, then the simulation's parallel builds
    (:func:`warm_up_parallel`; a run that ends first stops this process, and the next run's
    warm-up goes on where it stopped: numba caches each kernel as it is compiled)."""
    if simulation:
        for dispatcher, sig in reversed(specialisations()):
            if not _claim(_name(dispatcher)):
                break  # the packing got there first (compile_forward): it has the rest
            dispatcher.compile(sig)  # loads it instead when the cache has it
        if _claim("_warm_misfit"):
            _warm_misfit()
    if render:
        _warm_render()
    if parallel:
        warm_up_parallel()


def parallel_missing() -> bool:
    """True when the simulation's parallel builds are not all cached (and this machine has
    a core to spare for them): a warm-up process can compile them while a run goes on."""
    from .sim.kernels import parallel_cached

    return _spare_cores() >= 1 and not parallel_cached()


def _spare_cores() -> int:
    try:
        return len(os.sched_getaffinity(0)) - 1
    except AttributeError:  # not on Linux
        return (os.cpu_count() or 1) - 1


def start() -> subprocess.Popen | None:
    """Start :func:`warm_up` in a background process when kernels are not cached yet and
    the machine has a spare core; returns the process (or None). On the first run it
    compiles everything (``python -m repulsionpak.warmup``); on a later run whose parallel
    builds are still missing only those (``--parallel``), while the run itself goes on one
    thread. The environment variable ``REPULSIONPAK_NO_WARMUP=1`` turns it off."""
    global _current, _claims, _parallel_only
    if os.environ.get("REPULSIONPAK_NO_WARMUP") or _spare_cores() < 1:
        return None
    if is_cold():
        mode = []
    elif parallel_missing():
        mode = ["--parallel"]
    else:
        return None
    import shutil
    import tempfile

    claims = None
    try:
        claims = tempfile.mkdtemp(prefix="repulsionpak-warmup-")  # see compile_forward
        _current = subprocess.Popen([sys.executable, "-m", "repulsionpak.warmup", *mode],
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL, env={**os.environ, _CLAIMS_ENV: claims})
    except OSError:
        if claims is not None:
            shutil.rmtree(claims, ignore_errors=True)
        return None
    _claims = claims
    _parallel_only = bool(mode)
    return _current


def compiles_parallel_only() -> bool:
    """True while this run's warm-up process compiles only the parallel builds."""
    return _current is not None and _parallel_only


def running() -> subprocess.Popen | None:
    """The warm-up process :func:`start` started (None when none was)."""
    return _current


def wait(timeout: float = 60.0) -> None:
    """Let a running warm-up finish the render kernels (the renderer calls this before its
    first kernel: the warm-up compiles them after the simulation's and is further along
    than a fresh start). While it still compiles the curve fitter, this process compiles
    (or loads) the two small render kernels itself, in the order the renderer calls them,
    those the warm-up has not claimed: it compiles them after the fitter in the opposite
    order, so the two meet in the middle again. Returns once the render kernels are
    cached, not when the warm-up ends (it goes on with the parallel builds)."""
    import time

    proc = _current
    if proc is None or proc.poll() is not None:
        return
    for name in ("_warm_tps", "_warm_flatten"):
        if _claim(name):
            globals()[name]()
    end = time.monotonic() + timeout
    try:
        while proc.poll() is None and time.monotonic() < end:
            if all(_cached(d) for d in _render_dispatchers()):
                return
            time.sleep(0.01)
    except Exception:  # noqa: BLE001  (private numba API: the renderer compiles what it needs)
        return


def stop(proc: subprocess.Popen | None) -> None:
    """End a background warm-up (numba writes its cache files atomically, so stopping it
    loses nothing)."""
    global _current, _claims
    if proc is None:
        return
    ours = proc is _current
    if ours:
        _current = None
    if proc.poll() is None:
        proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    if ours and _claims is not None:
        import shutil

        shutil.rmtree(_claims, ignore_errors=True)
        _claims = None


if __name__ == "__main__":
    if sys.argv[1:] == ["--write-signatures"]:
        print(f"{len(write_signatures())} specialisations written to {SIGNATURES}")
    elif sys.argv[1:] == ["--parallel"]:
        warm_up_parallel()
    else:
        warm_up()
