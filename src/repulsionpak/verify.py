"""Final verification of a packing's promises on the art itself, and its repair.

The simulation works on meshes and skins; what a user gets is the art mapped through
them. Whatever the simulation left, :func:`verify_and_repair` checks the promises on the
exact art polygons of every element:

* no two elements' art overlap;
* every element's art lies inside the container, at least ``margin`` from its edge;
* every element's art is at least ``min_gap`` from every other element's art.

An element that breaks one of them is first *moved* away from what it is too close to
(local separation, a few rounds: a moved element may make room for, or crowd, its
neighbours), then *shrunk* by just enough (both are similarities: its shape is untouched)
about its own centroid, or about the point of it that moves its contacts away with
clearly less shrink (a thin part pressed sideways, a bent or curled element whose centroid
lies off its body: :func:`_shrink_centre`). Of two primaries too close, the smaller one
shrinks, until it has shrunk half-way to ``min_scale``: then the other one does. An
element that would have to shrink below ``min_scale`` (half that for secondary elements,
which are small by nature) is dropped, with a warning naming it. What remains is verified once more and reported; the CLI exits
non-zero if anything is still violated (on valid input it never is).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.ops import polylabel

from .geometry.outline import _polygonal
from .geometry.robust import overlay
from .render.placed import refined, similarity_matrix
from .types import PlacedArt


@dataclass(frozen=True)
class Verification:
    """Result of :func:`verify_and_repair` (lengths in container units)."""

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


def scaled_art(placed: PlacedArt, scale: float, centre: np.ndarray,
               shift: np.ndarray = np.zeros(2), angle: float = 0.0) -> PlacedArt:
    """``placed`` scaled by ``scale`` and turned by ``angle`` (radians, x towards y) about
    ``centre`` (strokes scaled with it), then moved by ``shift``."""
    c = np.asarray(centre, dtype=float)
    t = c + np.asarray(shift, dtype=float)
    r = scale * np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    if angle:
        def f(pts):
            return t + (np.asarray(pts) - c) @ r.T
    else:  # (unturned copies keep exactly the coordinates a plain scaling gives)
        def f(pts):
            return t + (np.asarray(pts) - c) * scale
    paths = tuple(p.transformed(f) for p in placed.paths)
    frame = placed.frame
    if frame is not None:  # the same similarity, as a matrix
        m = np.eye(3)
        m[:2, :2] = r
        m[:2, 2] = t - r @ c
        frame = m @ frame
    return dataclasses.replace(placed, paths=paths, stroke_scale=placed.stroke_scale * scale, frame=frame)


def similar_copy(rest: PlacedArt, placed: PlacedArt) -> PlacedArt:
    """The undeformed art ``rest`` moved, turned and scaled onto ``placed`` (least squares
    over their corresponding vertices, or the meshes' similarity ``frame`` when both carry
    one — rendered curves have no vertex correspondence): what the element would look like
    unbent."""
    extra = {}
    if placed.frame is not None and rest.frame is not None:
        m = np.asarray(placed.frame, dtype=float) @ np.linalg.inv(np.asarray(rest.frame, dtype=float))
        extra["frame"] = m @ np.asarray(rest.frame, dtype=float)
    else:
        src = np.concatenate([p for a in rest.paths for p in a.subpaths])
        cur = np.concatenate([p for a in placed.paths for p in a.subpaths])
        m = similarity_matrix(src, cur)
    rot, b = m[:2, :2], m[:2, 2]
    paths = tuple(p.transformed(lambda pts: np.asarray(pts) @ rot.T + b) for p in rest.paths)
    k = float(np.sqrt(abs(np.linalg.det(rot))))
    return dataclasses.replace(placed, paths=paths, stroke_scale=rest.stroke_scale * k, deformation=0.0, **extra)


def distortion(art, copy) -> float:
    """Area of the symmetric difference of two art geometries over the first's area."""
    if art.is_empty or art.area <= 0:
        return 0.0
    return float(overlay(shapely.symmetric_difference, art, copy).area / art.area)


