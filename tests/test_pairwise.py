"""Distances of many pairs on several threads (:mod:`repulsionpak.geometry.pairwise`)."""

import numpy as np
import pytest
import shapely

from repulsionpak.geometry import pairwise
from repulsionpak.geometry.pairwise import MIN_PAIRS, distances


def _blobs(rng, n):
    t = np.linspace(0.0, 2.0 * np.pi, 60, endpoint=False)
    out = []
    for _ in range(n):
        r = 5.0 + rng.random(60)
        cx, cy = rng.uniform(0.0, 300.0, 2)
        out.append(shapely.Polygon(np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])))
    return np.array(out, dtype=object)


@pytest.mark.parametrize("n", [0, 1, MIN_PAIRS * 2 - 1, MIN_PAIRS * 2, MIN_PAIRS * 5 + 3])
@pytest.mark.parametrize("workers", [1, 2, 3])
def test_distances_are_shapelys_to_the_bit(n, workers):
    rng = np.random.default_rng(n + workers)
    a, b = _blobs(rng, n), _blobs(rng, n)
    if n > 3:  # overlapping, identical and empty pairs too
        b[0], b[1], a[2] = a[0], shapely.buffer(a[1], 2.0), shapely.Polygon()
    got = distances(a, b, workers=workers)
    want = shapely.distance(a, b)
    assert got.shape == (n,)
    assert np.array_equal(got, want, equal_nan=True)


def test_distances_share_out_only_long_lists(monkeypatch):
    """Fewer than MIN_PAIRS pairs per thread: one shapely call on this thread."""
    calls = []
    real = shapely.distance
    monkeypatch.setattr(pairwise.shapely, "distance", lambda a, b: calls.append(len(a)) or real(a, b))
    rng = np.random.default_rng(0)
    a, b = _blobs(rng, MIN_PAIRS + 10), _blobs(rng, MIN_PAIRS + 10)
    distances(a, b, workers=4)
    assert calls == [MIN_PAIRS + 10]
    calls.clear()
    a, b = _blobs(rng, 3 * MIN_PAIRS), _blobs(rng, 3 * MIN_PAIRS)
    distances(a, b, workers=2)
    assert sorted(calls) == [3 * MIN_PAIRS // 2] * 2


def test_threads_respects_the_thread_cap(monkeypatch):
    monkeypatch.setenv("REPULSIONPAK_THREADS", "1")
    assert pairwise.threads() == 1
    monkeypatch.setenv("REPULSIONPAK_THREADS", "many")
    assert 1 <= pairwise.threads() <= 4
