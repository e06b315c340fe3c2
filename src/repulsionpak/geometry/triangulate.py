"""Quality triangulation of a simple polygon whose boundary is kept exactly (sec. 4–5).

The constrained Delaunay triangulation (CDT) comes from ``pythoncdt`` (MPL-2.0). Interior
Steiner points are added by our own Delaunay refinement, in rounds:

1. find the *bad* triangles: smallest angle below ``min_angle`` or area above ``max_area``;
2. give each one a candidate point: its circumcentre, or the closer *off-centre* on the
   bisector of its shortest edge (Üngör 2004), which needs fewer points for the same bound;
3. reject candidates outside the polygon, hidden from their triangle behind the boundary,
   or inside the *diametral lens* of a boundary edge (they would make a sliver with that
   edge, and the boundary may not be split);
4. insert, worst triangle first, the candidates whose *cavities* (the triangles whose
   circumcircle holds the candidate) do not overlap an accepted one, so a round does
   what inserting them one by one in that order would do, at the cost of one CDT;
5. re-triangulate, until no bad triangle has an acceptable candidate.

As with any refinement that may not split the boundary, the bounds can fail next to it:
a triangle on a boundary edge much shorter than its neighbours, or at a corner sharper
than 2·min_angle, may keep a smaller angle, and one on an edge longer than about
sqrt(max_area) a larger area. Skin rings have neither (their samples are about one
spacing apart, max_area is several spacings squared): their meshes meet both bounds.

Cost: every test is local (shapely STRtrees), but each round re-triangulates everything:
a skin of ~100 samples takes 5–9 ms (about 7 rounds); a mesh of 17k vertices ~7 s (42
rounds), where Triangle took milliseconds. Skins that big do not occur in packings.
"""

from __future__ import annotations

import numpy as np
import pythoncdt as cdt
import shapely

#: The off-centre's distance from its edge's midpoint is this × cot(min_angle/2) × edge length
#: (Üngör's off-centre is 0.5; 0.475 gives ~5% fewer Steiner points on the skins of the shipped
#: examples and of the paper's animals at the same minimum angle, 0.45 no fewer).
OFF_CENTRE = 0.475

#: Refinement rounds at most (each inserts many points; the skins need 4–12).
MAX_ROUNDS = 200