def straighten(placed: list[PlacedArt], rest: list[PlacedArt], limits: np.ndarray
               ) -> tuple[list[PlacedArt], np.ndarray, list[int]]:
    """Keep shapes: an element whose distortion (symmetric difference with its unbent,
    similar copy, over its area) exceeds ``limits[i]`` is replaced by that copy (the
    repair that follows makes room for it). Returns (art, distortion of each element as
    it is returned, indices replaced). A copy's curves are flattened as the placed art's
    were (:func:`refined` at its tolerance), so that the repair measures what is written."""
    out, dist, replaced = [], np.zeros(len(placed)), []
    for i, (p, r) in enumerate(zip(placed, rest)):
        copy = similar_copy(r, p)
        d = distortion(p.art, copy.art)
        if d > limits[i]:
            out.append(dataclasses.replace(copy, paths=tuple(refined(a, p.tolerance) for a in copy.paths)))
            replaced.append(i)
            d = 0.0
        else:
            out.append(p)
        dist[i] = d
    return out, dist, replaced


def _edge_distance(region_boundary, region, g) -> float:
    """Distance from ``g`` to the container's edge; negative when ``g`` is not inside:
    minus the depth of its deepest point outside."""
    if shapely.contains(region, g):
        return float(shapely.distance(region_boundary, g))
    out = shapely.get_coordinates(overlay(shapely.difference, g, region))
    if len(out) == 0:
        return 0.0
    return -float(np.max(shapely.distance(region_boundary, shapely.points(out))))


def _moved(g, scale: float, angle: float, centre, dx: float, dy: float):
    """Outline ``g`` scaled by ``scale`` and turned by ``angle`` (radians) about ``centre``,
    then moved by (dx, dy): the similarity the repair, the growth and the gathering apply
    (:func:`scaled_art` applies it to the art)."""
    g = shapely.affinity.scale(g, scale, scale, origin=tuple(centre))
    if angle:
        g = shapely.affinity.rotate(g, angle, origin=tuple(centre), use_radians=True)
    return shapely.affinity.translate(g, dx, dy)


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


