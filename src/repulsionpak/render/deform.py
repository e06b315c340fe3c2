"""The deformation map: from an element's rest mesh to its deformed copy.

The simulation moves mesh vertices only; the art between them follows a map that is
fixed by the rest mesh and linear in the deformed vertex positions::

    f(p) = Σ_j w_j(p) · x_j          (x_j: deformed vertex j, container units)

Two choices of weights ``w_j``:

* ``smooth`` (default): thin-plate-spline interpolation of the mesh vertices (the
  polyharmonic spline φ(r) = r² log r plus an affine part, rest vertices as centres).
  The weights sum to one, reproduce every affine map exactly (so a copy that is only
  moved, turned and scaled is exact), follow every vertex (skin and interior) — exactly
  with ``smoothing`` 0, within a fraction of a mesh spacing as the smoothing spline that
  ``RenderParams.smoothing`` makes the default — and are C∞ away from the vertices and C¹
  at them: a bent element looks bent, not faceted.
* ``linear``: the paper's barycentric coordinates in the enclosing rest triangle
  (piecewise affine: kinks wherever an outline crosses a triangle edge).

A :class:`MapPlan` samples a template's art curves densely once (in the template's rest
coordinates) and holds the weights of every sample and of the derivative along its
segment, so mapping a copy is two small matrix products.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..geometry.curves import as_cubics, cubic_points
from ..geometry.mesh import bind_points
from ..types import CurveSubpath

__all__ = ["MapPlan", "Spline", "art_curves", "map_plan", "tps_weights", "linear_weights"]

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
    scale = 0.0  # loops rather than array expressions: seconds less to compile on a first run
    for i in range(n):
        for j in range(n):
            scale = max(scale, abs(m[i, j]))
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(m[i, k]) > abs(m[p, k]):
                p = i
        if abs(m[p, k]) <= 1e-13 * scale:
            for i in range(x.shape[0]):
                for j in range(x.shape[1]):
                    x[i, j] = np.nan
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


#: meshes with more vertices than this are solved by LAPACK: the compiled loop is as
#: fast up to ~150 vertices (0.9 against 0.7 ms at 100) but cubic without blocking
#: (0.55 against 0.05 s at 800; the largest meshes of an element ~50 gaps across have
#: ~1,800 vertices, 2 s each)
LAPACK_ABOVE = 200


def _solve_system(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x = b``: :func:`_solve` for small systems, LAPACK for large ones (NaN if singular)."""
    if a.shape[0] <= LAPACK_ABOVE:
        return _solve(a, b)
    try:
        return np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        return np.full(b.shape, np.nan)


def tps_weights(rest: np.ndarray, points: np.ndarray, directions: np.ndarray | None = None,
                chunk: int = 4096, smoothing: float = 0.0) -> tuple[np.ndarray, np.ndarray | None]:
    """Thin-plate-spline weights (see :func:`tps_factors`): ``W`` (P, N) and ``D``."""
    B, DB, coef = tps_factors(rest, points, directions, chunk, smoothing)
    return B @ coef, (None if DB is None else DB @ coef)


def tps_factors(rest: np.ndarray, points: np.ndarray, directions: np.ndarray | None = None,
                chunk: int = 4096, smoothing: float = 0.0) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """Thin-plate-spline weights of ``points`` (P, 2) w.r.t. the centres ``rest`` (N, 2).

    Returns ``(B, DB, C)``: ``W = B @ C`` (P, N) gives ``f(points) = W @ x`` for deformed
    centres ``x`` (N, 2), and, when ``directions`` (P, 2) are given, ``D = DB @ C`` gives
    ``Df(points)·directions = D @ x``. Rows of W sum to 1 and rows of D to 0 (affine maps
    are reproduced exactly). ``smoothing`` > 0 gives the smoothing spline (λ added to the
    kernel's diagonal, coordinates scaled to the rest mesh's size): it no longer passes
    exactly through the vertices but irons out crumpled spots. ``B``, ``DB`` (P, N + 3) are the kernel rows, ``C``
    (N + 3, N) the spline coefficients of each unit vertex: mapping a copy as
    ``B @ (C @ x)`` avoids ever forming the (P, N) product.
    """
    spline = Spline.fit(rest, points, directions, smoothing)
    W = np.empty((len(spline.points), spline.width))
    D = None if directions is None else np.empty((len(spline.points), spline.width))
    for i in range(0, len(spline.points), chunk):
        b, db = spline.rows(slice(i, i + chunk))
        W[i : i + chunk] = b
        if D is not None:
            D[i : i + chunk] = db
    return W, D, spline.coef