def triangulate_polygon(boundary: np.ndarray, max_area: float | None = None,
                        min_angle: float = 20.0, interior: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Constrained quality triangulation of a simple polygon.

    Parameters
    ----------
    boundary : (K, 2) vertices of a simple polygon (no repeated closing vertex), either
        orientation.
    max_area : largest triangle area allowed (None: no limit).
    min_angle : smallest triangle angle aimed at, degrees (0 < min_angle <= 34).
    interior : allow Steiner points inside the polygon (never on its boundary).

    Returns
    -------
    verts : (N, 2), the first K rows are ``boundary`` unchanged and in order.
    tris : (T, 3) int32 vertex indices, counter-clockwise (y up), every triangle inside
        the polygon, every vertex used.

    Raises
    ------
    ValueError : fewer than 3 vertices, zero area, repeated vertices or crossing edges.
    """
    boundary = np.asarray(boundary, dtype=float)
    if boundary.ndim != 2 or boundary.shape[1] != 2 or len(boundary) < 3:
        raise ValueError("boundary must be a (K>=3, 2) array")
    if not np.isfinite(boundary).all():
        raise ValueError("boundary has non-finite coordinates")
    if not 0.0 < min_angle <= 34.0:
        raise ValueError(f"min_angle must be in (0, 34] degrees, got {min_angle:g}")
    if max_area is not None and not max_area > 0:
        raise ValueError(f"max_area must be positive, got {max_area:g}")
    k = len(boundary)
    # work in normalised coordinates: the polygon spans about [-0.5, 0.5]
    centre = boundary.mean(axis=0)
    size = float(np.ptp(boundary, axis=0).max())
    if not size > 0:
        raise ValueError("boundary has zero extent")
    pts = (boundary - centre) / size
    tris = _cdt(pts, k)
    if interior:
        amax = np.inf if max_area is None else max_area / size ** 2
        pts, tris = _refine(pts, tris, k, np.radians(min_angle), amax)
    verts = pts * size + centre
    verts[:k] = boundary  # exactly the input boundary
    return np.ascontiguousarray(verts), np.ascontiguousarray(tris.astype(np.int32))


def _cdt(pts: np.ndarray, k: int) -> np.ndarray:
    """(T, 3) int64 CDT of ``pts`` constrained by the ring ``pts[:k]``, inside triangles
    only, counter-clockwise."""
    t = cdt.Triangulation(cdt.VertexInsertionOrder.AS_PROVIDED,
                          cdt.IntersectingConstraintEdges.NOT_ALLOWED, 0.0)
    ring = np.arange(k, dtype=np.uintc)
    try:
        t.insert_vertices(np.ascontiguousarray(pts, dtype=float))
        t.insert_edges(np.column_stack([ring, np.roll(ring, -1)]))
        t.erase_outer_triangles_and_holes()
    except RuntimeError as e:  # duplicate vertices, crossing edges
        raise ValueError(f"the boundary is not a simple polygon: {str(e).splitlines()[0]}") from None
    if t.vertices_count() != len(pts):
        raise ValueError("the triangulation changed the vertex set (degenerate boundary)")
    tris = t.triangles_array()["vertices"].astype(np.int64)
    if len(tris) == 0:
        raise ValueError("the boundary encloses no area")
    cross = _cross(pts, tris)
    tris = tris[cross != 0.0]
    flip = cross[cross != 0.0] < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]
    return tris


def _cross(pts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def min_angles(pts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """(T,) smallest angle of each triangle, radians (the angle opposite its shortest edge)."""
    pts = np.asarray(pts, dtype=float)
    tris = np.asarray(tris)
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    l2 = np.stack([((c - b) ** 2).sum(1), ((a - c) ** 2).sum(1), ((b - a) ** 2).sum(1)], axis=1)
    j = np.argmin(l2, axis=1)
    others = np.sqrt(np.prod(l2, axis=1) / np.maximum(l2[np.arange(len(tris)), j], 1e-300))
    return np.arcsin(np.clip(np.abs(_cross(pts, tris)) / np.maximum(others, 1e-300), 0.0, 1.0))


def _refine(pts: np.ndarray, tris: np.ndarray, k: int, theta: float,
            amax: float) -> tuple[np.ndarray, np.ndarray]:
    ring_a, ring_b = pts[:k], np.roll(pts[:k], -1, axis=0)
    poly = shapely.Polygon(pts[:k])
    shapely.prepare(poly)
    # boundary edges indexed by their diametral disc's box (it holds the lens) and by
    # their own box (for the visibility test): every test below is local
    mid, half = 0.5 * (ring_a + ring_b), 0.5 * np.hypot(*(ring_b - ring_a).T)
    lens_tree = shapely.STRtree(_boxes(mid - half[:, None], mid + half[:, None]))
    edge_tree = shapely.STRtree(_boxes(np.minimum(ring_a, ring_b), np.maximum(ring_a, ring_b)))
    off = OFF_CENTRE / np.tan(theta / 2)
    cos_lens = np.cos(np.pi - 2 * theta)  # apex angles above π − 2θ leave a base angle < θ
    for _ in range(MAX_ROUNDS):
        q = min_angles(pts, tris)
        area = 0.5 * _cross(pts, tris)
        bad = np.flatnonzero((q < theta) | (area > amax))
        if len(bad) == 0:
            break
        cc, r2 = _circumcircles(pts, tris)
        cand = _off_centres(pts, tris[bad], cc[bad], off)
        ok = shapely.contains_xy(poly, cand[:, 0], cand[:, 1])
        ok &= ~_in_lens(cand, ring_a, ring_b, cos_lens, lens_tree)
        # seen from its triangle: a vertex it could coincide with would be a vertex in the
        # triangle's circumcircle, and only vertices hidden behind the boundary can be
        ok &= ~_crosses(pts[tris[bad]].mean(axis=1), cand, ring_a, ring_b, edge_tree)
        near = shapely.STRtree(shapely.points(pts)).query_nearest(
            shapely.points(cand), return_distance=True, all_matches=False)[1]
        ok &= near > 1e-10
        if not ok.any():
            break
        bad, cand = bad[ok], cand[ok]
        cavities = _cavities(cand, bad, cc, r2)
        taken = np.zeros(len(tris), bool)
        accept = []
        for i in np.argsort(q[bad], kind="stable"):  # worst first
            if not taken[cavities[i]].any():
                accept.append(i)
                taken[cavities[i]] = True
        pts = np.vstack([pts, cand[accept]])
        tris = _cdt(pts, k)
    return pts, tris


def _boxes(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1])


def _cavities(cand: np.ndarray, own: np.ndarray, cc: np.ndarray, r2: np.ndarray) -> list[np.ndarray]:
    """For each candidate, the triangles whose circumcircle holds it, and its own."""
    r = np.sqrt(r2)
    ci, ti = shapely.STRtree(_boxes(cc - r[:, None], cc + r[:, None])).query(shapely.points(cand))
    inside = ((cand[ci] - cc[ti]) ** 2).sum(axis=1) < r2[ti] * (1 - 1e-12)
    ci = np.concatenate([ci[inside], np.arange(len(cand))])
    ti = np.concatenate([ti[inside], own])
    order = np.argsort(ci, kind="stable")
    ci, ti = ci[order], ti[order]
    return np.split(ti, np.searchsorted(ci, np.arange(1, len(cand))))


def _circumcircles(pts: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Circumcentres (T, 2) and squared radii (T,)."""
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    bx, by = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    cx, cy = c[:, 0] - a[:, 0], c[:, 1] - a[:, 1]
    d = 2.0 * (bx * cy - by * cx)
    b2, c2 = bx * bx + by * by, cx * cx + cy * cy
    ux, uy = (cy * b2 - by * c2) / d, (bx * c2 - cx * b2) / d
    return np.column_stack([ux + a[:, 0], uy + a[:, 1]]), ux * ux + uy * uy


def _off_centres(pts: np.ndarray, tris: np.ndarray, cc: np.ndarray, off: float) -> np.ndarray:
    """The point on the bisector of each triangle's shortest edge at ``off`` × its length
    from the edge, or the circumcentre when that is closer."""
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    l2 = np.stack([((c - b) ** 2).sum(1), ((a - c) ** 2).sum(1), ((b - a) ** 2).sum(1)], axis=1)
    j = np.argmin(l2, axis=1)
    r = np.arange(len(tris))
    p, q = pts[tris[r, (j + 1) % 3]], pts[tris[r, (j + 2) % 3]]
    mid = 0.5 * (p + q)
    h = off * np.sqrt(l2[r, j])
    to_cc = cc - mid
    dist = np.hypot(to_cc[:, 0], to_cc[:, 1])
    closer = h < dist
    oc = mid + to_cc * (h / np.maximum(dist, 1e-300))[:, None]
    return np.where(closer[:, None], oc, cc)


def _in_lens(p: np.ndarray, a: np.ndarray, b: np.ndarray, cos_lens: float,
             tree: shapely.STRtree) -> np.ndarray:
    """(P,) whether a boundary edge a–b is seen from p under an angle above the lens
    angle (only edges whose diametral disc's box holds p can be)."""
    pi, ei = tree.query(shapely.points(p))
    pa, pb = a[ei] - p[pi], b[ei] - p[pi]
    dot = (pa * pb).sum(axis=1)
    norm = np.sqrt((pa * pa).sum(axis=1) * (pb * pb).sum(axis=1))
    out = np.zeros(len(p), bool)
    out[pi[dot < cos_lens * norm]] = True
    return out


def _crosses(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray,
             tree: shapely.STRtree) -> np.ndarray:
    """(P,) whether segment p–q properly crosses any boundary edge a–b."""
    def orient(u, v, w):
        return (v[:, 0] - u[:, 0]) * (w[:, 1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (w[:, 0] - u[:, 0])
    si, ei = tree.query(_boxes(np.minimum(p, q), np.maximum(p, q)))
    pp, qq, aa, bb = p[si], q[si], a[ei], b[ei]
    hit = (orient(pp, qq, aa) * orient(pp, qq, bb) < 0) & (orient(aa, bb, pp) * orient(aa, bb, qq) < 0)
    out = np.zeros(len(p), bool)
    out[si[hit]] = True
    return out
