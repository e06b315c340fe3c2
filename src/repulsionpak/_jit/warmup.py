"""The first run: compile numba kernels on the spare core, from the far end of the run.

A fresh install compiles every numba kernel the first time it is called: about 11 CPU
seconds for a packing, more than the packing itself takes. The run calls its kernels in a
fixed order (preprocessing, then the simulation kernels in the order one iteration calls
them, then the renderer's curve fitting). On a machine with a spare core :func:`start`
launches the package's warm-up entry (``python -m repulsionpak.warmup``; the CLI starts it
before it reads its inputs), which compiles the same specialisations in **reverse** order
into numba's disk cache: the packing compiles forward from the start (lazily, then
:func:`compile_forward` just before its simulation starts), the warm-up backward from the
end, and each finds in the cache what the other has done (numba looks there before
compiling a new specialisation). Each process claims a kernel before compiling it (an
atomic file creation in a temporary folder the two share), so they meet in the middle
without compiling any kernel twice: the packing waits for the one kernel the warm-up is
still compiling when they meet, the warm-up stops at the packing's first claim. Before
rendering, the packing waits for a warm-up that is still compiling the render kernels
(:func:`wait`), compiling meanwhile the small ones the warm-up has not claimed yet.

**What to compile** is the package's: a :class:`Workload` names the entry module, the
modules whose kernels count, the recording of the simulation's specialisations (used when
the shipped file, :mod:`repulsionpak._jit.signatures`, does not match the kernels) and
the warm-up calls of the kernels compiled after the simulation's (the pocket fill, the
renderer). The package's top-level ``warmup`` module defines it; this layer imports
nothing of the package.

**The parallel builds.** Runs use both cores once the simulation kernels' parallel builds
(:mod:`repulsionpak._jit.kernels`) are cached; they take ~13 CPU seconds to compile, more
than a run lasts. So the warm-up compiles them last, after the render kernels, and a
later run whose parallel builds are still missing starts it for them alone
(``--parallel``) while the run itself goes on one thread: the spare core would idle
anyway. A run that ends stops its warm-up; numba has cached every kernel finished by
then, and the next run's warm-up goes on from there.

Later runs find everything cached and start nothing.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field

from .kernels import KERNELS, cache_is_cold, is_cached, parallel_cached
from .signatures import load_signatures

__all__ = ["Workload", "warm_up", "warm_up_parallel", "parallel_missing", "is_cold", "start", "stop",
           "wait", "running", "compiles_parallel_only", "compile_forward", "specialisations"]


@dataclass(frozen=True)
class Workload:
    """What a warm-up compiles, given by the package (this layer imports none of it).

    Parameters
    ----------
    entry
        The module run as ``python -m entry [--parallel]`` for the warm-up process; it
        calls :func:`warm_up` (or :func:`warm_up_parallel`) with this workload.
    modules
        Modules imported before judging the cache (:func:`is_cold`): their kernels count.
    record
        Records the simulation's specialisations now (``[(dispatcher, argument types),
        ...]`` in the order a run first calls them), for when the shipped file does not
        match the kernels.
    after_simulation
        ``(name, call)`` pairs compiled after the simulation's kernels (the pocket fill).
    render
        ``(name, call)`` pairs compiling the render kernels through the renderer's own
        functions: the largest first; :func:`wait` compiles the others from the other end.
    render_kernels
        Returns the render kernels' dispatchers (whose cache :func:`wait` watches).
    """

    entry: str
    modules: tuple[str, ...] = ()
    record: Callable[[], list] | None = None
    after_simulation: tuple[tuple[str, Callable[[], None]], ...] = ()
    render: tuple[tuple[str, Callable[[], None]], ...] = ()
    render_kernels: Callable[[], list] = field(default=lambda: [])


#: the warm-up process of this run, if one was started (see :func:`wait`)
_current: subprocess.Popen | None = None
#: the workload that process compiles
_workload: Workload | None = None
#: whether that process compiles only the parallel builds (a later run's warm-up)
_parallel_only = False


def is_cold(workload: Workload) -> bool:
    """True when numba's disk cache holds no entry for any render kernel or for any
    simulation kernel (:func:`repulsionpak._jit.kernels.cache_is_cold`): the first run, or
    the sources changed since. False when that cannot be told."""
    try:
        render = not any(is_cached(d) for d in workload.render_kernels())
    except Exception:  # noqa: BLE001  (private numba API: stay silent rather than fail)
        return False
    return render or cache_is_cold(workload.modules)


def specialisations(workload: Workload | None = None) -> list:
    """The shipped specialisations (:func:`~repulsionpak._jit.signatures.load_signatures`),
    or recorded now by ``workload.record`` when the file does not match the kernels."""
    calls = load_signatures()
    if calls is None and workload is not None and workload.record is not None:
        calls = workload.record()
    return calls or []


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
    until that one is in the cache, and stop — the warm-up has done the rest.

    Parameters
    ----------
    serial
        Whether the run uses the serial builds. False (the parallel builds): nothing to do,
        the warm-up compiles the serial ones, but not on the critical path.

    Notes
    -----
    So no kernel is compiled twice, and the packing never compiles one the warm-up is
    compiling. Nothing to do without a warm-up process.
    """
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
            while not is_cached(dispatcher) and proc.poll() is None:
                time.sleep(0.01)
            return
    except Exception:  # noqa: BLE001  (private numba API: the run compiles what it needs)
        return


