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


def _wavy(n, r, c=(0.0, 0.0), k=37, amp=0.03):
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    rr = r * (1.0 + amp * np.sin(k * t) + 0.2 * np.sin(3 * t))
    return np.column_stack([c[0] + rr * np.cos(t), c[1] + rr * np.sin(t)])


def _dense_pairs():
    """Finely traced outlines around, beside, inside and across each other."""
    inner = shapely.Polygon(_wavy(3000, 1.0))
    ring = shapely.Polygon(_wavy(3000, 2.2), [_wavy(2500, 1.6)[::-1]])
    beside = shapely.Polygon(_wavy(2800, 1.0, (2.9, 0.4), k=41))
    across = shapely.Polygon(_wavy(2000, 0.8, (0.9, 0.0)))
    far = shapely.Polygon(_wavy(2000, 10.0, (500.0, -300.0)))
    line = shapely.LineString(_wavy(2200, 1.3, k=29))
    two = shapely.MultiPolygon([beside, shapely.Polygon(_wavy(2000, 0.5, (-3.0, -2.5)))])
    return [(inner, ring), (ring, inner), (inner, beside), (inner, across), (inner, far),
            (line, ring), (ring, line), (line, inner), (two, inner), (two, ring),
            (inner, shapely.Polygon())]


@pytest.mark.parametrize("k", range(len(_dense_pairs())))
def test_dense_pairs_are_measured_piece_by_piece_to_shapelys_bit(k):
    a, b = _dense_pairs()[k]
    want = float(shapely.distance(a, b))
    got = pairwise.dense_distance(a, b)
    assert got == want or (np.isnan(want) and np.isnan(got))


def test_distances_send_only_dense_pairs_to_the_pieces(monkeypatch):
    pairs = _dense_pairs()
    rng = np.random.default_rng(5)
    small = _blobs(rng, 6)
    a = np.array([p[0] for p in pairs] + list(small[:3]), dtype=object)
    b = np.array([p[1] for p in pairs] + list(small[3:]), dtype=object)
    monkeypatch.setattr(pairwise, "DENSE", 1_000_000)  # every traced pair, no small blob
    seen = []
    real = pairwise.dense_distance
    monkeypatch.setattr(pairwise, "dense_distance", lambda x, y: seen.append(1) or real(x, y))
    got = distances(a, b, workers=2)
    assert np.array_equal(got, shapely.distance(a, b), equal_nan=True)
    count = shapely.get_num_coordinates
    dense = sum(1 for x, y in pairs if count(x) * count(y) > pairwise.DENSE)
    assert len(seen) == dense == len(pairs) - 1  # not the empty one, not the small blobs
