"""A smooth direction field over the container, interpolated from guide strokes.

The strokes' unit tangents, written as (cos θ, sin θ), are fixed values on the grid nodes
they pass; every other node takes the harmonic (Laplace) interpolation of them, solved as
one sparse linear system per component; the result is normalised. Far from every stroke
the field turns smoothly between them; at a point where the tangents cancel (the centre of
a circular guide) the direction is undefined and the field's norm there is ~0
(:meth:`FlowField.strength`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError


@dataclass(frozen=True)
class FlowField:
    """Unit directions on a regular grid, sampled bilinearly.

    ``u[j, i]`` is the (x, y) direction at node ``(ox + i·h, oy + j·h)``, container units
    with y down (SVG): an angle θ is ``atan2(y, x)``, clockwise on screen. ``norm`` is the
    interpolated vector's length before normalising (1 on a guide; small where guides
    oppose each other).
    """

    ox: float
    oy: float
    h: float
    u: np.ndarray  # (ny, nx, 2)
    norm: np.ndarray  # (ny, nx)

    def _bilinear(self, values: np.ndarray, points: np.ndarray) -> np.ndarray:
        p = np.atleast_2d(np.asarray(points, dtype=float))
        ny, nx = values.shape[:2]
        fx = np.clip((p[:, 0] - self.ox) / self.h, 0.0, nx - 1.000001)
        fy = np.clip((p[:, 1] - self.oy) / self.h, 0.0, ny - 1.000001)
        i, j = fx.astype(np.int64), fy.astype(np.int64)
        tx, ty = fx - i, fy - j
        if values.ndim == 3:
            tx, ty = tx[:, None], ty[:, None]
        return ((1 - tx) * (1 - ty) * values[j, i] + tx * (1 - ty) * values[j, i + 1]
                + (1 - tx) * ty * values[j + 1, i] + tx * ty * values[j + 1, i + 1])

    def direction(self, points: np.ndarray) -> np.ndarray:
        """(K, 2) unit directions at ``points`` ((K, 2), container units)."""
        v = self._bilinear(self.u, points)
        n = np.hypot(v[:, 0], v[:, 1])
        out = np.zeros_like(v)
        ok = n > 1e-12
        out[ok] = v[ok] / n[ok, None]
        out[~ok, 0] = 1.0
        return out

    def angle(self, points: np.ndarray) -> np.ndarray:
        """(K,) field angles (radians, clockwise on screen) at ``points``."""
        d = self.direction(points)
        return np.arctan2(d[:, 1], d[:, 0])

    def strength(self, points: np.ndarray) -> np.ndarray:
        """(K,) the interpolated vector's length at ``points`` (1 on a guide, ~0 where the
        direction is undefined)."""
        return self._bilinear(self.norm, points)

    def arrows(self, region, spacing: float) -> list[np.ndarray]:
        """Arrow polygons (a shaft and a head, ``0.8·spacing`` long) on a grid of
        ``spacing`` inside ``region`` (a shapely geometry): the debug layer."""
        import shapely  # noqa: PLC0415

        x0, y0, x1, y1 = region.bounds
        xs = np.arange(x0 + 0.5 * spacing, x1, spacing)
        ys = np.arange(y0 + 0.5 * spacing, y1, spacing)
        gx, gy = np.meshgrid(xs, ys)
        pts = np.column_stack([gx.ravel(), gy.ravel()])
        if len(pts) == 0:
            return []
        pts = pts[shapely.contains_xy(region, pts[:, 0], pts[:, 1])]
        d = self.direction(pts) * (0.4 * spacing)
        nrm = np.column_stack([-d[:, 1], d[:, 0]]) * 0.35
        tail, tip = pts - d, pts + d
        left, right = tip - 0.5 * d + nrm, tip - 0.5 * d - nrm
        return [np.array([t, p, a, p, b, p]) for t, p, a, b in zip(tail, tip, left, right)]


def _tangent_samples(strokes, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points every ~``step`` along the strokes and the unit tangents there."""
    pts, tans = [], []
    for s in strokes:
        s = np.asarray(s, dtype=float)
        seg = np.diff(s, axis=0)
        length = np.hypot(seg[:, 0], seg[:, 1])
        keep = length > 0
        a, seg, length = s[:-1][keep], seg[keep], length[keep]
        for p, d, n in zip(a, seg, length):
            k = max(1, int(np.ceil(n / step)))
            t = (np.arange(k) + 0.5) / k
            pts.append(p + t[:, None] * d)
            tans.append(np.repeat((d / n)[None], k, axis=0))
    if not pts:
        raise ParameterError("the flow guides have no stroke of positive length")
    return np.vstack(pts), np.vstack(tans)


