"""Triangle meshes of skins: triangulation, springs, barycentric binding (sec. 4–5)."""

from __future__ import annotations

import numpy as np
import shapely

from .triangulate import triangulate_polygon

__all__ = ["triangulate_polygon", "mesh_springs", "barycentric", "bind_points", "apply_binding", "triangle_areas"]


def mesh_springs(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edge springs and auxiliary springs of a triangle mesh.

    Returns
    -------
    edges : (E, 2) int32 unique mesh edges (i < j).
    aux : (A, 2) int32, for every interior edge the two vertices opposite it (sec. 5, Fig. 6b).
    """
    tris = np.asarray(tris, dtype=np.int64)
    half = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    opp = np.concatenate([tris[:, 2], tris[:, 0], tris[:, 1]])
    key = np.sort(half, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, opp = key[order], opp[order]
    same = np.all(key[1:] == key[:-1], axis=1)
    edges = np.unique(key, axis=0)
    aux = np.column_stack([opp[:-1][same], opp[1:][same]])
    aux = np.sort(aux, axis=1)
    aux = aux[aux[:, 0] != aux[:, 1]]
    aux = np.unique(aux, axis=0) if len(aux) else aux.reshape(0, 2)
    return edges.astype(np.int32), aux.astype(np.int32)


def _point_segment_dist2(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.einsum("...i,...i->...", p - a, ab) / np.maximum(np.einsum("...i,...i->...", ab, ab), 1e-300)
    t = np.clip(t, 0.0, 1.0)
    q = a + t[..., None] * ab
    return np.einsum("...i,...i->...", p - q, p - q)


def barycentric(points: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of ``points`` (…, 2) w.r.t. triangles (a, b, c) (…, 2) → (…, 3)."""
    v0, v1, v2 = b - a, c - a, points - a
    d00 = np.einsum("...i,...i->...", v0, v0)
    d01 = np.einsum("...i,...i->...", v0, v1)
    d11 = np.einsum("...i,...i->...", v1, v1)
    d20 = np.einsum("...i,...i->...", v2, v0)
    d21 = np.einsum("...i,...i->...", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) < 1e-300, 1e-300, den)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.stack([1.0 - v - w, v, w], axis=-1)


def bind_points(points: np.ndarray, verts: np.ndarray, tris: np.ndarray,
                chunk: int = 2048) -> tuple[np.ndarray, np.ndarray]:
    """Express points in barycentric coordinates of their enclosing or nearest triangle.

    Parameters
    ----------
    points : (P, 2); verts : (N, 2); tris : (T, 3).

    Returns
    -------
    tri_index : (P,) int32 triangle of each point.
    bary : (P, 3) coordinates; sum to 1; all >= 0 (up to rounding) for points inside
        the mesh, extrapolated for points just beyond a border edge.

    A point inside the mesh is bound to the triangle with the largest smallest coordinate
    among those containing it (up to 1e-9), the first of them on a tie; any other point to
    its nearest triangle. The candidates of each point are the triangles whose bounding
    box, slightly widened, holds it (a spatial index): the same choice, and the same
    numbers, as trying every triangle, which only the points outside every triangle need.
    """
    points = np.asarray(points, dtype=float)
    verts = np.asarray(verts, dtype=float)
    tris = np.asarray(tris)
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    if len(points) == 0 or len(tris) == 0:
        return _bind_all(points, a, b, c, chunk)
    out_t = np.empty(len(points), np.int32)
    out_b = np.empty((len(points), 3))
    lo = np.minimum(np.minimum(a, b), c)
    hi = np.maximum(np.maximum(a, b), c)
    # a point outside a triangle by less than 1e-9 of its height still counts as inside:
    # widen every box by far more than that (1e-8 of the mesh's extent)
    pad = 1e-8 * float(np.max(hi.max(axis=0) - lo.min(axis=0)))
    boxes = shapely.box(lo[:, 0] - pad, lo[:, 1] - pad, hi[:, 0] + pad, hi[:, 1] + pad)
    pi, ti = shapely.STRtree(boxes).query(shapely.points(points))
    bc = barycentric(points[pi], a[ti], b[ti], c[ti])
    low = bc.min(axis=1)
    inside = low >= -1e-9
    pi, ti, bc, low = pi[inside], ti[inside], bc[inside], low[inside]
    # per point: the largest smallest coordinate, then the first triangle
    order = np.lexsort((ti, -1.0 - low, pi))
    first = order[np.r_[True, pi[order][1:] != pi[order][:-1]]] if len(order) else order
    out_t[pi[first]] = ti[first]
    out_b[pi[first]] = bc[first]
    rest = np.ones(len(points), bool)
    rest[pi[first]] = False
    if rest.any():  # beyond the border: the nearest of all triangles
        out_t[rest], out_b[rest] = _bind_all(points[rest], a, b, c, chunk)
    return out_t, out_b


def _bind_all(points, a, b, c, chunk):
    """:func:`bind_points` trying every triangle for every point (chunks of ``chunk``
    points)."""
    out_t = np.empty(len(points), np.int32)
    out_b = np.empty((len(points), 3))
    for s in range(0, len(points), chunk):
        p = points[s:s + chunk, None, :]
        bc = barycentric(p, a[None], b[None], c[None])  # (p, T, 3)
        inside = bc.min(axis=2) >= -1e-9
        d2 = np.minimum(np.minimum(_point_segment_dist2(p, a[None], b[None]),
                                   _point_segment_dist2(p, b[None], c[None])),
                        _point_segment_dist2(p, c[None], a[None]))
        # among containing triangles prefer the one with the largest min coordinate
        score = np.where(inside, -1.0 - bc.min(axis=2), d2)
        t = np.argmin(score, axis=1)
        out_t[s:s + chunk] = t
        out_b[s:s + chunk] = bc[np.arange(len(t)), t]
    return out_t, out_b


def triangle_areas(verts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Signed areas of triangles ``tris`` (T, 3) of ``verts`` (N, 2) → (T,): positive for a
    counter-clockwise triangle."""
    p = verts[tris]
    return 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))


def apply_binding(verts: np.ndarray, tris: np.ndarray, tri_index: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Positions of bound points in a (deformed) mesh: Σ_k bary_k · verts[tris[t, k]] → (P, 2)."""
    corners = verts[tris[tri_index]]  # (P, 3, 2)
    return np.einsum("pk,pkd->pd", bary, corners)
