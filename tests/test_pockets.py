"""The pocket fitting's geometry (:mod:`repulsionpak.geometry.pockets`)."""

import numpy as np
import pytest

from repulsionpak.geometry.pockets import Pockets, best_fit, fit_scales, turned


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


def _free_space(rng):
    """Pockets of a random free space: a grid less a few discs (its exact distance
    transform), at a random origin and pixel size."""
    from repulsionpak.geometry.edt import distance_transform

    ny, nx = int(rng.integers(8, 100)), int(rng.integers(8, 100))
    yy, xx = np.mgrid[0:ny, 0:nx]
    mask = np.ones((ny, nx), bool)
    for _ in range(int(rng.integers(1, 10))):
        cy, cx, r = rng.uniform(0, ny), rng.uniform(0, nx), rng.uniform(1.0, 0.3 * min(nx, ny))
        mask &= (yy - cy) ** 2 + (xx - cx) ** 2 >= r * r
    h = float(rng.uniform(0.05, 3.0))
    x0, y0 = rng.uniform(-500.0, 500.0, 2)
    none = np.zeros(0, np.int64)
    return Pockets(distance_transform(mask, h), x0, y0, h, np.zeros(0), none, none)


def test_best_fit_is_the_first_largest_fit_scale():
    """best_fit gives the angle and scale of the first largest fit_scales, to the bit, or
    none when no fit is above the scale it must beat; the angles it drops early never
    change the answer."""
    rng = np.random.default_rng(11)
    steps = np.geomspace(0.5, 4.0, 37)
    for _ in range(600):
        pockets = _free_space(rng)
        ny, nx = pockets.dist.shape
        pts = rng.normal(size=(int(rng.integers(1, 160)), 2)) * rng.uniform(0.1, 5.0, 2)
        iy, ix = np.nonzero(pockets.dist > 0)
        if len(iy) and rng.random() < 0.9:  # in the free space, scales about its inscribed-circle fit
            k = int(rng.integers(len(iy)))
            seed = np.array([pockets.x0 + (ix[k] + 0.5) * pockets.h, pockets.y0 + (iy[k] + 0.5) * pockets.h])
            d = float(pockets.dist[iy[k], ix[k]])
            offset = float(rng.uniform(0.0, 0.5)) * d
            s0 = max(d - offset, 0.5 * d) / float(np.sqrt((pts ** 2).sum(axis=1).max()))
        else:  # anywhere, off the grid too
            seed = np.array([pockets.x0, pockets.y0]) + rng.uniform(-0.1, 1.1, 2) * np.array([nx, ny]) * pockets.h
            offset = float(rng.uniform(0.0, 10.0)) * pockets.h
            s0 = float(rng.uniform(0.1, 4.0)) * pockets.h
        angles = rng.uniform(0.0, 2.0 * np.pi, int(rng.integers(1, 13)))
        above = int(rng.integers(-1, 20))
        fits = fit_scales(pockets, seed, pts, angles, offset, s0, steps)
        a, sc = best_fit(pockets, seed, pts, angles, offset, s0, steps, above)
        top = int(np.argmax(fits))
        if fits[top] > s0 * steps[above] or above < 0:
            assert (a, sc) == (top, fits[top])
        else:
            assert a == -1 and np.isnan(sc)
