"""What holds of a packing's promises, measured on the exact art: the checks of the repair.

The promises, on each element's art polygons: no two elements' art overlap; every
element's art lies inside the container, at least ``margin`` from its edge; every
element's art is at least ``min_gap`` from every other element's art.

* :class:`Verification` – what the final check found (the report's ``verification``).
* :func:`_check` – for each element, how far it must get away from what it is too close
  to (``need``), the direction of a move that would do it (``push``) and the share of
  its size it would lose shrinking instead (``rel``), with counts of each violation.
* :func:`_shrink_centre` – the point an element clears its contacts best by shrinking
  about: its centroid, or a point of its outline or its pole when that needs clearly
  less shrink (a thin part pressed sideways, a bent element whose centroid lies off it).
* :func:`distortion` – the symmetric difference of two art geometries over the first's area.

The repairs that act on these measures are in :mod:`repulsionpak.verify.repairs`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.ops import polylabel

from ..geometry.edges import Edges
from ..geometry.pairwise import distances, near_pairs
from ..geometry.robust import overlay

__all__ = ["Verification", "distortion"]


@dataclass(frozen=True)
class Verification:
    """Result of :func:`~repulsionpak.verify.verify_and_repair` (lengths in container units)."""

    ok: bool  # every promise holds on the returned art
    overlap_pairs: int  # pairs of elements whose art overlaps
    outside: int  # elements with art outside the container
    margin_violations: int  # elements closer than margin (minus tolerance) to the edge
    gap_violations: int  # elements closer than min_gap (minus tolerance) to another
    min_gap: float  # the gap floor enforced
    margin: float  # the edge margin enforced
    min_distance: float | None  # smallest art–art distance found
    min_edge_distance: float | None  # smallest art–edge distance found (negative: outside)
    shrunk: dict = field(default_factory=dict)  # element index -> scale applied (moved, shrunk or grown)
    dropped: list = field(default_factory=list)  # (index, source) of dropped elements
    straightened: list = field(default_factory=list)  # elements replaced by their unbent copy

    def to_dict(self) -> dict:
        return {"ok": self.ok, "overlap_pairs": self.overlap_pairs, "outside": self.outside,
                "margin_violations": self.margin_violations, "gap_violations": self.gap_violations,
                "min_gap": self.min_gap, "margin": self.margin, "min_distance": self.min_distance,
                "min_edge_distance": self.min_edge_distance,
                "shrunk": {str(k): v for k, v in sorted(self.shrunk.items())},
                "dropped": [{"index": i, "source": s} for i, s in self.dropped],
                "straightened": list(self.straightened)}


def distortion(art, copy) -> float:
    """Area of the symmetric difference of two art geometries over the first's area."""
    if art.is_empty or art.area <= 0:
        return 0.0
    return float(overlay(shapely.symmetric_difference, art, copy).area / art.area)


def _edge_distance(edges: Edges, region, g) -> float:
    """Distance from ``g`` to the container's edge (``edges``, the boundary of
    ``region``); negative when ``g`` is not inside: minus the depth of its deepest point
    outside."""
    if shapely.contains(region, g):
        return edges.distance(g)
    out = shapely.get_coordinates(overlay(shapely.difference, g, region))
    if len(out) == 0:
        return 0.0
    return -float(np.max(edges.distance(shapely.points(out))))


def _edge_poke(boundary, g, margin: float):
    """Where the container's edge reaches deepest into the art ``g`` (a reflex corner of
    the container inside it, or the middle of an edge it crosses): ``(p, u, depth)``, p
    the art's outline point nearest that edge point, u the way from p to it (the way the
    art must move), depth their distance; None when the edge reaches less than a
    hundredth of ``margin`` into it."""
    inside = overlay(shapely.intersection, boundary, g)
    if inside.is_empty:
        return None
    pts = shapely.points(shapely.get_coordinates(shapely.segmentize(inside, max(margin, 1e-12))))
    depth = shapely.distance(g.boundary, pts)
    k = int(np.argmax(depth))
    if depth[k] <= 0.01 * margin:
        return None
    line = np.asarray(shapely.get_coordinates(shapely.shortest_line(g.boundary, pts[k])))
    return line[0], line[1] - line[0], float(depth[k])


