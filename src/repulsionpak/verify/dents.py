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

    ``violations[r]``: pairs too close plus elements too near the edge found in round r
    (of the last run of the rounds); ``dented``: indices of the elements returned bent;
    ``reverted``: those kept unbent because the dents bent them beyond their shape limit."""

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


def _jacobians(points: np.ndarray, bumps: list, two_rho2: float) -> np.ndarray:
    """(n, 2, 2) Jacobian of the bump map at ``points`` (n, 2)."""
    jac = np.zeros((len(points), 2, 2))
    jac[:, 0, 0] = jac[:, 1, 1] = 1.0
    for c, v in bumps:
        d = points - c
        w = np.exp(-(d ** 2).sum(axis=1) / two_rho2)
        grad = (-2.0 / two_rho2) * w[:, None] * d  # ∇w
        jac += v[None, :, None] * grad[:, None, :]
    return jac


def _bent_curve(c: CurveSubpath, bumps: list, two_rho2: float) -> CurveSubpath:
    """``c`` under the bump map, smooth joins kept smooth: the end points move with the
    map, each handle with the map's tangent (affine) approximation at its own end point,
    so a handle pair in line across a join stays in line. A quadratic's one handle takes
    the mean of its two ends' estimates."""
    ctrl = c.ctrl
    n = len(c.order)
    idx = np.arange(n)
    start = ctrl[:, 0]
    end = ctrl[idx, c.order]
    ends = np.concatenate([start, end])
    moved = _bumped(ends, bumps, two_rho2)
    jac = _jacobians(ends, bumps, two_rho2)
    f0, f1, j0, j1 = moved[:n], moved[n:], jac[:n], jac[n:]
    out = np.empty_like(ctrl)
    out[:, 0] = f0
    for k in range(n):
        o = c.order[k]
        if o == 3:
            out[k, 1] = f0[k] + j0[k] @ (ctrl[k, 1] - start[k])
            out[k, 2] = f1[k] + j1[k] @ (ctrl[k, 2] - end[k])
        elif o == 2:
            out[k, 1] = 0.5 * (f0[k] + j0[k] @ (ctrl[k, 1] - start[k]) + f1[k] + j1[k] @ (ctrl[k, 1] - end[k]))
        out[k, o:] = f1[k]  # the end point and its copies
    return CurveSubpath(c.order, out, c.closed)


def _bent(placed: PlacedArt, bumps: list, two_rho2: float) -> PlacedArt:
    """``placed`` with its art moved by ``bumps``: curves through their control points,
    then flattened at the copy's tolerance (:func:`~repulsionpak.render.placed.refined`);
    art without curves through its points."""
    paths = []
    for a in placed.paths:
        src = a.source
        if src is not None and src.curves and placed.tolerance is not None:
            curves = tuple(_bent_curve(c, bumps, two_rho2) for c in src.curves)
            paths.append(refined(ArtPath(a.subpaths, a.closed, a.style,
                                         source=dataclasses.replace(src, curves=curves)), placed.tolerance))
        else:
            paths.append(ArtPath(tuple(_bumped(p, bumps, two_rho2) for p in a.subpaths), a.closed, a.style,
                                 source=None if src is None or src.curves else src))
    return dataclasses.replace(placed, paths=tuple(paths))


def _xy(points: np.ndarray) -> np.ndarray:
    """(n, 2) coordinates of an array of points, NaN for an empty one (``get_coordinates``
    would skip it and shift the rest)."""
    out = np.full((len(points), 2), np.nan)
    full = ~shapely.is_empty(points)
    out[full] = shapely.get_coordinates(points[full])
    return out


def _part(bumps: dict, frozen: np.ndarray, i: int, j: int, pi, pj, u: np.ndarray, need: float,
          push: float) -> None:
    """Bumps moving ``i`` at ``pi`` along ``u`` and ``j`` at ``pj`` against it, ``need`` in
    all: half each, or all of it on one when the other may not bend."""
    share_i = 0.0 if frozen[i] else (1.0 if frozen[j] else 0.5)
    for k, p, sign, share in ((i, pi, 1.0, share_i), (j, pj, -1.0, 1.0 - share_i)):
        if share > 0.0:
            bumps.setdefault(int(k), []).append((p, sign * u * min(share * need, push)))