@dataclass(frozen=True, eq=False)
class Spline:
    """A thin-plate spline through a rest mesh's centres, and the samples it maps: the
    kernel rows of any samples (:meth:`rows`) on demand, so that a plan too large to hold
    its weight matrices (:data:`MAP_BYTES`) maps chunk by chunk (:meth:`apply`).

    ``q`` (N, 2) are the centres scaled to the unit box about ``c0`` by ``s`` and ``coef``
    (N + 3, N) the spline coefficients of each unit vertex (see :func:`tps_factors`);
    ``points`` (P, 2) and ``directions`` (P, 2) or None the samples in rest coordinates."""

    q: np.ndarray
    c0: np.ndarray
    s: float
    coef: np.ndarray
    points: np.ndarray
    directions: np.ndarray | None

    @classmethod
    def fit(cls, rest: np.ndarray, points: np.ndarray, directions: np.ndarray | None = None,
            smoothing: float = 0.0) -> "Spline":
        """Solve the spline system of the centres ``rest`` (see :func:`tps_factors`)."""
        rest = np.asarray(rest, dtype=float)
        n = len(rest)
        c0 = rest.mean(axis=0)
        s = float(np.ptp(rest, axis=0).max()) or 1.0
        q = (rest - c0) / s
        a = np.zeros((n + 3, n + 3))
        a[:n, :n] = _kernel(((q[:, None, :] - q[None, :, :]) ** 2).sum(-1)) + smoothing * np.eye(n)
        a[:n, n] = 1.0
        a[:n, n + 1 :] = q
        a[n, :n] = 1.0
        a[n + 1 :, :n] = q.T
        rhs = np.zeros((n + 3, n))
        rhs[:n] = np.eye(n)
        coef = _solve_system(a, rhs)  # (N+3, N): spline coefficients per unit vertex
        if not np.all(np.isfinite(coef)):  # coincident centres: least-squares solution
            coef = np.linalg.lstsq(a, rhs, rcond=None)[0]
        return cls(q, c0, s, coef, np.asarray(points, dtype=float),
                   None if directions is None else np.asarray(directions, dtype=float))

    @property
    def width(self) -> int:
        """Columns of a kernel row: the centres and the affine part."""
        return len(self.q) + 3

    def rows(self, idx) -> tuple[np.ndarray, np.ndarray | None]:
        """Kernel rows ``(B[idx], DB[idx])`` of the samples ``idx`` (a slice or indices)."""
        q = self.q
        p = (self.points[idx] - self.c0) / self.s
        qq = (q * q).sum(axis=1)
        r2 = np.maximum((p * p).sum(axis=1)[:, None] + qq[None, :] - 2.0 * (p @ q.T), 0.0)
        b = np.concatenate([_kernel(r2), np.ones((len(p), 1)), p], axis=1)
        if self.directions is None:
            return b, None
        d = self.directions[idx] / self.s
        proj = (p * d).sum(axis=1)[:, None] - d @ q.T  # (p - q_j) · d
        g = _kernel_grad_factor(r2) * proj
        return b, np.concatenate([g, np.zeros((len(p), 1)), d], axis=1)

    def apply(self, x: np.ndarray, chunk: int = 4096) -> tuple[np.ndarray, np.ndarray]:
        """``(B @ x, DB @ x)`` for spline-coefficient positions ``x`` (N + 3, 2), a chunk
        of samples at a time (memory: chunk × (N + 3) numbers)."""
        P = len(self.points)
        q, g = np.empty((P, 2)), np.empty((P, 2))
        for i in range(0, P, chunk):
            b, db = self.rows(slice(i, i + chunk))
            q[i : i + chunk] = b @ x
            g[i : i + chunk] = db @ x
        return q, g


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
    ``W``/``D`` (P, K) the position and derivative (d/dt) weights, applied to
    ``R @ verts`` (``R`` (K, N): the spline coefficients; None for the barycentric map).
    ``centres``: the mesh vertices the spline passes through when it is fitted on a
    subset of a large mesh (:data:`TPS_MAX_CENTRES`); ``R`` then applies to
    ``verts[centres]``. None: every vertex. ``spline``: for a plan whose weights would
    take more than :data:`MAP_BYTES`, the :class:`Spline` that computes them when the plan
    is applied (``W`` and ``D`` are then None).
    """

    curves: tuple[tuple[CurveSubpath, ...], ...]
    seg_start: tuple[tuple[np.ndarray, ...], ...]
    t: np.ndarray
    points: np.ndarray
    W: np.ndarray | None
    D: np.ndarray | None
    smooth: bool
    R: np.ndarray | None = None
    centres: np.ndarray | None = None
    spline: Spline | None = None

    def apply(self, verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mapped samples (P, 2) and their derivatives d/dt (P, 2) for deformed ``verts``."""
        if self.R is None:
            x = verts
        else:
            x = self.R @ (verts if self.centres is None else verts[self.centres])
        if self.spline is not None:
            return self.spline.apply(x)
        return self.W @ x, self.D @ x

    def weights(self, idx: np.ndarray) -> np.ndarray:
        """The position weights of the samples ``idx`` (``W[idx]``), applied to
        ``R @ verts`` as in :meth:`apply`."""
        return self.W[idx] if self.spline is None else self.spline.rows(idx)[0]


