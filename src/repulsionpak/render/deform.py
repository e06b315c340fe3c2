"""The deformation map: from an element's rest mesh to its deformed copy.

The simulation moves mesh vertices only; the art between them follows a map that is
fixed by the rest mesh and linear in the deformed vertex positions::

    f(p) = Σ_j w_j(p) · x_j          (x_j: deformed vertex j, container units)

Two choices of weights ``w_j``:

* ``smooth`` (default): thin-plate-spline interpolation of the mesh vertices (the
  polyharmonic spline φ(r) = r² log r plus an affine part, rest vertices as centres).
  The weights sum to one, reproduce every affine map exactly (so a copy that is only
  moved, turned and scaled is exact), interpolate every vertex (skin and interior), and
  are C∞ away from the vertices and C¹ at them: a bent element looks bent, not faceted.
* ``linear``: the paper's barycentric coordinates in the enclosing rest triangle
  (piecewise affine: kinks wherever an outline crosses a triangle edge).

A :class:`MapPlan` samples a template's art curves densely once (in the template's rest
coordinates) and holds the weights of every sample and of the derivative along its
segment, so mapping a copy is two small matrix products.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..geometry.mesh import bind_points
from ..types import CurveSubpath
from .curves import bezier, bezier_deriv

__all__ = ["MapPlan", "art_curves", "map_plan", "tps_weights", "linear_weights"]

#: samples are dense enough that the source curve is within this share of the element's
#: size of the chords between them (a quarter of the default curve tolerance)
SAMPLE_TOLERANCE = 2.5e-4


def _kernel(r2: np.ndarray) -> np.ndarray:
    """φ(r) = r² log r written with r²: ½ r² log r²; 0 at r = 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        k = 0.5 * r2 * np.log(r2)
    return np.where(r2 > 0, k, 0.0)


