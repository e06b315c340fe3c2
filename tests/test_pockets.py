"""The pocket fitting's geometry (:mod:`repulsionpak.geometry.pockets`)."""

import numpy as np
import pytest

from repulsionpak.geometry.pockets import Pockets, fit_scales, turned


def _one_by_one(pts, angles):
    """The outlines turned one angle at a time, as one 2×2 product each."""
    return np.stack([pts @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]]) for a in angles])


@pytest.mark.parametrize("layout", ["c", "f", "strided"])
def test_turned_is_the_per_angle_product_to_the_bit(layout):
    """The batched rotation gives the very bits of one product per angle (the packings
    depend on them: a sample on a pixel's edge falls on one side or the other)."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        n, a = int(rng.integers(2, 400)), int(rng.integers(1, 16))
        pts = rng.normal(size=(n, 2)) * rng.uniform(0.01, 500.0)
        if layout == "f":
            pts = np.asfortranarray(pts)
        elif layout == "strided":
            pts = np.ascontiguousarray(rng.normal(size=(n, 3)))[:, :2] * 40.0
        angles = rng.uniform(-7.0, 7.0, a)
        got = turned(pts, angles)
        assert got.shape == (a, n, 2)
        assert np.array_equal(got, _one_by_one(pts, angles))


def test_fit_scales_unchanged_on_a_ring_of_free_space():
    """fit_scales on a disc of free space: a unit square's corners fit up to the disc's
    radius less the offset, at every angle, as the one-angle fit says."""
    h, r = 0.05, 2.0
    ax = (np.arange(160) + 0.5) * h - 4.0
    x, y = np.meshgrid(ax, ax)
    dist = np.clip(r - np.hypot(x, y), 0.0, None)
    pockets = Pockets(dist, -4.0, -4.0, h, np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64))
    pts = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    angles = np.array([0.0, 0.3, np.pi / 4])
    steps = np.geomspace(0.5, 4.0, 37)
    got = fit_scales(pockets, np.zeros(2), pts, angles, 0.1, 1.0, steps)
    for a, sc in zip(angles, got):
        one = fit_scales(pockets, np.zeros(2), pts, np.array([a]), 0.1, 1.0, steps)[0]
        assert sc == one
        assert sc * np.sqrt(0.5) <= r - 0.1 + h  # the corners stay inside the disc less the offset