def _near_pairs(arr: np.ndarray, which: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (k, j): ``arr[which[k]]``'s bounding box, widened by ``reach``, meets
    ``arr[j]``'s — every pair closer than ``reach``, and some farther ones. Callers measure
    the distance of each pair anyway; an STRtree ``dwithin`` query would measure it
    twice (its exact test costs as much as the distance itself)."""
    lo = shapely.bounds(arr[which])
    boxes = shapely.box(lo[:, 0] - reach, lo[:, 1] - reach, lo[:, 2] + reach, lo[:, 3] + reach)
    return shapely.STRtree(arr).query(boxes)


def _pair_distances(ga: np.ndarray, gb: np.ndarray, memo: dict | None) -> np.ndarray:
    """``shapely.distance(ga, gb)``, reusing the distances ``memo`` holds for the same two
    geometry objects (a repair round moves or shrinks a few copies; the pairs of the others
    keep their distances). ``memo`` maps ``(id(a), id(b))`` to ``(a, b, distance)``: it
    holds the geometries, so their ids are not reused while it lives."""
    if memo is None or not len(ga):
        return shapely.distance(ga, gb) if len(ga) else np.zeros(0)
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
        d[todo] = shapely.distance(ga[todo], gb[todo])
        for k in todo.tolist():
            memo[(id(ga[k]), id(gb[k]))] = (ga[k], gb[k], float(d[k]))
    return d


def _check(geoms, alive, region, boundary, min_gap, margin, tol, inner=None, exact_edges=False,
           fixed=None, rank=None, contacts=None, weak=None, memo=None):
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
    points. ``memo`` (a dict): pair distances kept between calls (:func:`_pair_distances`)."""
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
            centres[i] = _centre(geoms[i])
        return centres[i]

    shrink_points: dict = {}  # an element too close to several others: its candidates once

    def cost(i, p, u, total):
        if i not in shrink_points:
            shrink_points[i] = _shrink_candidates(geoms[i], centre(i), SHRINK_POINTS)
        return _shrink_cost(shrink_points[i], float(geoms[i].area), p, u, total)

    if len(idx) >= 2:
        a, b = _near_pairs(arr, np.arange(len(arr)), min_gap)
        keep = a < b
        a, b = a[keep], b[keep]
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
                line = np.asarray(shapely.shortest_line(gi, gj).coords)
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
            # one of the two shrinks: the one poking into the other's hollow (its contact
            # lies in the other's convex hull: shrinking the hollow's owner would close the
            # hollow further), else the smaller one
            in_i = gj.convex_hull.contains(shapely.points(pi))
            in_j = gi.convex_hull.contains(shapely.points(pj))
            if in_i != in_j:
                k, pk = (i, pi) if in_i else (j, pj)
            elif nu > 0:
                # the one that loses less art shrinking about its best point: a thin
                # part poking into a neighbour's body comes out of it when its owner
                # shrinks a little about a far point, while the body would have to shrink
                # by the whole depth about any of its points (a penguin's tail through
                # the heart's snake: the snake shrank to 0.67 of its size)
                ci = cost(i, pi, u / nu, total)
                cj = cost(j, pj, -u / nu, total)
                if ci == cj:  # both hopeless (no point moves the contact away): as before
                    ci, cj = gi.area, gj.area
                k, pk = (i, pi) if ci <= cj else (j, pj)
            else:
                k, pk = (i, pi) if gi.area <= gj.area else (j, pj)
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
        e = _edge_distance(boundary, region, g)
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
            line = np.asarray(shapely.shortest_line(g, boundary).coords)
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
            poke = _edge_poke(boundary, g, margin)
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
    for the latter: its centroid, as before. Shrinking about the centroid moves a contact
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


#: the most the skins' extra width (``grow_reach``) lets the final growth scale an element
REACH_MAX_SCALE = 2.0


def _inflate(geoms, base, alive, scale, shift, centre, region, boundary, target, margin,
             max_scale, tol, rounds, inner=None, fixed=None, reach=0.0):
    """Grow every element about its centroid into the room around it, never closer than
    ``target`` to another element nor ``margin`` to the edge, and no bigger than
    ``max_scale`` of its size — or than the size at which its outermost point has moved
    ``reach`` (container units), when that is more, up to :data:`REACH_MAX_SCALE` (small
    elements: see :func:`verify_and_repair`): each round, an element with slack s (half the spare
    distance to its nearest neighbour, or the spare distance to the edge) grows by
    1 + s/R, R its largest radius, so none of its points moves further than s (all grow at
    once, so a pair never closes more than its spare distance)."""
    n = len(geoms)
    idx = [i for i in range(n) if alive[i]]
    if not idx:
        return
    radius = {i: float(np.sqrt(((shapely.get_coordinates(geoms[i]) - (centre[i] + shift[i])) ** 2)
                               .sum(axis=1).max())) for i in idx}
    # the largest scale of each element (of its size as simulated: scale 1); the reach
    # never more than doubles one (a speck or a dot far smaller than the gap keeps its size
    # class: the live view's removed elements, shrunk to specks, stay specks)
    cap = {i: max(max_scale, min(1.0 + reach * scale[i] / radius[i], REACH_MAX_SCALE))
           if radius[i] > 0 else max_scale for i in idx}
    for _ in range(rounds):
        # only the elements that may still grow need their slack
        can = np.array([not (fixed is not None and fixed[i]) and scale[i] < cap[i]
                        and radius[i] > 0 for i in idx])
        if not can.any():
            break
        arr = np.array([geoms[i] for i in idx], dtype=object)
        q = np.flatnonzero(can)
        edge = shapely.distance(boundary, arr[q])  # inside: the rounds before made sure
        # a round grows an element by at most 1.5 targets: neighbours farther than 4
        # targets cannot limit it
        slack = np.full(len(idx), np.inf)
        slack[q] = np.minimum(edge - margin, 1.5 * target)
        a, b = _near_pairs(arr, q, 4.0 * target)
        a = q[a]
        keep = a != b
        pairs = np.unique(np.sort(np.stack([a[keep], b[keep]], axis=1), axis=1), axis=0)
        if len(pairs):  # each pair measured once, for whichever of the two may grow
            d = 0.5 * (shapely.distance(arr[pairs[:, 0]], arr[pairs[:, 1]]) - target)
            np.minimum.at(slack, pairs[:, 0], d)
            np.minimum.at(slack, pairs[:, 1], d)
        grow = {}
        for p, i in enumerate(idx):
            sl = slack[p] - tol
            if not can[p]:
                continue
            if sl > 1e-3 * target:
                grow[i] = min(1.0 + sl / radius[i], cap[i] / scale[i])
        if not grow:
            break
        for i, f in grow.items():
            scale[i] *= f
            radius[i] *= f
            geoms[i] = _moved(base[i], scale[i], 0.0, centre[i], shift[i][0], shift[i][1])


def _gather(geoms, base, alive, scale, shift, angle, centre, region, boundary, target, threshold,
            margin, tol, rounds=6, fixed=None):
    """Close the gaps wider than ``threshold``: each element whose nearest neighbour is
    farther than ``threshold`` moves towards it until the two are ``target`` apart,
    never closer than ``margin`` to the edge. Where elements cannot grow into the room
    between them (a narrow band holds copies limited by its width, not by their
    neighbours), the repulsion spreads the length left over evenly, every gap a little
    wide; gathered, it leaves most gaps at the gap asked for and a few wider pockets
    that pocket copies may fill.

    Moving an element changes its distance to anything by at most the longest way one of
    its points travels, and every other element is at least as far as its nearest, so a
    move whose points travel at most (distance − target) keeps it at least ``target``
    from every element. A straight move that would come closer than ``margin`` to the
    edge is tried again turned (about the element's centre, by up to the angle that moves
    its farthest point as far as the step: an element that fills the width of a curved
    band slides along it only so), at half the step so the travel bound holds, and
    halved until the margin is kept. None crosses what is not the container (the segment
    between the two nearest points must lie in ``region``). Elements move one at a time,
    the loneliest first; the rounds repeat while moves help."""
    idx = [i for i in range(len(geoms)) if alive[i] and not (fixed is not None and fixed[i])]
    if not idx or threshold <= target:
        return
    everyone = np.array([i for i in range(len(geoms)) if alive[i]])
    reach = 4.0 * threshold  # farther apart: another element lies between them, or the edge
    # turned moves: directions up to 45 degrees off the straight one, turns that move the
    # farthest point up to the step; the most direct first
    tries = sorted(((np.cos(b), np.sin(b), k) for b in np.radians([0, 15, -15, 30, -30, 45, -45])
                    for k in (0.0, 0.125, -0.125, 0.25, -0.25, 0.5, -0.5, 1.0, -1.0)),
                   key=lambda t: (-round(t[0], 6), abs(t[2])))
    stuck: set = set()
    memo: dict = {}  # the distances of pairs neither of which moved

    def moved_copy(i, step, u, turn):
        return _moved(base[i], scale[i], angle[i] + turn, centre[i], shift[i][0] + step * u[0],
                      shift[i][1] + step * u[1])

    for _ in range(rounds):
        bounds = shapely.bounds(np.array([geoms[i] for i in everyone], dtype=object))
        moved = False
        order = []
        for i in idx:
            d, j = _nearest(geoms, everyone, bounds, i, reach, memo)
            if d > threshold:
                order.append((-d, i))
        for _, i in sorted(order):
            d, j = _nearest(geoms, everyone, bounds, i, reach, memo)
            if not d > threshold or j < 0:
                continue
            line = shapely.shortest_line(geoms[i], geoms[j])
            if not region.covers(line):  # the room between them is not the container's
                continue
            p, q = shapely.get_coordinates(line)
            u = (q - p) / max(float(np.hypot(*(q - p))), 1e-300)
            budget = d - target - tol
            g = moved_copy(i, budget, u, 0.0)
            ok = float(shapely.distance(boundary, g)) - margin > tol
            step, v, turn = budget, u, 0.0
            if not ok and i not in stuck:  # turned: the step and the turn share the travel budget
                c = np.asarray(shapely.get_coordinates(geoms[i])) - (centre[i] + shift[i])
                radius = float(np.sqrt((c ** 2).sum(axis=1).max())) if len(c) else 0.0
                for step in (0.5 * budget, 0.25 * budget, 0.125 * budget) if radius > 0 else ():
                    for cb, sb, k in tries:
                        v = np.array([u[0] * cb - u[1] * sb, u[0] * sb + u[1] * cb])
                        turn = k * step / radius
                        g = moved_copy(i, step, v, turn)
                        if float(shapely.distance(boundary, g)) - margin > tol:
                            ok = True
                            break
                    if ok:
                        break
                if not ok:
                    stuck.add(i)  # wedged: not tried again
            if not ok or step <= 1e-3 * target:
                continue
            shift[i] += step * v
            angle[i] += turn
            geoms[i] = g
            bounds[np.searchsorted(everyone, i)] = geoms[i].bounds
            moved = True
        if not moved:
            break


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


def verify_and_repair(placed: list[PlacedArt], region, gap: float, margin: float, min_gap: float,
                      min_scale: float = 0.5, rounds: int = 24, repair: bool = True,
                      straightened: list | None = None, grow_to: float = 0.0,
                      max_scale: float = 1.15, should_stop: Callable[[], bool] | None = None,
                      grow_reach: float = 0.0, gather: float = 0.0) -> tuple[list[PlacedArt], Verification]:
    """Check (and, with ``repair``, enforce) the promises on the art of ``placed``.

    ``margin`` and ``min_gap`` in container units. Returns the (possibly shrunk, with
    dropped elements removed) art and the verification of what is returned.
    After the repair, with ``grow_to`` > 0, elements grow into the room left around them
    (:func:`_inflate`) up to ``max_scale`` of their size, or until their outermost point
    has moved ``grow_reach`` when that is more (at most :data:`REACH_MAX_SCALE`): the room
    the skins' extra width leaves between two arts is the same in container units whatever
    the elements' size, so an element not much wider than the gap needs more than
    ``max_scale`` to close it. With ``gather`` > ``grow_to`` (container units), elements
    then farther than ``gather`` from their nearest neighbour move towards it until they
    are ``grow_to`` apart (:func:`_gather`).
    ``should_stop()`` true ends the repair rounds early (Ctrl-C while very detailed art is
    repaired): what still violates is then dropped, so the promises hold all the same."""
    region = _polygonal(region)
    boundary = region.boundary
    shapely.prepare(region)
    tol = 1e-9 * max(1.0, float(np.ptp(np.asarray(region.bounds))))
    n = len(placed)
    exact = [p.art for p in placed]
    centre = [np.asarray(g.centroid.coords[0]) if not g.is_empty else np.zeros(2) for g in exact]
    # the rounds work on outlines simplified by eps and ask eps more of every distance
    # (exact checks are the slow part with detailed art); the final check is exact
    eps = 0.01 * max(min_gap, gap * 0.5)
    base = [shapely.simplify(g, eps, preserve_topology=True) for g in exact]
    w_gap, w_margin = min_gap + 2 * eps, margin + eps
    inner = shapely.buffer(region, -(w_margin + eps))
    shapely.prepare(inner)
    scale = np.ones(n)
    alive = np.array([not g.is_empty for g in exact])
    geoms = list(base)
    slack = 0.02 * min_gap  # aim a little beyond the floor: fewer rounds
    shift = np.zeros((n, 2))
    stuck = np.zeros(n, bool)  # a move made it worse: shrink from now on
    fixed = np.array([bool(getattr(p, "pinned", False)) for p in placed])  # pinned: never touched
    fixed = fixed if fixed.any() else None

    angle = np.zeros(n)  # radians about centre[i]: only the gathering turns an element

    def transform(g, i):
        return _moved(g, scale[i], angle[i], centre[i], shift[i][0], shift[i][1])

    def place(i):
        geoms[i] = transform(base[i], i)

    # a secondary element too close to a primary gives way alone (moves, shrinks, or is dropped)
    rank = np.array([0 if getattr(p, "kind", "primary") == "secondary" else 1 for p in placed])
    # below ``lowest`` an element is dropped (half min_scale for secondaries, small by nature)
    lowest = np.where(rank > 0, min_scale, 0.5 * min_scale)
    halfway = 0.5 * (1.0 + lowest)  # shrunk half-way to being dropped

    memo: dict = {}  # pair distances of the rounds' outlines: a round changes a few copies

    def check(exact_edges=False, contacts=None):
        return _check(geoms, alive, region, boundary, w_gap, w_margin, tol, inner, exact_edges, fixed, rank,
                      contacts, scale < halfway, memo)

    def move(i, ln):
        """The step that takes element i its need (plus the slack) along its push (length ln)."""
        return push[i] * min(1.0 + slack / need[i], (need[i] + slack) / ln)

    def keep_helpful(moved, before, mark_stuck):
        """Undo the moves that did not lower their own element's need below ``before``."""
        after = check()[0]
        for i, step in moved:
            if after[i] >= before[i]:
                shift[i] -= step
                stuck[i] |= mark_stuck
                place(i)

    stopped = False
    for r in range(rounds if repair else 0):
        if should_stop is not None and should_stop():
            stopped = True
            break
        contacts: dict = {}
        need, rel, push, counts, _, _ = check(contacts=contacts)
        bad = np.flatnonzero(need > 0)
        if len(bad) == 0:
            break
        translate = r < rounds // 2  # local separation first: a move keeps shape and size
        moved = []
        shrunk = []
        for i in bad:
            if fixed is not None and fixed[i]:
                continue
            ln = float(np.hypot(*push[i]))
            if translate and ln > 0 and not stuck[i]:
                step = move(i, ln)
                shift[i] += step
                moved.append((i, step))
            else:
                # about the point that moves its contacts away (mostly its centroid):
                # scale f about c folded into (scale about centre[i], shift)
                c, r_c = _shrink_centre(geoms[i], centre[i] + shift[i], contacts.get(i))
                f = max(0.85, 1.0 - (rel[i] if r_c is None else r_c) * (1.0 + slack / max(need[i], 1e-300)))
                scale[i] *= f
                if r_c is not None:
                    shift[i] = f * (centre[i] + shift[i] - c) + c - centre[i]
                if scale[i] < lowest[i]:
                    alive[i] = False
                    continue
                if scale[i] < halfway[i]:
                    shrunk.append(i)
            place(i)
        if moved:  # keep only the moves that helped the element that made them
            keep_helpful(moved, need, True)
        if shrunk:
            # a copy half-way to being dropped may fit a step away: a thin part squeezed
            # sideways gains little from shrinking about its centroid (the heart's snake
            # was dropped so). Each such copy still short tries its move from where it
            # shrank and keeps it only if that helped. (Every shrunk copy moving cost
            # fill: its moves pressed neighbours that then shrank; keyholes in a star:
            # area 0.530 -> 0.503.)
            need, _, push, _, _, _ = check()
            moved = []
            for i in shrunk:
                ln = float(np.hypot(*push[i]))
                if need[i] > 0 and ln > 0:
                    step = move(i, ln)
                    shift[i] += step
                    moved.append((i, step))
                    place(i)
            if moved:
                keep_helpful(moved, need, False)
    if repair and grow_to > 0 and not stopped:  # give back the room the repair (or the simulation) left
        _inflate(geoms, base, alive, scale, shift, centre, region, boundary, grow_to + 2 * eps,
                 w_margin, max_scale, tol, rounds=8, inner=inner, fixed=fixed, reach=grow_reach)
        if gather > grow_to:
            _gather(geoms, base, alive, scale, shift, angle, centre, region, boundary, grow_to + 2 * eps,
                    gather + 2 * eps, w_margin, tol, fixed=fixed)
    # final verification, exact, on what is returned
    geoms = [transform(exact[i], i) for i in range(n)]
    need, rel, push, counts, dmin, emin = _check(geoms, alive, region, boundary, min_gap, margin, tol,
                                                 exact_edges=True, fixed=fixed, rank=rank)
    if repair:  # anything still violating after the rounds is dropped (never a pinned copy)
        for i in np.flatnonzero(need > 0):
            if fixed is None or not fixed[i]:
                alive[i] = False
        if (need > 0).any():
            need, rel, push, counts, dmin, emin = _check(geoms, alive, region, boundary, min_gap, margin,
                                                         tol, exact_edges=True, fixed=fixed, rank=rank)
    dropped = [(int(i), placed[i].source) for i in range(n) if not alive[i] and not exact[i].is_empty]
    for i, src in dropped:
        if placed[i].kind == "primary":
            warnings.warn(f"element {i} ({src}) was dropped: " + (
                "the repair was stopped before it kept the gap and the edge margin" if stopped else
                f"moving and shrinking it (to {min_scale:g} of its size) could not keep the gap and the "
                "edge margin"), stacklevel=2)
    n_sec = sum(1 for i, _ in dropped if placed[i].kind != "primary")
    if n_sec:
        warnings.warn(f"{n_sec} secondary element(s) dropped: " + (
            "the repair was stopped before they kept the gap" if stopped else
            "their pockets could not hold them a gap away from everything"), stacklevel=2)
    out, shrunk = [], {}
    for i in range(n):
        if not alive[i]:
            continue
        if scale[i] != 1.0 or shift[i].any() or angle[i]:
            shrunk[i] = float(scale[i])
            moved = scaled_art(placed[i], float(scale[i]), centre[i], shift[i], float(angle[i]))
            # its art is the similarity of the art just verified: kept, not measured again
            # from the moved paths (detailed art costs 0.06 s a copy; the pocket fill and
            # the report measure every copy the repair moved)
            moved.__dict__["art"] = geoms[i]
            out.append(moved)
        else:
            out.append(placed[i])
    ok = not (need > 0).any()
    return out, Verification(ok, counts["overlap_pairs"], counts["outside"], counts["margin"], counts["gap"],
                             float(min_gap), float(margin), dmin, emin, shrunk, dropped,
                             [int(i) for i in straightened or []])
