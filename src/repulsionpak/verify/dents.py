"""Dents: the repair by local deformation, before any element is moved or shrunk.

The simulation ends jammed: skins pressed into each other at a few contacts and against
the container's edge, so the mapped art of neighbours can come closer than the gap floor
there (a limb pressed into a neighbour, a back pressed to the edge), while the rest of
each element has room. Shrinking such an element about its centroid
(:func:`~repulsionpak.verify.verify_and_repair`) clears one contact at the cost of its
whole size. :func:`dent` clears it where it is: the art of each element is bent away
from the contact by a smooth bump, as the element's mesh would bend, and only what is
still too close afterwards is left to the moves and shrinks.

Notes
-----
A bump moves every point ``p`` of an element's art by ``v · exp(-|p − c|² / (2ρ²))``:
the contact point ``c`` by ``v``, points a few ρ away not at all. With ``|v|`` at most
half a gap and ρ two gaps, the map stretches the art by at most ~15 % locally and cannot
fold it. Curves are bent by moving their control points (the bump varies little over a
segment) and flattened again as the writer writes them, so the checks measure what is
written. On the heart with 30 animals (seeds 1–3) the repair's shrinking cost 0.016–0.025
of the container's area; the dents give back 0.009–0.018 of it (``docs/algorithm.md``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import shapely
import shapely.affinity

from ..render.placed import refined
from ..types import ArtPath, CurveSubpath, PlacedArt
from .checks import distortion
from .repairs import _similarity

__all__ = ["DentResult", "dent"]

#: a bump overshoots the missing distance by this factor: its neighbouring points move
#: a little less than the contact point, and one of them may become the closest
OVERSHOOT = 1.1


@dataclass(frozen=True)
class DentResult:
    """What :func:`dent` did.

    ``violations[r]``: pairs too close plus elements too near the edge found in round r;
    ``dented``: indices of the elements returned bent; ``reverted``: those whose dents
    were undone because they bent the element beyond its shape limit."""

    violations: tuple[int, ...]
    dented: tuple[int, ...]
    reverted: tuple[int, ...]


def _bumped(points: np.ndarray, bumps: list[tuple[np.ndarray, np.ndarray]], two_rho2: float) -> np.ndarray:
    """``points`` (..., 2) moved by the sum of the bumps (centre, vector)."""
    pts = np.asarray(points, dtype=float)
    flat = pts.reshape(-1, 2)
    out = flat.copy()
    for c, v in bumps:
        w = np.exp(-((flat - c) ** 2).sum(axis=1) / two_rho2)
        out += w[:, None] * v
    return out.reshape(pts.shape)


def _bent(placed: PlacedArt, bumps: list, two_rho2: float) -> PlacedArt:
    """``placed`` with its art moved by ``bumps``: curves through their control points,
    then flattened at the copy's tolerance (:func:`~repulsionpak.render.placed.refined`);
    art without curves through its points."""
    paths = []
    for a in placed.paths:
        src = a.source
        if src is not None and src.curves and placed.tolerance is not None:
            curves = tuple(CurveSubpath(c.order, _bumped(c.ctrl, bumps, two_rho2), c.closed) for c in src.curves)
            paths.append(refined(ArtPath(a.subpaths, a.closed, a.style,
                                         source=dataclasses.replace(src, curves=curves)), placed.tolerance))
        else:
            paths.append(ArtPath(tuple(_bumped(p, bumps, two_rho2) for p in a.subpaths), a.closed, a.style,
                                 source=None if src is None or src.curves else src))
    return dataclasses.replace(placed, paths=tuple(paths))


def _pair_bumps(geoms: np.ndarray, target: float, frozen: np.ndarray, push: float, bumps: dict) -> int:
    """Bumps that part the pairs of ``geoms`` closer than ``target`` (but not touching:
    overlaps are the moves' to resolve); returns the number of pairs too close."""
    tree = shapely.STRtree(geoms)
    a, b = tree.query(geoms, predicate="dwithin", distance=target)
    keep = a < b
    a, b = a[keep], b[keep]
    if len(a) == 0:
        return 0
    d = shapely.distance(geoms[a], geoms[b])
    close = d < target
    bad = close & (d > 1e-9) & ~(frozen[a] & frozen[b])
    if bad.any():
        ends = shapely.get_coordinates(shapely.shortest_line(geoms[a[bad]], geoms[b[bad]])).reshape(-1, 2, 2)
        for i, j, dd, (pi, pj) in zip(a[bad], b[bad], d[bad], ends):
            u = (pi - pj) / dd
            need = OVERSHOOT * (target - dd)
            # each gives way half, or all of it when the other may not bend
            share_i = 0.0 if frozen[i] else (1.0 if frozen[j] else 0.5)
            for k, p, sign, share in ((i, pi, 1.0, share_i), (j, pj, -1.0, 1.0 - share_i)):
                if share > 0.0:
                    bumps.setdefault(int(k), []).append((p, sign * u * min(share * need, push)))
    return int(close.sum())


def _edge_bumps(geoms: np.ndarray, inner, frozen: np.ndarray, push: float, bumps: dict) -> int:
    """Bumps that take the art of each element back inside ``inner`` (the container less
    the margin) at its deepest point outside it; returns the number of elements out."""
    out = np.flatnonzero(~shapely.within(geoms, inner))
    for i in out:
        if frozen[i]:
            continue
        pts = shapely.points(shapely.get_coordinates(shapely.difference(geoms[i], inner)))
        if len(pts) == 0:
            continue
        depth = shapely.distance(pts, inner)
        k = int(np.argmax(depth))
        if depth[k] <= 1e-9:
            continue
        p, q = shapely.get_coordinates(shapely.shortest_line(pts[k], inner))
        bumps.setdefault(int(i), []).append((p, (q - p) / depth[k] * min(OVERSHOOT * depth[k], push)))
    return len(out)


def dent(placed: list[PlacedArt], region, gap: float, margin: float, min_gap: float, *,
         rounds: int = 8, radius: float = 2.0, push: float = 0.5, budget: float = 3.0,
         slack: float = 0.06, frozen: np.ndarray | None = None, rest: list[PlacedArt] | None = None,
         limits: np.ndarray | None = None) -> tuple[list[PlacedArt], DentResult]:
    """Bend the art of elements that are too close to a neighbour or to the container's
    edge away from the contact.

    Parameters
    ----------
    placed : list of PlacedArt
        The packing's art (not changed; the result holds new copies).
    region : shapely geometry
        The container.
    gap, margin, min_gap : float
        The gap asked for, the edge margin and the gap floor (container units).
    rounds : int
        Rounds of measuring and bending (a bent element may come close to a third one).
    radius : float
        ρ of a bump, × gap.
    push : float
        The most one bump moves its contact point, × gap.
    budget : float
        The most the bumps of one element may move its contact points in all, × gap;
        an element past it is left to the moves and shrinks.
    slack : float
        Distances are cleared to (1 + slack) × ``min_gap`` and ``margin``: the repair
        that follows measures simplified outlines.
    frozen : (n,) bool array, optional
        Elements that must not bend (pinned and rigid copies).
    rest, limits : optional
        Each element's undeformed art and shape limit, as for
        :func:`~repulsionpak.verify.straighten`: an element bent beyond its limit gets
        its art back unbent by the dents.

    Returns
    -------
    art : list of PlacedArt
        The art, bent where it helped.
    result : DentResult
    """
    n = len(placed)
    out = list(placed)
    if n == 0 or rounds <= 0:
        return out, DentResult((), (), ())
    frozen = np.zeros(n, bool) if frozen is None else np.asarray(frozen, bool)
    target = min_gap * (1.0 + slack)
    inner = shapely.buffer(region, -(margin * (1.0 + slack) + 0.01 * gap))
    shapely.prepare(inner)
    two_rho2 = 2.0 * (radius * gap) ** 2
    used = np.zeros(n)  # how far each element's contact points have been moved in all
    spent = np.zeros(n, bool)
    counts = []
    for _ in range(rounds):
        geoms = np.array([p.art for p in out], dtype=object)
        bumps: dict[int, list] = {}
        blocked = frozen | spent
        found = _pair_bumps(geoms, target, blocked, push * gap, bumps) + _edge_bumps(geoms, inner, blocked,
                                                                                    push * gap, bumps)
        counts.append(found)
        if not bumps:
            break
        for i, bl in bumps.items():
            moved = sum(float(np.hypot(*v)) for _, v in bl)
            if used[i] + moved > budget * gap:
                spent[i] = True
                continue
            used[i] += moved
            out[i] = _bent(out[i], bl, two_rho2)
    dented = [i for i in range(n) if out[i] is not placed[i]]
    reverted = []
    if rest is not None and limits is not None:
        for i in dented:
            if not np.isfinite(limits[i]):
                continue
            m, _ = _similarity(rest[i], placed[i])
            moved = shapely.affinity.affine_transform(
                rest[i].art, [m[0, 0], m[0, 1], m[1, 0], m[1, 1], m[0, 2], m[1, 2]])
            if distortion(out[i].art, moved) > limits[i]:
                out[i] = placed[i]
                reverted.append(i)
    return out, DentResult(tuple(counts), tuple(i for i in dented if i not in set(reverted)), tuple(reverted))