def _samples_per_segment(order: np.ndarray, cubic: np.ndarray, spacing: float, density: float,
                         tol: float) -> np.ndarray:
    """Intervals per segment: ``density`` per mesh spacing along it, and enough that the
    source curve is within ``tol`` of the chords between samples; curves 8 to 128,
    lines 3 to 128 (a line's map only varies at the mesh's scale)."""
    length = np.hypot(*np.diff(cubic, axis=1).transpose(2, 0, 1)).sum(axis=1)
    n = density * length / spacing
    d1 = np.hypot(*(cubic[:, 0] - 2 * cubic[:, 1] + cubic[:, 2]).T)
    d2 = np.hypot(*(cubic[:, 1] - 2 * cubic[:, 2] + cubic[:, 3]).T)
    bound = 6.0 * np.maximum(d1, d2)
    if tol > 0:
        n = np.maximum(n, np.sqrt(bound / (8.0 * tol)))
    low = np.where(order == 1, 3, 8)
    return np.minimum(128, np.maximum(low, np.ceil(n))).astype(np.int64)


def _sample_chain(order: np.ndarray, ctrl: np.ndarray, spacing: float, density: float, tol: float):
    """Samples of one subpath: points, derivatives d/dt, parameters, segment starts."""
    c = as_cubics(order, ctrl)
    n = _samples_per_segment(order, c, spacing, density, tol)
    seg = np.repeat(np.arange(len(order)), n + 1)
    first = np.concatenate([[0], np.cumsum(n + 1)])
    t = (np.arange(len(seg)) - first[seg]) / n[seg]
    pts, der = cubic_points(c[seg], t)
    return pts, der, t, first


def build_plan(template, smooth: bool = True, density: float = 8.0, smoothing: float = 0.0) -> MapPlan:
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
            p_, d_, t_, first = _sample_chain(sub.order, sub.ctrl, spacing, density, tol)
            pts.append(p_)
            ders.append(d_)
            ts.append(t_)
            starts.append(first + count)
            count += len(t_)
            subs.append(sub)
        curves_out.append(tuple(subs))
        starts_out.append(tuple(starts))
    points = np.concatenate(pts) if pts else np.zeros((0, 2))
    dirs = np.concatenate(ders) if ders else np.zeros((0, 2))
    t = np.concatenate(ts) if ts else np.zeros(0)
    centres, spline = None, None
    if smooth:
        if len(verts) > TPS_MAX_CENTRES:
            centres = spline_centres(verts, template.n_skin, TPS_MAX_CENTRES)
        rest = verts if centres is None else verts[centres]
        if 2 * 8 * len(points) * (len(rest) + 3) > MAP_BYTES:
            spline = Spline.fit(rest, points, dirs, smoothing)
            W, D, R = None, None, spline.coef
        else:
            W, D, R = tps_factors(rest, points, dirs, smoothing=smoothing)
    else:
        (W, D), R = linear_weights(verts, tris, points, dirs), None
    return MapPlan(tuple(curves_out), tuple(starts_out), t, points, W, D, smooth, R, centres, spline)


#: the most memory a plan's weight matrices (position and derivative, samples × centres)
#: may take; a larger plan (art of tens of thousands of samples: a traced outline, a line
#: of text) computes its weights chunk by chunk each time it maps a copy. Held, a
#: 40,000-point outline's took 1.9 GB per template (one per element and pocket scale)
MAP_BYTES = 256 * 2**20


#: the smooth map of a mesh with more vertices than this (an element hundreds of gaps
#: across) is the spline through this many of them: the spline's dense system grows as
#: the square of its centres (182,000 vertices asked for 248 GB) and its solve as the
#: cube (1,500 centres: ~1 s, once per template)
TPS_MAX_CENTRES = 1500


def spline_centres(verts: np.ndarray, n_skin: int, k: int) -> np.ndarray:
    """``k`` vertex indices spread over a large mesh: evenly along the skin boundary
    (``verts[:n_skin]``, three quarters of them: the art lies along it), and one interior
    vertex per cell of a grid over the rest, sorted."""
    n = len(verts)
    nb = min(n_skin, (3 * k) // 4)
    boundary = np.unique(np.linspace(0, n_skin - 1, nb).round().astype(np.int64))
    inner = np.arange(n_skin, n)
    m = k - len(boundary)
    if len(inner) > m > 0:
        p = verts[inner]
        lo, span = p.min(axis=0), np.maximum(np.ptp(p, axis=0), 1e-12)
        cell = float(np.sqrt(span[0] * span[1] / m)) or 1.0
        key = np.floor((p - lo) / cell).astype(np.int64)
        _, first = np.unique(key[:, 0] * (int(key[:, 1].max()) + 1) + key[:, 1], return_index=True)
        inner = inner[np.sort(first)[:m]]
    elif m <= 0:
        inner = inner[:0]
    return np.concatenate([boundary, inner])


_PLANS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def map_plan(template, smooth: bool = True, density: float = 8.0, smoothing: float = 0.0) -> MapPlan:
    """:func:`build_plan`, cached per template (plans depend on the rest shape only)."""
    per = _PLANS.setdefault(template, {})
    key = (bool(smooth), float(density), float(smoothing))
    if key not in per:
        per[key] = build_plan(template, smooth, density, smoothing)
    return per[key]