def _kernel_grad_factor(r2: np.ndarray) -> np.ndarray:
    """∇φ = (p - c) · (log r² + 1); returns the factor (log r² + 1), 0 at r = 0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.log(r2) + 1.0
    return np.where(r2 > 0, g, 0.0)


@njit(cache=True)
def _solve(a, b):
    """Solve a x = b by Gaussian elimination with partial pivoting (NaN if singular).

    The systems are small (mesh vertices + 3); a compiled loop is as fast as LAPACK here
    and, unlike a threaded BLAS on a busy machine, never waits for other threads."""
    n = a.shape[0]
    m = a.copy()
    x = b.copy()
    scale = np.abs(m).max()
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(m[i, k]) > abs(m[p, k]):
                p = i
        if abs(m[p, k]) <= 1e-13 * scale:
            x[:, :] = np.nan
            return x
        if p != k:
            for j in range(n):
                m[k, j], m[p, j] = m[p, j], m[k, j]
            for j in range(x.shape[1]):
                x[k, j], x[p, j] = x[p, j], x[k, j]
        inv = 1.0 / m[k, k]
        for i in range(k + 1, n):
            f = m[i, k] * inv
            if f != 0.0:
                for j in range(k, n):
                    m[i, j] -= f * m[k, j]
                for j in range(x.shape[1]):
                    x[i, j] -= f * x[k, j]
    for k in range(n - 1, -1, -1):
        inv = 1.0 / m[k, k]
        for j in range(x.shape[1]):
            s = x[k, j]
            for i in range(k + 1, n):
                s -= m[k, i] * x[i, j]
            x[k, j] = s * inv
    return x


def tps_weights(rest: np.ndarray, points: np.ndarray, directions: np.ndarray | None = None,
                chunk: int = 4096) -> tuple[np.ndarray, np.ndarray | None]:
    """Thin-plate-spline weights of ``points`` (P, 2) w.r.t. the centres ``rest`` (N, 2).

    Returns ``W`` (P, N) with ``f(points) = W @ x`` for deformed centres ``x`` (N, 2), and,
    when ``directions`` (P, 2) are given, ``D`` (P, N) with ``Df(points)·directions = D @ x``.
    Rows of W sum to 1 and rows of D to 0 (affine maps are reproduced exactly).
    """
    rest = np.asarray(rest, dtype=float)
    points = np.asarray(points, dtype=float)
    n = len(rest)
    c0 = rest.mean(axis=0)
    s = float(np.ptp(rest, axis=0).max()) or 1.0
    q = (rest - c0) / s
    a = np.zeros((n + 3, n + 3))
    a[:n, :n] = _kernel(((q[:, None, :] - q[None, :, :]) ** 2).sum(-1))
    a[:n, n] = 1.0
    a[:n, n + 1 :] = q
    a[n, :n] = 1.0
    a[n + 1 :, :n] = q.T
    rhs = np.zeros((n + 3, n))
    rhs[:n] = np.eye(n)
    coef = _solve(a, rhs)  # (N+3, N): spline coefficients per unit vertex
    if not np.all(np.isfinite(coef)):  # coincident centres: least-squares solution
        coef = np.linalg.lstsq(a, rhs, rcond=None)[0]
    W = np.empty((len(points), n))
    D = None if directions is None else np.empty((len(points), n))
    for i in range(0, len(points), chunk):
        p = (points[i : i + chunk] - c0) / s
        diff = p[:, None, :] - q[None, :, :]
        r2 = (diff**2).sum(-1)
        b = np.concatenate([_kernel(r2), np.ones((len(p), 1)), p], axis=1)
        W[i : i + chunk] = b @ coef
        if D is not None:
            d = np.asarray(directions[i : i + chunk], dtype=float) / s
            g = _kernel_grad_factor(r2) * np.einsum("pnk,pk->pn", diff, d)
            db = np.concatenate([g, np.zeros((len(p), 1)), d], axis=1)
            D[i : i + chunk] = db @ coef
    return W, D


def linear_weights(rest: np.ndarray, tris: np.ndarray, points: np.ndarray,
                   directions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Barycentric weights (the paper's map) in the same form as :func:`tps_weights`."""
    rest = np.asarray(rest, dtype=float)
    tri, bary = bind_points(points, rest, tris)
    n, m = len(rest), len(points)
    W = np.zeros((m, n))
    rows = np.repeat(np.arange(m), 3)
    np.add.at(W, (rows, tris[tri].ravel()), bary.ravel())
    if directions is None:
        return W, None
    a = rest[tris[tri, 0]]
    e = np.stack([rest[tris[tri, 1]] - a, rest[tris[tri, 2]] - a], axis=2)  # (m, 2, 2) columns
    inv = np.linalg.pinv(e)  # rows: gradients of bary 1 and 2
    g12 = np.einsum("mij,mj->mi", inv, directions)
    g = np.column_stack([-g12.sum(axis=1), g12])
    D = np.zeros((m, n))
    np.add.at(D, (rows, tris[tri].ravel()), g.ravel())
    return W, D


def art_curves(art) -> tuple[CurveSubpath, ...]:
    """The curves of an ArtPath: its exact source curves, else its polylines as lines."""
    if art.source is not None and art.source.curves:
        return art.source.curves
    out = []
    for pts, closed in zip(art.subpaths, art.closed):
        pts = np.asarray(pts, dtype=float)
        if len(pts) < 2:
            continue
        ends = np.vstack([pts, pts[:1]]) if closed else pts
        a, b = ends[:-1], ends[1:]
        ctrl = np.stack([a, b, b, b], axis=1)
        out.append(CurveSubpath(np.ones(len(a), np.int8), ctrl, bool(closed)))
    return tuple(out)