def _pair_bumps(geoms: np.ndarray, target: float, frozen: np.ndarray, push: float, reach: float,
                bumps: dict) -> int:
    """Bumps that part the pairs of ``geoms`` closer than ``target``; returns the number of
    pairs too close.

    Apart, a pair parts along the line between its closest points. Overlapping (a limb
    pressed into a neighbour), it parts at the centroid of the overlap, along the line
    between the centroids of the two arts within ``reach`` of it, by the overlap's depth
    along that line plus ``target``."""
    tree = shapely.STRtree(geoms)
    a, b = tree.query(geoms, predicate="dwithin", distance=target)
    keep = a < b
    a, b = a[keep], b[keep]
    if len(a) == 0:
        return 0
    d = shapely.distance(geoms[a], geoms[b])
    close = d < target
    todo = close & ~(frozen[a] & frozen[b])
    apart = todo & (d > 1e-9)
    if apart.any():
        ends = shapely.get_coordinates(shapely.shortest_line(geoms[a[apart]], geoms[b[apart]])).reshape(-1, 2, 2)
        for i, j, dd, (pi, pj) in zip(a[apart], b[apart], d[apart], ends):
            _part(bumps, frozen, i, j, pi, pj, (pi - pj) / dd, OVERSHOOT * (target - dd), push)
    over = todo & (d <= 1e-9)
    if over.any():
        ia, ib = a[over], b[over]
        lens = shapely.intersection(geoms[ia], geoms[ib])
        centre = shapely.centroid(lens)
        disc = shapely.buffer(centre, reach)
        ca = _xy(shapely.centroid(shapely.intersection(geoms[ia], disc)))
        cb = _xy(shapely.centroid(shapely.intersection(geoms[ib], disc)))
        cc = _xy(centre)
        for k, (i, j) in enumerate(zip(ia, ib)):
            u = ca[k] - cb[k]
            n = float(np.hypot(*u))  # NaN where a part was empty (arts closer than 1e-9, apart)
            if not n > 1e-12:
                continue
            u /= n
            pts = shapely.get_coordinates(lens[k]) @ u
            depth = float(pts.max() - pts.min()) if len(pts) else 0.0
            _part(bumps, frozen, i, j, cc[k], cc[k], u, OVERSHOOT * (depth + target), push)
    return int(close.sum())


def _edge_bumps(geoms: np.ndarray, inner, frozen: np.ndarray, push: float, bumps: dict) -> int:
    """Bumps that take the art of each element back inside ``inner`` (the container less
    the margin) at its deepest point outside it; returns the number of elements out."""
    if inner.is_empty:  # a container narrower than twice the margin: nothing to bend into
        return 0
    out = np.flatnonzero(~shapely.within(geoms, inner))
    for i in out:
        if frozen[i]:
            continue
        pts = shapely.points(shapely.get_coordinates(shapely.difference(geoms[i], inner)))
        if len(pts) == 0:
            continue
        depth = shapely.distance(pts, inner)
        k = int(np.argmax(depth))
        if not depth[k] > 1e-9:
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
        :func:`~repulsionpak.verify.straighten`: an element the dents bend beyond its
        limit gets its art back, and the rounds run once more with it frozen, so that
        its neighbours give way alone.

    Returns
    -------
    art : list of PlacedArt
        The art, bent where it helped.
    result : DentResult
    """
    n = len(placed)
    if n == 0 or rounds <= 0:
        return list(placed), DentResult((), (), ())
    frozen = np.zeros(n, bool) if frozen is None else np.asarray(frozen, bool)
    target = min_gap * (1.0 + slack)
    inner = shapely.buffer(region, -(margin * (1.0 + slack) + 0.01 * gap))
    shapely.prepare(inner)
    args = (target, inner, rounds, radius * gap, push * gap, budget * gap)
    out, counts = _rounds(placed, frozen, *args)
    over = _over_limit(placed, out, rest, limits)
    if over:  # again with those unbent: their neighbours give way alone
        frozen = frozen.copy()
        frozen[over] = True
        out, counts = _rounds(placed, frozen, *args)
        over2 = _over_limit(placed, out, rest, limits)
        for i in over2:
            out[i] = placed[i]
        over = sorted(set(over) | set(over2))
    dented = tuple(i for i in range(n) if out[i] is not placed[i])
    return out, DentResult(tuple(counts), dented, tuple(over))


def _rounds(placed, frozen, target, inner, rounds, rho, push, budget):
    """The rounds of :func:`dent` (lengths in container units); returns (art, violations
    found in each round)."""
    n = len(placed)
    out = list(placed)
    two_rho2 = 2.0 * rho ** 2
    used = np.zeros(n)  # how far each element's contact points have been moved in all
    spent = np.zeros(n, bool)
    counts = []
    for _ in range(rounds):
        geoms = np.array([p.art for p in out], dtype=object)
        bumps: dict[int, list] = {}
        blocked = frozen | spent
        found = (_pair_bumps(geoms, target, blocked, push, 2.0 * rho, bumps)
                 + _edge_bumps(geoms, inner, blocked, push, bumps))
        counts.append(found)
        if not bumps:
            break
        for i, bl in bumps.items():
            moved = sum(float(np.hypot(*v)) for _, v in bl)
            if used[i] + moved > budget:
                spent[i] = True
                continue
            used[i] += moved
            out[i] = _bent(out[i], bl, two_rho2)
    return out, counts


def _over_limit(placed, out, rest, limits) -> list[int]:
    """The elements that ``out`` bends beyond their shape ``limits`` (measured as
    :func:`~repulsionpak.verify.straighten` does, against ``rest`` moved onto ``placed``)."""
    if rest is None or limits is None:
        return []
    over = []
    for i, (p, q) in enumerate(zip(placed, out)):
        if q is p or not np.isfinite(limits[i]):
            continue
        m, _ = _similarity(rest[i], p)
        moved = shapely.affinity.affine_transform(rest[i].art, [m[0, 0], m[0, 1], m[1, 0], m[1, 1], m[0, 2], m[1, 2]])
        if distortion(q.art, moved) > limits[i]:
            over.append(i)
    return over
