"""Compile the render kernels in a second process while the first run simulates.

The first run of a fresh install compiles every numba kernel it calls. The render kernels
(curve fitting, flattening, the thin-plate-spline solve: about 4.5 of the 11 CPU seconds
of compilation) are only needed once the simulation has ended, so on a machine with a
spare core :func:`start` compiles them in a background process meanwhile, into the same
disk cache; the packing then loads them from there. Later runs find them cached and
start nothing.

:func:`warm_up` calls the same public wrappers the renderer calls (they fix every
argument's dtype and layout), on a tiny input, so it compiles exactly the specialisations
a packing uses; ``tests/test_warmup.py`` checks that rendering after it compiles nothing.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

__all__ = ["warm_up", "is_cold", "start", "stop"]


def _dispatchers() -> list:
    from . import curves, deform, fit

    return [fit._fit_chain, curves._flatten, deform._solve]


def is_cold() -> bool:
    """True when numba's disk cache holds no entry for any render kernel (the first run,
    or the sources changed since). False when that cannot be told."""
    try:
        return not any(d._cache._cache_file._load_index() for d in _dispatchers())
    except Exception:  # noqa: BLE001  (private numba API: stay silent rather than fail)
        return False


def warm_up() -> None:
    """Compile (or load from the cache) the render kernels on a tiny input."""
    from ..types import CurveSubpath
    from .curves import flatten_subpath
    from .deform import tps_factors
    from .fit import fit_subpath

    th = np.linspace(0.0, 0.5 * np.pi, 9)
    q = np.column_stack([np.cos(th), np.sin(th)])
    g = np.column_stack([-np.sin(th), np.cos(th)])
    fit_subpath(np.array([3, 1]), np.array([0, 5, 9]), False, q, g, th, 1e-6)
    sub = CurveSubpath(np.array([1, 3], np.int8),
                       np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 0.0]],
                                 [[1.0, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 1.0]]]), False)
    flatten_subpath(sub, 1e-3)
    rest = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    tps_factors(rest, q, g)


def _spare_cores() -> int:
    try:
        return len(os.sched_getaffinity(0)) - 1
    except AttributeError:  # not on Linux
        return (os.cpu_count() or 1) - 1


def start() -> subprocess.Popen | None:
    """Start :func:`warm_up` in a background process when the render kernels are not
    cached yet and the machine has a spare core; returns the process (or None)."""
    if _spare_cores() < 1 or not is_cold():
        return None
    try:
        return subprocess.Popen([sys.executable, "-m", "repulsionpak.render.warmup"],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:
        return None


def stop(proc: subprocess.Popen | None) -> None:
    """End a background warm-up: it has finished by then on a machine with a free core;
    if not, the packing compiled the kernels itself and the warm-up is only in the way
    (numba writes its cache files atomically, so stopping it loses nothing)."""
    if proc is None:
        return
    if proc.poll() is None:
        proc.terminate()
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


if __name__ == "__main__":
    warm_up()