@dataclass(frozen=True, eq=False)
class MapPlan:
    """Dense samples of a template's art (rest coordinates) and their map weights.

    ``curves[a][s]`` is subpath s of art path a in rest (template) coordinates;
    ``seg_start[a][s]`` (n_seg + 1,) indexes the samples of each of its segments
    (segment k owns samples ``seg_start[k] .. seg_start[k+1] - 1``, at t = 0, 1/n, ...,
    1: both end points included). ``t`` (P,) are the samples' segment parameters,
    ``W``/``D`` (P, N) the position and derivative (d/dt) weights.
    """

    curves: tuple[tuple[CurveSubpath, ...], ...]
    seg_start: tuple[tuple[np.ndarray, ...], ...]
    t: np.ndarray
    points: np.ndarray
    W: np.ndarray
    D: np.ndarray
    smooth: bool

    def apply(self, verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mapped samples (P, 2) and their derivatives d/dt (P, 2) for deformed ``verts``."""
        return self.W @ verts, self.D @ verts


def _samples_per_segment(ctrl: np.ndarray, order: int, spacing: float, density: float,
                         tol: float) -> int:
    """``density`` samples per mesh spacing along the segment, and enough that the source
    curve is within ``tol`` of the chords between samples; 8 to 128."""
    length = float(np.hypot(*np.diff(ctrl[: order + 1], axis=0).T).sum())
    n = density * length / spacing
    if order == 2:
        bound = 2.0 * float(np.hypot(*(ctrl[0] - 2 * ctrl[1] + ctrl[2])))
    elif order == 3:
        bound = 6.0 * max(float(np.hypot(*(ctrl[0] - 2 * ctrl[1] + ctrl[2]))),
                          float(np.hypot(*(ctrl[1] - 2 * ctrl[2] + ctrl[3]))))
    else:
        bound = 0.0
    if bound > 0 and tol > 0:
        n = max(n, math.sqrt(bound / (8.0 * tol)))
    return int(min(128, max(8, math.ceil(n))))


def build_plan(template, smooth: bool = True, density: float = 8.0) -> MapPlan:
    """Sample ``template``'s art and compute the weights (see :class:`MapPlan`)."""
    verts, tris = template.verts, template.tris
    e = verts[np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])]
    spacing = float(np.median(np.hypot(*(e[:, 1] - e[:, 0]).T))) or 1.0
    to_rest = np.array([[template.scale, 0.0, -template.scale * template.outline.center[0]],
                        [0.0, template.scale, -template.scale * template.outline.center[1]],
                        [0.0, 0.0, 1.0]])
    pts, ders, ts = [], [], []
    curves_out, starts_out = [], []
    count = 0
    rest_curves = [[sub.transformed(to_rest) for sub in art_curves(art)] for art in template.element.paths]
    ends = [sub.ctrl.reshape(-1, 2) for subs in rest_curves for sub in subs]
    size = float(np.hypot(*np.ptp(np.concatenate(ends), axis=0))) if ends else 1.0
    tol = SAMPLE_TOLERANCE * size
    for subs_in in rest_curves:
        subs, starts = [], []
        for sub in subs_in:
            st = [count]
            for o, c in zip(sub.order, sub.ctrl):
                n = _samples_per_segment(c, int(o), spacing, density, tol)
                t = np.arange(n + 1) / n
                pts.append(bezier(c, int(o), t))
                ders.append(bezier_deriv(c, int(o), t))
                ts.append(t)
                count += n + 1
                st.append(count)
            subs.append(sub)
            starts.append(np.asarray(st))
        curves_out.append(tuple(subs))
        starts_out.append(tuple(starts))
    points = np.concatenate(pts) if pts else np.zeros((0, 2))
    dirs = np.concatenate(ders) if ders else np.zeros((0, 2))
    t = np.concatenate(ts) if ts else np.zeros(0)
    if smooth:
        W, D = tps_weights(verts, points, dirs)
    else:
        W, D = linear_weights(verts, tris, points, dirs)
    return MapPlan(tuple(curves_out), tuple(starts_out), t, points, W, D, smooth)


_PLANS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def map_plan(template, smooth: bool = True, density: float = 8.0) -> MapPlan:
    """:func:`build_plan`, cached per template (plans depend on the rest shape only)."""
    per = _PLANS.setdefault(template, {})
    key = (bool(smooth), float(density))
    if key not in per:
        per[key] = build_plan(template, smooth, density)
    return per[key]