def _thickness(g) -> float:
    """Width of an overlap (the shorter side of its minimum rotated rectangle): how far
    the two elements must move apart to clear it (cheap; exact for a lens or a strip)."""
    if g.is_empty or g.area <= 0:
        return 0.0
    c = np.asarray(shapely.get_coordinates(shapely.minimum_rotated_rectangle(g)))
    if len(c) < 4:
        return 0.0
    return float(min(np.hypot(*(c[1] - c[0])), np.hypot(*(c[2] - c[1]))))


def _centre(g) -> np.ndarray:
    return np.asarray(shapely.get_coordinates(shapely.centroid(g)))[0]


def _pair_distances(ga: np.ndarray, gb: np.ndarray, memo: dict | None) -> np.ndarray:
    """``shapely.distance(ga, gb)``, reusing the distances ``memo`` holds for the same two
    geometry objects (a repair round moves or shrinks a few copies; the pairs of the others
    keep their distances). ``memo`` maps ``(id(a), id(b))`` to ``(a, b, distance)``: it
    holds the geometries, so their ids are not reused while it lives."""
    if memo is None or not len(ga):
        return distances(ga, gb) if len(ga) else np.zeros(0)
    d = np.empty(len(ga))
    todo = []
    for k, (a, b) in enumerate(zip(ga, gb)):
        hit = memo.get((id(a), id(b)))
        if hit is not None and hit[0] is a and hit[1] is b:
            d[k] = hit[2]
        else:
            todo.append(k)
    if todo:
        todo = np.asarray(todo)
        d[todo] = distances(ga[todo], gb[todo])
        for k in todo.tolist():
            memo[(id(ga[k]), id(gb[k]))] = (ga[k], gb[k], float(d[k]))
    return d


def _kept(shapes: dict | None, key: tuple, objs: tuple, make):
    """``make()``, kept in ``shapes`` under ``key`` (the ids of the objects ``objs`` it is
    made of) when ``shapes`` is given. The entry holds ``objs``, so their ids are not
    reused while ``shapes`` lives: a repair round replaces the geometry of the few copies
    it moves; what is made of the others' geometry is made once."""
    if shapes is None:
        return make()
    hit = shapes.get(key)
    if hit is None:
        hit = shapes[key] = (objs, make())
    return hit[1]


