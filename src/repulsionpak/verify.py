"""Final verification of a packing's promises on the art itself, and its repair.

The simulation works on meshes and skins; what a user gets is the art mapped through
them. Whatever the simulation left, :func:`verify_and_repair` checks the promises on the
exact art polygons of every element:

* no two elements' art overlap;
* every element's art lies inside the container, at least ``margin`` from its edge;
* every element's art is at least ``min_gap`` from every other element's art.

An element that breaks one of them is first *moved* away from what it is too close to
(local separation, a few rounds: a moved element may make room for, or crowd, its
neighbours), then *shrunk* about its own centroid by just enough (both are similarities:
its shape is untouched); an element that would have to shrink below ``min_scale`` is
dropped, with a warning naming it. What remains is verified once more and reported; the CLI exits
non-zero if anything is still violated (on valid input it never is).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import shapely

from .geometry.outline import art_area, _polygonal
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
    shrunk: dict = field(default_factory=dict)  # element index -> scale applied (moved and/or shrunk)
    dropped: list = field(default_factory=list)  # (index, source) of dropped elements

    def to_dict(self) -> dict:
        return {"ok": self.ok, "overlap_pairs": self.overlap_pairs, "outside": self.outside,
                "margin_violations": self.margin_violations, "gap_violations": self.gap_violations,
                "min_gap": self.min_gap, "margin": self.margin, "min_distance": self.min_distance,
                "min_edge_distance": self.min_edge_distance,
                "shrunk": {str(k): v for k, v in sorted(self.shrunk.items())},
                "dropped": [{"index": i, "source": s} for i, s in self.dropped]}


def scaled_art(placed: PlacedArt, scale: float, centre: np.ndarray,
               shift: np.ndarray = np.zeros(2)) -> PlacedArt:
    """``placed`` scaled by ``scale`` about ``centre`` (strokes scaled with it), then moved
    by ``shift``."""
    c = np.asarray(centre, dtype=float)
    t = c + np.asarray(shift, dtype=float)
    paths = tuple(p.transformed(lambda pts: t + (np.asarray(pts) - c) * scale) for p in placed.paths)
    return PlacedArt(placed.source, placed.kind, paths, placed.stroke_scale * scale, placed.deformation)


def _edge_distance(region_boundary, region, g) -> float:
    """Distance from ``g`` to the container's edge, negative when ``g`` is not inside."""
    d = float(shapely.distance(region_boundary, g))
    if not shapely.contains(region, g):
        return -max(d, 0.0) if d > 0 else -float(shapely.difference(g, region).area ** 0.5)
    return d


def _check(geoms, alive, region, boundary, min_gap, margin, tol):
    """Per-element deficits: how far (container units) each element's art must move in
    to meet the promises, and the point of its art where that is needed."""
    n = len(geoms)
    need = np.zeros(n)
    where = [None] * n
    push = np.zeros((n, 2))  # summed directions (weighted by deficit) that would resolve it
    counts = {"overlap_pairs": 0, "outside": 0, "margin": 0, "gap": 0}
    dmin, emin = np.inf, np.inf
    idx = [i for i in range(n) if alive[i]]
    if len(idx) >= 2:
        sub = [geoms[i] for i in idx]
        tree = shapely.STRtree(sub)
        a, b = tree.query(sub, predicate="dwithin", distance=min_gap)
        for p, q in zip(a, b):
            if p >= q:
                continue
            i, j = idx[p], idx[q]
            gi, gj = geoms[i], geoms[j]
            d = float(shapely.distance(gi, gj))
            dmin = min(dmin, d)
            if d >= min_gap - tol:
                continue
            counts["gap"] += 1
            if d <= 0.0:
                counts["overlap_pairs"] += 1
                inter = shapely.intersection(gi, gj)
                depth = 2.0 * float(shapely.maximum_inscribed_circle(inter).length) if inter.area > 0 else 0.0
                deficit = 0.5 * (min_gap + depth) + tol
                pi = pj = shapely.centroid(inter) if not inter.is_empty else None
                ci = np.asarray(shapely.get_coordinates(shapely.centroid(gi)))[0]
                cj = np.asarray(shapely.get_coordinates(shapely.centroid(gj)))[0]
                u = ci - cj
            else:
                line = shapely.shortest_line(gi, gj)
                pi, pj = shapely.points(np.asarray(line.coords))
                deficit = 0.5 * (min_gap - d) + tol
                u = np.asarray(line.coords[0]) - np.asarray(line.coords[1])
            nu = float(np.hypot(*u))
            if nu > 0:
                push[i] += deficit * u / nu
                push[j] -= deficit * u / nu
            for k, pt in ((i, pi), (j, pj)):
                if deficit > need[k]:
                    need[k], where[k] = deficit, pt
    elif len(idx) == 1:
        pass
    for i in idx:
        g = geoms[i]
        e = _edge_distance(boundary, region, g)
        emin = min(emin, e)
        if e >= margin - tol:
            continue
        if e < 0:
            counts["outside"] += 1
        counts["margin"] += 1
        deficit = margin - e + tol
        if deficit > need[i]:
            # the art's point nearest the edge (or farthest outside)
            if e >= 0:
                line = np.asarray(shapely.shortest_line(g, boundary).coords)
                pt = shapely.points(line[0])
                u = line[0] - line[1]
                nu = float(np.hypot(*u))
                if nu > 0:
                    push[i] += deficit * u / nu
            else:
                out = shapely.difference(g, region)
                coords = np.asarray(shapely.get_coordinates(out))
                c = np.asarray(shapely.get_coordinates(shapely.centroid(g)))[0]
                far = coords[np.argmax(((coords - c) ** 2).sum(axis=1))]
                pt = shapely.points(far)
                push[i] += deficit * (c - far) / max(float(np.hypot(*(c - far))), 1e-300)
            need[i], where[i] = deficit, pt
    return need, where, push, counts, (None if not np.isfinite(dmin) else dmin), (None if not np.isfinite(emin) else emin)


