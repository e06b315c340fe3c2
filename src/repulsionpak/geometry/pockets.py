"""Free space on a grid, and the largest scale at which a shape fits in it.

:class:`Pockets` holds a distance transform of the free space (distance to the nearest
obstacle, 0 outside) and points chosen in it; :func:`fit_scales` scans increasing scales of
a sampled outline (:func:`outline_samples`) at a point and stops at the first that comes
closer than an offset to an obstacle. The pocket fill (:mod:`repulsionpak.secondary`) sizes
its copies so, and the size plan of the primaries (:mod:`repulsionpak.sizing`) its parts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numba import njit


@dataclass(frozen=True)
class Pockets:
    """The negative space left by the primaries, on a grid: the distance transform
    ``dist`` (container units, 0 outside the free space), its grid origin and pixel size,
    and the seeds chosen in it (grid indices, distances; :attr:`seeds` their points)."""

    dist: np.ndarray
    x0: float
    y0: float
    h: float
    distance: np.ndarray  # (K,)
    iy: np.ndarray
    ix: np.ndarray

    @property
    def seeds(self) -> np.ndarray:
        """The seeds' points (K, 2): their pixels' centres, container units."""
        return np.column_stack([self.x0 + (self.ix + 0.5) * self.h, self.y0 + (self.iy + 0.5) * self.h])

    def lookup(self, pts: np.ndarray) -> np.ndarray:
        """Distance to the nearest skin or the boundary at ``pts`` (..., 2); 0 outside the
        free space and off the grid."""
        j = np.floor((pts[..., 0] - self.x0) / self.h).astype(np.int64)
        i = np.floor((pts[..., 1] - self.y0) / self.h).astype(np.int64)
        ny, nx = self.dist.shape
        ok = (i >= 0) & (i < ny) & (j >= 0) & (j < nx)
        out = np.zeros(pts.shape[:-1])
        out[ok] = self.dist[i[ok], j[ok]]
        return out


def outline_samples(outline, n: int = 96, n_inside: int = 64) -> np.ndarray:
    """Points of an element's outline, centred on its centroid, in file units: ``n``
    along its outer boundaries and about ``n_inside`` on a grid inside them (holes
    included: the mesh covers them too), so a copy is never fitted around a neighbour."""
    geoms = [g for g in getattr(outline.geometry, "geoms", [outline.geometry]) if not g.is_empty]
    rings = [g.exterior for g in geoms]
    total = sum(r.length for r in rings) or 1.0
    pts = []
    for r in rings:
        k = max(4, int(round(n * r.length / total)))
        t = np.linspace(0.0, r.length, k, endpoint=False)
        pts.append(shapely.get_coordinates(shapely.line_interpolate_point(r, t)))
    filled = shapely.union_all([shapely.Polygon(r) for r in rings])
    x0, y0, x1, y1 = filled.bounds
    step = np.sqrt(max(filled.area, 1e-300) / n_inside)
    gx, gy = np.meshgrid(np.arange(x0 + step / 2, x1, step), np.arange(y0 + step / 2, y1, step))
    gx, gy = gx.ravel(), gy.ravel()
    inside = shapely.contains_xy(filled, gx, gy)
    pts.append(np.column_stack([gx[inside], gy[inside]]))
    return np.vstack(pts) - outline.center


def fit_scale(pockets: Pockets, seed: np.ndarray, pts: np.ndarray, angle: float, offset: float,
              s0: float, steps: np.ndarray) -> float:
    """The largest ``s0 · steps[j]`` (steps increasing) at which the outline ``pts``,
    scaled, turned by ``angle`` and centred on ``seed``, keeps ``offset`` from every skin
    and the boundary at all its samples, stopping at the first scale that does not fit;
    ``s0 · steps[0]`` when none does."""
    return float(fit_scales(pockets, seed, pts, np.array([angle], dtype=float), offset, s0, steps)[0])


def turned(pts: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(A, n, 2): the points ``pts`` (n, 2) turned by each of ``angles`` (A,) about the
    origin, ``pts @ [[cos a, sin a], [-sin a, cos a]]``.

    Notes
    -----
    One batched product over stacked rotation matrices, built with one vectorised
    ``cos`` and ``sin``: the fill fits hundreds of pockets, each at a dozen angles and for
    several candidate elements, and building the 2×2 matrices one angle at a time took
    as long as the fitting kernel itself (a 1,000-element poster: ~2 s of ~4). The same
    products as one ``pts @ matrix`` per angle, to the bit (``tests/test_pockets.py``).
    """
    angles = np.asarray(angles, dtype=float)
    c, s = np.cos(angles), np.sin(angles)
    rot = np.empty((len(angles), 2, 2))
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1] = c, s, -s, c
    return np.matmul(np.asarray(pts, dtype=float)[None], rot)