@dataclass(frozen=True)
class Rough:
    """Outlines ``geoms`` that each lie within ``err[i]`` of the outline they stand for
    (Hausdorff distance of the regions: every point of either is within ``err[i]`` of the
    other), with a memo of their pair distances (:func:`_pair_distances`): a lower bound
    of the distance of two exact outlines, cheaper to measure. Indices are the elements'."""

    geoms: list
    err: np.ndarray
    memo: dict | None = None

    def maybe_within(self, i: np.ndarray, j: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
        """The pairs (``i[k]``, ``j[k]``) whose exact outlines may be within ``reach``:
        their rough distance less twice their error bounds (a margin for rounding) is not
        beyond it."""
        if not len(i):
            return i, j
        g = np.empty(len(self.geoms), dtype=object)
        g[:] = self.geoms
        d = _pair_distances(g[i], g[j], self.memo)
        keep = ~(d - 2.0 * (self.err[i] + self.err[j]) > reach)
        return i[keep], j[keep]


def _check(geoms, alive, region, edges, min_gap, margin, tol, inner=None, exact_edges=False,
           fixed=None, rank=None, contacts=None, weak=None, memo=None, rough=None, shapes=None):
    """What each element needs to meet the promises: ``need[i]`` how far (container
    units) its art must get away from what it is too close to, ``push[i]`` the summed
    directions (weighted by deficit) of a move that would do it, and ``rel[i]`` the
    share of its size it must lose if it is shrunk about its centroid instead (of a pair
    too close, the smaller one shrinks). Also counts of each kind of violation and the
    smallest art–art and art–edge distances seen (the latter only over the elements that
    are not clearly inside ``inner``, the container shrunk by the margin, unless
    ``exact_edges``). ``fixed[i]`` (pinned copies): element i never moves nor shrinks;
    its neighbours take the whole of a pair's deficit. ``rank[i]``: of a pair too close,
    the element of lower rank (a secondary next to a primary) takes the whole deficit:
    pocket fillers give way, never the elements they fill around. ``weak[i]``: element i
    has shrunk half-way to being dropped; of a pair of equal rank, the other one shrinks
    instead of it (the smaller of two would otherwise shrink every time, to nothing).
    ``contacts`` (a dict, filled when given): for each element that is to shrink, the
    contacts that set its ``rel`` as (point, unit direction away from what it is too
    close to, distance to gain, measured: True for a shortest line between art a gap
    apart or art and edge, False for an overlap or art outside, whose point and direction
    are estimates), from which :func:`_shrink_centre` predicts the shrink about other
    points. ``memo`` (a dict): pair distances kept between calls (:func:`_pair_distances`).
    ``rough`` (:class:`Rough`): cheaper outlines within a known distance of ``geoms``;
    pairs whose rough distance shows them farther apart than ``min_gap`` are not measured
    on ``geoms`` (the result is the same: only pairs closer than ``min_gap`` count).
    ``shapes`` (a dict): what is measured of each geometry object and pair of them
    (centroid, convex hull, shrink candidates, shortest line), kept between calls
    (:func:`_kept`)."""
    n = len(geoms)
    need = np.zeros(n)
    rel = np.zeros(n)
    push = np.zeros((n, 2))
    counts = {"overlap_pairs": 0, "outside": 0, "margin": 0, "gap": 0}
    dmin, emin = np.inf, np.inf
    idx = np.flatnonzero(alive)
    arr = np.array([geoms[i] for i in idx], dtype=object)
    centres: dict = {}

    def centre(i):
        if i not in centres:
            g = geoms[i]
            centres[i] = _kept(shapes, ("centre", id(g)), (g,), lambda: _centre(g))
        return centres[i]

    shrink_points: dict = {}  # an element too close to several others: its candidates once

    def cost(i, p, u, total):
        if i not in shrink_points:
            g = geoms[i]
            shrink_points[i] = _kept(shapes, ("shrink", id(g)), (g,),
                                     lambda: (_shrink_candidates(g, centre(i), SHRINK_POINTS), float(g.area)))
        return _shrink_cost(*shrink_points[i], p, u, total)

    def hull(g):
        return _kept(shapes, ("hull", id(g)), (g,), lambda: g.convex_hull)

    if len(idx) >= 2:
        a, b = near_pairs(arr, np.arange(len(arr)), min_gap)
        keep = a < b
        a, b = a[keep], b[keep]
        if rough is not None:
            a, b = rough.maybe_within(idx[a], idx[b], min_gap)
            a, b = np.searchsorted(idx, a), np.searchsorted(idx, b)
        d = _pair_distances(arr[a], arr[b], memo)
        close = d <= min_gap  # what a dwithin query would have found
        a, b, d = a[close], b[close], d[close]
        if len(d):
            dmin = float(d.min())
        for p, q, dd in zip(a, b, d):
            if dd >= min_gap - tol:
                continue
            i, j = int(idx[p]), int(idx[q])
            gi, gj = geoms[i], geoms[j]
            counts["gap"] += 1
            if dd <= 0.0:
                counts["overlap_pairs"] += 1
                inter = overlay(shapely.intersection, gi, gj)
                depth = _thickness(inter)
                total = min_gap + depth + 2 * tol
                pi = pj = _centre(inter) if not inter.is_empty else 0.5 * (centre(i) + centre(j))
                u = centre(i) - centre(j)
            else:
                line = _kept(shapes, ("line", id(gi), id(gj)), (gi, gj),
                             lambda: np.asarray(shapely.shortest_line(gi, gj).coords))
                pi, pj = line[0], line[1]
                total = min_gap - dd + 2 * tol
                u = pi - pj
            nu = float(np.hypot(*u))
            fi = fixed is not None and bool(fixed[i])
            fj = fixed is not None and bool(fixed[j])
            ri = 0 if rank is None else int(rank[i])
            rj = 0 if rank is None else int(rank[j])
            if fi or fj or ri != rj:
                if fi and fj:
                    continue  # two pins: the designer's choice, reported, not repaired
                if fi or (not fj and ri > rj):  # j takes it all
                    i, j, gi, gj, pi, pj, u = j, i, gj, gi, pj, pi, -u
                if nu > 0:
                    push[i] += total * u / nu
                need[i] = max(need[i], total)
                rho = float(np.hypot(*(pi - centre(i))))
                rel[i] = max(rel[i], total / rho if rho > 0 else 0.05)
                if contacts is not None and nu > 0:
                    contacts.setdefault(i, []).append((pi, u / nu, total, dd > 0.0))
                continue
            if nu > 0:
                push[i] += 0.5 * total * u / nu
                push[j] -= 0.5 * total * u / nu
            need[i] = max(need[i], 0.5 * total)
            need[j] = max(need[j], 0.5 * total)
            def i_shrinks():
                # one of the two shrinks: the one poking into the other's hollow (its contact
                # lies in the other's convex hull: shrinking the hollow's owner would close the
                # hollow further), else the smaller one
                in_i = hull(gj).contains(shapely.points(pi))
                in_j = hull(gi).contains(shapely.points(pj))
                if in_i != in_j:
                    return in_i
                if nu > 0:
                    # the one that loses less art shrinking about its best point: a thin
                    # part poking into a neighbour's body comes out of it when its owner
                    # shrinks a little about a far point, while the body would have to shrink
                    # by the whole depth about any of its points (a penguin's tail through
                    # the heart's snake: the snake shrank to 0.67 of its size)
                    ci = cost(i, pi, u / nu, total)
                    cj = cost(j, pj, -u / nu, total)
                    if ci == cj:  # both hopeless (no point moves the contact away): the smaller shrinks
                        ci, cj = gi.area, gj.area
                    return ci <= cj
                return gi.area <= gj.area

            # (a function of the two outlines and the floor: made once for a pair that stays)
            first = _kept(shapes, ("shrinks", id(gi), id(gj), min_gap, tol), (gi, gj), i_shrinks)
            k, pk = (i, pi) if first else (j, pj)
            if weak is not None and weak[k] and not weak[i + j - k]:
                k, pk = (j, pj) if k == i else (i, pi)
            rho = float(np.hypot(*(pk - centre(k))))
            rel[k] = max(rel[k], total / rho if rho > 0 else 0.05)
            if contacts is not None and nu > 0:
                contacts.setdefault(k, []).append((pk, (u if k == i else -u) / nu, total, dd > 0.0))
    if exact_edges or inner is None:
        near = idx
    else:
        near = idx[~shapely.contains(inner, arr)] if len(idx) else idx
    for i in near:
        i = int(i)
        g = geoms[i]
        e = _edge_distance(edges, region, g)
        emin = min(emin, e)
        if e >= margin - tol:
            continue
        if e < 0:
            counts["outside"] += 1
        counts["margin"] += 1
        if fixed is not None and fixed[i]:
            continue  # a pin placed there by the designer: reported, not repaired
        deficit = margin - e + tol
        c = centre(i)
        if e >= 0:
            line = np.asarray(edges.shortest_line(g).coords)
            pt, u = line[0], line[0] - line[1]
        else:  # the art's point farthest outside
            coords = np.asarray(shapely.get_coordinates(overlay(shapely.difference, g, region)))
            pt = coords[np.argmax(((coords - c) ** 2).sum(axis=1))]
            u = c - pt
            # unless the container's edge pokes into the art (a reflex corner: the heart's
            # cleft into its snake): then the art must move off the edge's deepest point,
            # from the art's outline nearest that point towards it, by its depth and the
            # margin. (Towards the centroid is along a long element poked into sideways:
            # the snake shrank four rounds for nothing before a shrink about a better
            # point, to 0.665 in all, and the margin's deficit measured from the art's
            # points outside missed the corner's depth in the art.)
            poke = _edge_poke(edges.boundary, g, margin)
            if poke is not None:
                pt, u, depth = poke
                deficit = max(deficit, depth + margin + tol)
        nu = float(np.hypot(*u))
        if nu > 0:
            push[i] += deficit * u / nu
        need[i] = max(need[i], deficit)
        rho = float(np.hypot(*(pt - c)))
        rel[i] = max(rel[i], deficit / rho if rho > 0 else 0.05)
        if contacts is not None and nu > 0:
            contacts.setdefault(i, []).append((pt, u / nu, deficit, e >= 0))
    return (need, rel, push, counts, (None if not np.isfinite(dmin) else dmin),
            (None if not np.isfinite(emin) else emin))


#: outline vertices an element may shrink about, besides its centroid (and pole)
SHRINK_POINTS = 64


def _shrink_candidates(g, centroid: np.ndarray, max_points: int) -> np.ndarray:
    """Points an element may shrink about: its centroid (first) and at most
    ``max_points`` of its outline's vertices, evenly taken."""
    xy = np.asarray(shapely.get_coordinates(g), dtype=float)
    xy = xy[::max(1, -(-len(xy) // max_points))]
    return np.concatenate([np.asarray(centroid, dtype=float)[None, :], xy])


def _shrink_cost(cands: np.ndarray, area: float, p: np.ndarray, u: np.ndarray, total: float) -> float:
    """The art area an element of ``area`` loses when it shrinks about its best point of
    ``cands`` (:func:`_shrink_candidates`: those of :func:`_shrink_centre`, without its
    pole) to take the contact at ``p`` ``total`` away along ``u``: area × (1 − (1 − r)²)
    for the predicted relative shrink r (infinite when no point moves the contact away)."""
    r = float(_predicted_shrink(cands, [(p, u, total, True)]).min())
    if not np.isfinite(r) or r >= 1.0:
        return np.inf
    return area * (1.0 - (1.0 - r) ** 2)


def _predicted_shrink(cands: np.ndarray, contacts: list) -> np.ndarray:
    """For each candidate centre c (rows of ``cands``), the relative shrink about c that
    takes every contact (p, û, total, measured) its ``total`` away along û: shrinking by f about c
    moves p by (1 − f)(c − p), so it is the largest total / ((c − p)·û); infinite where
    a contact would not move away at all."""
    p = np.array([q[0] for q in contacts], dtype=float)
    u = np.array([q[1] for q in contacts], dtype=float)
    t = np.array([q[2] for q in contacts], dtype=float)
    proj = ((cands[:, None, :] - p[None, :, :]) * u[None, :, :]).sum(axis=2)
    r = np.full(proj.shape, np.inf)
    ok = proj > 0
    r[ok] = np.broadcast_to(t, proj.shape)[ok] / proj[ok]
    return r.max(axis=1)


def _shrink_centre(g, centroid: np.ndarray, contacts: list | None, prefer: float = 1.25,
                   max_points: int = SHRINK_POINTS) -> tuple[np.ndarray, float | None]:
    """The point an element (current geometry ``g``) should shrink about to clear its
    ``contacts`` (see :func:`_check`), and the relative shrink predicted there; ``None``
    for the latter: its centroid (shrink by ``rel``). Shrinking about the centroid moves a contact
    away only if the centroid lies beyond it, seen from what it is too close to: not so
    for a curled or bent element whose centroid lies in its hollow or off its body (the
    centroid then pulls the body towards its neighbour), and it gains little for a thin
    part pressed sideways (the contact's direction nearly perpendicular to the radius).
    Candidates: the centroid, the vertices of ``g`` (at most ``max_points``) and the pole
    of inaccessibility of its largest part; the centroid is kept when its prediction is
    within ``prefer`` of the best, and also, when a contact is an overlap or lies
    outside (point and direction estimated, not measured), whenever it lies on the
    element and moves every contact away."""
    if not contacts or g.is_empty:
        return centroid, None
    cands = [_shrink_candidates(g, centroid, max_points)]
    part = max(getattr(g, "geoms", [g]), key=lambda q: q.area)
    if part.geom_type == "Polygon" and part.area > 0:
        pole = polylabel(part, tolerance=0.01 * float(np.sqrt(part.area)))
        cands.append(np.array([[pole.x, pole.y]]))
    cands = np.concatenate(cands)
    pred = _predicted_shrink(cands, contacts)
    best = int(np.argmin(pred))
    measured = all(q[3] for q in contacts)
    if np.isfinite(pred[0]) and (pred[0] <= prefer * pred[best]
                                 or (not measured and shapely.covers(g, shapely.points(cands[0])))):
        return centroid, None
    if not np.isfinite(pred[best]):
        return centroid, None
    return cands[best], float(pred[best])


def _nearest(geoms, everyone, bounds, i, reach, memo):
    """(distance, index) of the element of ``everyone`` nearest to ``i`` among those whose
    bounding boxes come within ``reach`` of its box; (inf, -1) when there is none. Pairs
    neither of which moved since they were measured come from ``memo``
    (:func:`_pair_distances`)."""
    b = bounds[np.searchsorted(everyone, i)]
    near = ((bounds[:, 0] <= b[2] + reach) & (bounds[:, 2] >= b[0] - reach)
            & (bounds[:, 1] <= b[3] + reach) & (bounds[:, 3] >= b[1] - reach) & (everyone != i))
    js = everyone[near]
    if not len(js):
        return np.inf, -1
    gi = np.empty(len(js), dtype=object)
    gi[:] = [geoms[i]] * len(js)
    d = _pair_distances(gi, np.array([geoms[j] for j in js], dtype=object), memo)
    k = int(np.argmin(d))
    return float(d[k]), int(js[k])