def field_from_guides(strokes, bounds: tuple[float, float, float, float], resolution: int = 96
                      ) -> FlowField:
    """The harmonic direction field of ``strokes`` over ``bounds``.

    Parameters
    ----------
    strokes : list of (K, 2) arrays
        Guide polylines (:func:`repulsionpak.flow.guides.load_guides`), in the container's
        units; each one's direction is the direction of travel.
    bounds : (x0, y0, x1, y1)
        The area to cover (the container's bounds); a margin of two cells is added.
    resolution : int
        Grid cells along the longer side of ``bounds``.

    Returns
    -------
    FlowField

    Notes
    -----
    Each grid node a stroke passes takes the mean of the tangents sampled in its cell
    (samples every half cell); the other nodes solve the graph Laplace equation (zero
    normal derivative at the grid's border), for the x and y components separately
    (scipy's sparse direct solver: ~10⁴ unknowns, milliseconds). Harmonic interpolation
    has no overshoot: the field between two parallel strokes is parallel to them, a single
    straight stroke gives a uniform field.
    """
    import scipy.sparse as sp  # noqa: PLC0415
    from scipy.sparse.linalg import spsolve  # noqa: PLC0415

    if int(resolution) < 4:
        raise ParameterError(f"flow field resolution must be >= 4, got {resolution!r}")
    x0, y0, x1, y1 = map(float, bounds)
    size = max(x1 - x0, y1 - y0)
    if not size > 0:
        raise ParameterError("the container has no extent for a flow field")
    h = size / int(resolution)
    ox, oy = x0 - 2 * h, y0 - 2 * h
    nx = int(np.ceil((x1 - x0) / h)) + 5
    ny = int(np.ceil((y1 - y0) / h)) + 5
    pts, tans = _tangent_samples(strokes, 0.5 * h)
    i = np.rint((pts[:, 0] - ox) / h).astype(np.int64)
    j = np.rint((pts[:, 1] - oy) / h).astype(np.int64)
    inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
    if not inside.any():
        raise ParameterError("no flow guide passes over the container: draw the guides in the "
                             "container's coordinates (on a copy of its file)")
    node = (j * nx + i)[inside]
    n = nx * ny
    acc = np.zeros((n, 2))
    np.add.at(acc, node, tans[inside])
    cnt = np.bincount(node, minlength=n).astype(float)
    fixed = cnt > 0
    acc[fixed] /= cnt[fixed, None]
    # nodes where opposite tangents cancel carry no direction: left free
    fixed &= np.hypot(acc[:, 0], acc[:, 1]) > 0.25
    if not fixed.any():
        raise ParameterError("the flow guides cancel each other everywhere (opposite strokes on top of each other)")
    # the grid graph's Laplacian (4-neighbours)
    idx = np.arange(n).reshape(ny, nx)
    a = np.concatenate([idx[:, :-1].ravel(), idx[:-1, :].ravel()])
    b = np.concatenate([idx[:, 1:].ravel(), idx[1:, :].ravel()])
    adj = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    adj = (adj + adj.T).tocsr()
    lap = (sp.diags(np.asarray(adj.sum(axis=1)).ravel()) - adj).tocsr()
    free = ~fixed
    values = acc.copy()
    if free.any():
        lff = lap[free][:, free].tocsc()
        rhs = -(lap[free][:, fixed] @ acc[fixed])
        sol = spsolve(lff, rhs)
        values[free] = np.asarray(sol).reshape(-1, 2)
    norm = np.hypot(values[:, 0], values[:, 1])
    u = np.zeros_like(values)
    ok = norm > 1e-12
    u[ok] = values[ok] / norm[ok, None]
    u[~ok, 0] = 1.0
    return FlowField(ox, oy, h, u.reshape(ny, nx, 2), norm.reshape(ny, nx))


__all__ = ["FlowField", "field_from_guides"]
