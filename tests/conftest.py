"""Test set-up: the scene suites and studies live in ``benchmarks/`` (they are not part of
the library), so that folder goes on ``sys.path`` for the tests that build their scenes
(``import scenes``, ``import region_scenes``, ``import deformation_study``); the files with
slow tests are collected first."""

import sys
from pathlib import Path

import pytest

_BENCHMARKS = str(Path(__file__).resolve().parents[1] / "benchmarks")
if _BENCHMARKS not in sys.path:
    sys.path.append(_BENCHMARKS)


@pytest.fixture(scope="module")
def one_numba_thread():
    """numba kernels on one thread for a test module (``pytestmark =
    pytest.mark.usefixtures("one_numba_thread")``): the machine is small and shared, and
    numba's OpenMP threads spinning against other processes make tiny kernels ~50x
    slower. Results do not depend on it."""
    import numba

    old = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(old)


def pytest_collection_modifyitems(config, items):
    """The files holding ``slow`` tests first, in their order, then the rest: with one
    worker per core (pytest-xdist, ``--dist loadfile``) the long files then start at once
    beside the short ones instead of running alone at the end."""
    slow = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow)