def fit_scales(pockets: Pockets, seed: np.ndarray, pts: np.ndarray, angles: np.ndarray, offset: float,
               s0: float, steps: np.ndarray) -> np.ndarray:
    """:func:`fit_scale` for each of ``angles`` at once (A,)."""
    q = turned(pts, angles)
    scales = s0 * np.asarray(steps, dtype=float)
    first = _first_misfit(pockets.dist, pockets.x0, pockets.y0, pockets.h, float(seed[0]), float(seed[1]),
                          np.ascontiguousarray(q), scales, float(offset))
    return scales[np.maximum(first - 1, 0)]


@njit(cache=True)
def _misfits(dist, x0, y0, h, sx, sy, q, a, s, offset):  # pragma: no cover - numba
    """Whether a sample of the turned outline ``q[a]``, scaled by ``s`` and centred on
    (sx, sy), lies less than ``offset`` from a skin or the boundary on the grid ``dist``
    (0 off the grid)."""
    ny, nx = dist.shape
    for p in range(q.shape[1]):
        jx = int(np.floor((sx + s * q[a, p, 0] - x0) / h))
        iy = int(np.floor((sy + s * q[a, p, 1] - y0) / h))
        d = dist[iy, jx] if 0 <= iy < ny and 0 <= jx < nx else 0.0
        if not d >= offset:
            return True
    return False


@njit(cache=True)
def _first_misfit(dist, x0, y0, h, sx, sy, q, scales, offset):  # pragma: no cover - numba
    """For each turned outline ``q[a]`` (A, n, 2) centred on (sx, sy): the index of the first
    of ``scales`` at which one of its samples lies less than ``offset`` from a skin or the
    boundary on the grid ``dist`` (0 off the grid), or len(scales) when every one fits.
    Each outline stops at its first misfit (the same answer as testing every scale)."""
    n_a = q.shape[0]
    out = np.full(n_a, len(scales), np.int64)
    for a in range(n_a):
        for j in range(len(scales)):
            if _misfits(dist, x0, y0, h, sx, sy, q, a, scales[j], offset):
                out[a] = j
                break
    return out


@njit(cache=True)
def _best_misfit(dist, x0, y0, h, sx, sy, q, scales, offset, above):  # pragma: no cover - numba
    """(a, f): the first turned outline ``q[a]`` whose fit index f (one below its first
    misfit, :func:`_first_misfit`, at least 0) is the largest of all and above ``above``;
    (-1, above) when none is. An outline after the best so far (fit index b) counts only
    if it fits at every scale up to b + 1: those are tried first, the largest first, and
    the first misfit among them drops it; only a new best is fitted on upwards."""
    m = len(scales)
    best_a, best_f = -1, above
    for a in range(q.shape[0]):
        if best_f >= m - 1:  # a fit at every scale: nothing after it is larger
            break
        start = 0
        if best_f >= 0:
            beaten = True
            for j in range(best_f + 1, -1, -1):
                if _misfits(dist, x0, y0, h, sx, sy, q, a, scales[j], offset):
                    beaten = False
                    break
            if not beaten:
                continue
            start = best_f + 2
        first = m
        for j in range(start, m):
            if _misfits(dist, x0, y0, h, sx, sy, q, a, scales[j], offset):
                first = j
                break
        best_a, best_f = a, max(first - 1, 0)
    return best_a, best_f


def best_fit(pockets: Pockets, seed: np.ndarray, pts: np.ndarray, angles: np.ndarray, offset: float,
             s0: float, steps: np.ndarray, above: int = -1) -> tuple[int, float]:
    """The first of ``angles`` whose :func:`fit_scales` is the largest, and that scale:
    ``(a, fit_scales(...)[a])`` for ``a`` its first maximum — or (-1, nan) when no fit
    is above ``s0 · steps[above]`` (``above`` -1: any fit counts).

    Notes
    -----
    The pocket fill keeps, of each element, its best angle only, and of the elements of
    a pocket the one with the most art: an angle can only matter if it fits at every
    scale up to one step beyond the best before it, and a fit at the step beyond is
    tried first and mostly fails at once. On the 1,000-element poster's pockets most
    angles and most candidate elements are so dropped after a few lookups
    (``tests/test_pockets.py`` checks the answers against :func:`fit_scales`)."""
    q = turned(pts, angles)
    scales = s0 * np.asarray(steps, dtype=float)
    a, f = _best_misfit(pockets.dist, pockets.x0, pockets.y0, pockets.h, float(seed[0]), float(seed[1]),
                        np.ascontiguousarray(q), scales, float(offset), int(above))
    return (int(a), float(scales[f])) if a >= 0 else (-1, float("nan"))


__all__ = ["Pockets", "best_fit", "fit_scale", "fit_scales", "outline_samples", "turned"]