def verify_and_repair(placed: list[PlacedArt], region, gap: float, margin: float, min_gap: float,
                      min_scale: float = 0.5, rounds: int = 24, repair: bool = True
                      ) -> tuple[list[PlacedArt], Verification]:
    """Check (and, with ``repair``, enforce) the promises on the art of ``placed``.

    ``margin`` and ``min_gap`` in container units. Returns the (possibly shrunk, with
    dropped elements removed) art and the verification of what is returned."""
    region = _polygonal(region)
    boundary = region.boundary
    shapely.prepare(region)
    tol = 1e-9 * max(1.0, float(np.ptp(np.asarray(region.bounds))))
    n = len(placed)
    base = [art_area(p.paths, p.stroke_scale) for p in placed]
    centre = [np.asarray(g.centroid.coords[0]) if not g.is_empty else np.zeros(2) for g in base]
    scale = np.ones(n)
    alive = np.array([not g.is_empty for g in base])
    geoms = list(base)
    slack = 0.02 * min_gap  # aim a little beyond the floor: fewer rounds
    shift = np.zeros((n, 2))
    for r in range(rounds if repair else 0):
        need, where, push, counts, _, _ = _check(geoms, alive, region, boundary, min_gap, margin, tol)
        bad = np.flatnonzero(need > 0)
        if len(bad) == 0:
            break
        translate = r < rounds // 2  # local separation first: a move keeps shape and size
        for i in bad:
            c = centre[i] + shift[i]
            if translate and np.hypot(*push[i]) > 0:
                step = push[i] * (1.0 + slack / max(need[i], 1e-300))
                # never move further than the deficit: neighbours move too
                ln = float(np.hypot(*step))
                if ln > need[i] + slack:
                    step *= (need[i] + slack) / ln
                shift[i] += step
            else:
                pt = where[i]
                rho = float(np.hypot(*(np.asarray(pt.coords[0]) - c))) if pt is not None else 0.0
                factor = 0.97 if rho <= 0.0 else max(0.9, 1.0 - (need[i] + slack) / rho)
                scale[i] *= factor
                if scale[i] < min_scale:
                    alive[i] = False
                    continue
            geoms[i] = shapely.affinity.translate(
                shapely.affinity.scale(base[i], scale[i], scale[i], origin=tuple(centre[i])),
                shift[i][0], shift[i][1])
    # final verification: what is returned
    need, where, push, counts, dmin, emin = _check(geoms, alive, region, boundary, min_gap, margin, tol)
    if repair:  # anything still violating after the rounds is dropped
        for i in np.flatnonzero(need > 0):
            alive[i] = False
        if (need > 0).any():
            need, where, push, counts, dmin, emin = _check(geoms, alive, region, boundary, min_gap, margin, tol)
    dropped = [(int(i), placed[i].source) for i in range(n) if not alive[i] and not base[i].is_empty]
    for i, src in dropped:
        warnings.warn(f"element {i} ({src}) was dropped: moving and shrinking it (to "
                      f"{min_scale:g} of its size) could not keep the gap and the edge margin",
                      stacklevel=2)
    out, shrunk = [], {}
    for i in range(n):
        if not alive[i]:
            continue
        if scale[i] < 1.0 or shift[i].any():
            shrunk[i] = float(scale[i])
            out.append(scaled_art(placed[i], float(scale[i]), centre[i], shift[i]))
        else:
            out.append(placed[i])
    ok = not (need > 0).any()
    return out, Verification(ok, counts["overlap_pairs"], counts["outside"], counts["margin"], counts["gap"],
                             float(min_gap), float(margin), dmin, emin, shrunk, dropped)