# -- the warm-up (the process start() launches) ---------------------------------------

def warm_up_parallel(workload: Workload) -> None:
    """Compile (or load) the parallel builds of the simulation kernels
    (:mod:`repulsionpak._jit.kernels`), in the order a run first calls them, for the same
    argument types as the serial ones. Runs use them, on every core, once all are cached."""
    calls = specialisations(workload)  # imports the kernels' modules: they register in KERNELS
    builds = {id(k.serial): k for k in KERNELS}
    for dispatcher, sig in calls:
        k = builds.get(id(dispatcher))
        if k is not None and _claim(_name(dispatcher) + "__parallel"):
            k.parallel.compile(sig)


def warm_up(workload: Workload, simulation: bool = True, render: bool = True,
            parallel: bool = True) -> None:
    """Compile (or load from the cache) the kernels a packing uses: the simulation's in
    reverse order of first use, then ``workload.after_simulation``, the renderer's, then
    the simulation's parallel builds (:func:`warm_up_parallel`; a run that ends first
    stops this process, and the next run's warm-up goes on where it stopped: numba caches
    each kernel as it is compiled)."""
    if simulation:
        for dispatcher, sig in reversed(specialisations(workload)):
            if not _claim(_name(dispatcher)):
                break  # the packing got there first (compile_forward): it has the rest
            dispatcher.compile(sig)  # loads it instead when the cache has it
        for name, call in workload.after_simulation:
            if _claim(name):
                call()
    if render:
        for name, call in workload.render:
            if _claim(name):
                call()
    if parallel:
        warm_up_parallel(workload)


def parallel_missing() -> bool:
    """True when the simulation's parallel builds are not all cached (and this machine has
    a core to spare for them): a warm-up process can compile them while a run goes on."""
    return _spare_cores() >= 1 and not parallel_cached()


def _spare_cores() -> int:
    try:
        return len(os.sched_getaffinity(0)) - 1
    except AttributeError:  # not on Linux
        return (os.cpu_count() or 1) - 1


def start(workload: Workload) -> subprocess.Popen | None:
    """Start the warm-up of ``workload`` in a background process when kernels are not
    cached yet and the machine has a spare core.

    Returns
    -------
    subprocess.Popen or None
        On the first run it compiles everything (``python -m <entry>``); on a later run
        whose parallel builds are still missing only those (``--parallel``), while the run
        itself goes on one thread. None when nothing is started; the environment variable
        ``REPULSIONPAK_NO_WARMUP=1`` turns it off.
    """
    global _current, _claims, _parallel_only, _workload
    if os.environ.get("REPULSIONPAK_NO_WARMUP") or _spare_cores() < 1:
        return None
    if is_cold(workload):
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
        _current = subprocess.Popen([sys.executable, "-m", workload.entry, *mode],
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL, env={**os.environ, _CLAIMS_ENV: claims})
    except OSError:
        if claims is not None:
            shutil.rmtree(claims, ignore_errors=True)
        return None
    _claims = claims
    _workload = workload
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
    than a fresh start).

    Notes
    -----
    While the warm-up still compiles the largest render kernel, this process compiles (or
    loads) the others itself, in the order the renderer calls them, those the warm-up has
    not claimed: it compiles them after the largest in the opposite order, so the two meet
    in the middle again. Returns once the render kernels are cached, not when the warm-up
    ends (it goes on with the parallel builds).
    """
    import time

    proc, workload = _current, _workload
    if proc is None or proc.poll() is not None or workload is None:
        return
    for name, call in reversed(workload.render[1:]):
        if _claim(name):
            call()
    end = time.monotonic() + timeout
    try:
        while proc.poll() is None and time.monotonic() < end:
            if all(is_cached(d) for d in workload.render_kernels()):
                return
            time.sleep(0.01)
    except Exception:  # noqa: BLE001  (private numba API: the renderer compiles what it needs)
        return


def stop(proc: subprocess.Popen | None) -> None:
    """End a background warm-up (numba writes its cache files atomically, so stopping it
    loses nothing)."""
    global _current, _claims, _workload
    if proc is None:
        return
    ours = proc is _current
    if ours:
        _current = None
        _workload = None
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
