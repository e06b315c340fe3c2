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
the contact point ``c`` by ``v``, points a few ρ away not at all. It stretches the art
by at most 0.61 |v|/ρ locally and folds it only from |v| = 1.65 ρ: with |v| at most half
a gap and ρ one gap (``VerifyParams.dent_radius``), 30 %, and a round's bumps on one
stretch of outline would have to add up to over three of them to fold it. Curves are
bent by moving their control points (a segment too long to follow the bump that way is
split first, :func:`_bent_curves`) and flattened again as the writer writes them, so the
checks measure what is written. On the heart with 30 animals (seeds
1–3) the repair's shrinking cost 0.016–0.025 of the container's area; the dents give back
0.009–0.018 of it (``docs/algorithm.md``).
"""

from __future__ import annotations

import dataclasses
import math
import operator
from dataclasses import dataclass

import numpy as np
import shapely
from numba import njit

from ..geometry.curves import as_cubics, cubic_points, decimals_for
from ..geometry.edges import Edges
from ..geometry.pairwise import distances, near_pairs
from ..render.placed import FIT_SHARE, written
from ..types import ArtPath, CurveSubpath, PlacedArt
from ..threads import thread_map
from .repairs import rest_distortion

__all__ = ["DentResult", "dent"]

#: a bump overshoots the missing distance by this factor: its neighbouring points move
#: a little less than the contact point, and one of them may become the closest
OVERSHOOT = 1.1


@dataclass(frozen=True)
class DentResult:
    """What :func:`dent` did.

    ``violations[r]``: pairs too close plus elements too near the edge found in round r
    (after the first, among the elements the round before bent; then the rounds that go
    on from the elements bent back to their shape limit); ``dented``: indices of the
    elements returned bent; ``reverted``: those whose dents bent them beyond their shape
    limit, returned with the share of their bumps that fits it (or unbent)."""

    violations: tuple[int, ...]
    dented: tuple[int, ...]
    reverted: tuple[int, ...]


def _packed(bumps: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """A bump list as one (B, 4) array of rows (centre x, y, vector x, y), as the
    kernels take it."""
    out = np.empty((len(bumps), 4))
    for k, (c, v) in enumerate(bumps):
        out[k, :2] = c
        out[k, 2:] = v
    return out


@njit(cache=True, nogil=True)
def _bump_points(pts, cv, two_rho2):
    """``pts`` (n, 2) moved by the sum of the bumps ``cv`` (B, 4): each bump's weight is
    taken at the unmoved point.

    Notes
    -----
    Compiled because the dents call it thousands of times on a few points each (every
    bent segment's ends, then its samples while it is split): as numpy expressions that
    was one temporary array per bump and call. The sums run in numpy's order, so the
    packings are the same to the bit."""
    out = pts.copy()
    for i in range(pts.shape[0]):
        px = pts[i, 0]
        py = pts[i, 1]
        for k in range(cv.shape[0]):
            dx = px - cv[k, 0]
            dy = py - cv[k, 1]
            w = math.exp(-(dx * dx + dy * dy) / two_rho2)
            out[i, 0] += w * cv[k, 2]
            out[i, 1] += w * cv[k, 3]
    return out


@njit(cache=True, nogil=True)
def _bump_map(pts, cv, two_rho2):
    """``pts`` (n, 2) moved by the bumps ``cv`` (B, 4), as :func:`_bump_points`, and the
    map's (n, 2, 2) Jacobian there: both from one weight per point and bump."""
    n = pts.shape[0]
    out = pts.copy()
    jac = np.zeros((n, 2, 2))
    f = -2.0 / two_rho2
    for i in range(n):
        jac[i, 0, 0] = 1.0
        jac[i, 1, 1] = 1.0
        px = pts[i, 0]
        py = pts[i, 1]
        for k in range(cv.shape[0]):
            dx = px - cv[k, 0]
            dy = py - cv[k, 1]
            w = math.exp(-(dx * dx + dy * dy) / two_rho2)
            out[i, 0] += w * cv[k, 2]
            out[i, 1] += w * cv[k, 3]
            fw = f * w
            gx = fw * dx
            gy = fw * dy
            jac[i, 0, 0] += cv[k, 2] * gx
            jac[i, 0, 1] += cv[k, 2] * gy
            jac[i, 1, 0] += cv[k, 3] * gx
            jac[i, 1, 1] += cv[k, 3] * gy
    return out, jac


def _bumped(points: np.ndarray, bumps: list[tuple[np.ndarray, np.ndarray]], two_rho2: float) -> np.ndarray:
    """``points`` (..., 2) moved by the sum of the bumps (centre, vector)."""
    pts = np.asarray(points, dtype=float)
    flat = np.ascontiguousarray(pts.reshape(-1, 2))
    return _bump_points(flat, _packed(bumps), float(two_rho2)).reshape(pts.shape)


def _bumped_outline(geom, bumps: list, two_rho2: float):
    """``geom`` (an art's outline) with its vertices moved by the bumps; made valid again
    where that made it cross itself.

    Notes
    -----
    The map cannot fold the art, but it moves vertices, not the straight edges between
    them: two parts of an outline a hair apart (the strokes of an emoji meeting) crossed
    under a bump of 0.08 ρ, and the next measure of that outline failed in GEOS
    ("side location conflict"). Only the dents' own measures use this outline; the art
    written is bent through its curves and measured again (``PlacedArt.art``)."""
    out = shapely.transform(geom, lambda pts: _bumped(pts, bumps, two_rho2))
    if not shapely.is_valid(out):
        out = shapely.make_valid(out, method="structure", keep_collapsed=False)
    return out


def _bumped_with_jacobians(points: np.ndarray, bumps: list, two_rho2: float) -> tuple[np.ndarray, np.ndarray]:
    """``points`` (n, 2) moved by the bumps (:func:`_bumped`) and the (n, 2, 2) Jacobian
    of the bump map at them."""
    pts = np.ascontiguousarray(points, dtype=float)
    return _bump_map(pts, _packed(bumps), float(two_rho2))


class _Steps:
    """The bump lists of several elements (groups), each applied in turn, as the kernels
    take them: ``steps[g]`` is group g's list of bump lists.

    Notes
    -----
    The dents bend thousands of elements, each a few times over, in small numpy steps:
    one element at a time, their fixed cost, not the arithmetic, is most of the time. The
    bends of every element are therefore taken together, one array over all their
    segments. Only the
    bump map differs between elements: it is evaluated one element at a time
    (:func:`_bump_map` on that element's points with its own bumps), so every point
    moves by the same sum, to the bit, as when each element was bent alone; the numpy
    steps around it are elementwise, the same on any batch."""

    def __init__(self, steps: list[list[list]], two_rho2: float):
        self.packed = [[_packed(bumps) for bumps in st] for st in steps]
        self.count = np.array([len(st) for st in steps], dtype=np.int64)
        self.two_rho2 = float(two_rho2)

    def depth(self, group: np.ndarray) -> int:
        """The most bump lists any of the ``group`` (one entry per row) applies."""
        return int(self.count[group].max()) if len(group) else 0

    def map(self, points: np.ndarray, group: np.ndarray, step: int) -> tuple[np.ndarray, np.ndarray]:
        """``points`` (n, 2), each moved by bump list ``step`` of its ``group`` (sorted;
        every group has that many lists), and the (n, 2, 2) Jacobian of that map there
        (:func:`_bumped_with_jacobians`)."""
        points = np.ascontiguousarray(points, dtype=float)
        moved = np.empty((len(points), 2))
        jac = np.empty((len(points), 2, 2))
        cut = np.concatenate([[0], np.flatnonzero(np.diff(group)) + 1, [len(group)]]).tolist()
        for a, b in zip(cut[:-1], cut[1:]):
            moved[a:b], jac[a:b] = _bump_map(points[a:b], self.packed[group[a]][step], self.two_rho2)
        return moved, jac


def _bend(order: np.ndarray, ctrl: np.ndarray, group: np.ndarray, steps: _Steps, step: int) -> np.ndarray:
    """Control points (n, 4, 2) of segments ``order``, ``ctrl`` under bump list ``step`` of
    each one's ``group``, smooth joins kept smooth: the end points move with the map, each
    handle with the map's tangent (affine) approximation at its own end point, so a handle
    pair in line across a join stays in line (a cubic then matches the bumped curve's
    position and derivative at both ends). A quadratic's one handle takes the mean of its
    two ends' estimates."""
    n = len(order)
    start = ctrl[:, 0]
    end = ctrl[np.arange(n), order]
    # each segment's two ends side by side, so that each group's points are one slice
    moved, jac = steps.map(np.stack([start, end], axis=1).reshape(-1, 2), np.repeat(group, 2), step)
    f0, f1 = np.ascontiguousarray(moved[0::2]), np.ascontiguousarray(moved[1::2])
    j0, j1 = np.ascontiguousarray(jac[0::2]), np.ascontiguousarray(jac[1::2])
    h0 = f0 + np.einsum("nij,nj->ni", j0, ctrl[:, 1] - start)  # first handle, from the start
    out = np.empty_like(ctrl)
    out[:, 0] = f0
    out[:, 1] = h0
    cubic, quad = order == 3, order == 2
    out[cubic, 2] = f1[cubic] + np.einsum("nij,nj->ni", j1[cubic], ctrl[cubic, 2] - end[cubic])
    out[quad, 1] = 0.5 * (h0[quad] + f1[quad] + np.einsum("nij,nj->ni", j1[quad], ctrl[quad, 1] - end[quad]))
    tail = np.arange(4)[None, :] >= order[:, None]  # the end point and its copies
    out[tail] = np.broadcast_to(f1[:, None, :], ctrl.shape)[tail]
    return out


def _bend_all(order: np.ndarray, ctrl: np.ndarray, group: np.ndarray, steps: _Steps) -> np.ndarray:
    """Segments ``order``, ``ctrl`` under every bump list of their ``group``, in turn
    (:func:`_bend`)."""
    out = ctrl
    for step in range(steps.depth(group)):
        rows = np.flatnonzero(steps.count[group] > step)
        if len(rows) == len(order):
            out = _bend(order, out, group, steps, step)
        else:
            out = out.copy()
            out[rows] = _bend(order[rows], out[rows], group[rows], steps, step)
    return out


#: where a bent segment is compared with the bumped curve (parameters inside it)
CHECK_AT = (0.25, 0.5, 0.75)
#: a bent segment is split in halves, exactly, and both bent again while it is off the
#: bumped curve by more than this share of the copy's curve tolerance (what the fit of the
#: written curves leaves of it) ...
SPLIT_DISTANCE = 1.0 - FIT_SHARE
#: ... or turned from the bumped curve's direction by more than this many degrees (a
#: quarter of the fit's default angle tolerance)
SPLIT_ANGLE = 0.5
#: at most this many halvings of one segment
SPLIT_DEPTH = 5


def _off_curve(order: np.ndarray, ctrl: np.ndarray, bent: np.ndarray, group: np.ndarray, steps: _Steps,
               distance: np.ndarray, angle: float) -> np.ndarray:
    """(n,) bool: whether each bent segment is farther than ``distance`` (one per
    segment) from the curve bumped by its ``group``'s bump lists, or turned from its
    direction by more than ``angle`` (radians), at any of :data:`CHECK_AT`."""
    k = len(CHECK_AT)
    t = np.tile(CHECK_AT, len(order))  # each segment at every parameter: a group's rows are one slice
    p, d = cubic_points(np.repeat(as_cubics(order, ctrl), k, axis=0), t)
    rows_group = np.repeat(group, k)
    for step in range(steps.depth(group)):  # the exact map: one bump list after the other
        rows = np.flatnonzero(steps.count[rows_group] > step)
        moved, jac = steps.map(p[rows], rows_group[rows], step)
        p[rows] = moved
        d[rows] = np.einsum("nij,nj->ni", jac, d[rows])
    q, e = cubic_points(np.repeat(as_cubics(order, bent), k, axis=0), t)
    turn = np.abs(np.arctan2(d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0], (d * e).sum(axis=1)))
    bad = (np.hypot(*(p - q).T) > np.repeat(distance, k)) | (turn > angle)
    return bad.reshape(-1, k).any(axis=1)


def _halves(order: np.ndarray, ctrl: np.ndarray) -> np.ndarray:
    """Control points (n, 2, 4, 2) of each segment's two halves, the same curve exactly
    (de Casteljau at t = 1/2); a quadratic's halves are quadratics."""
    c = as_cubics(order, ctrl)
    a, b, d = 0.5 * (c[:, 0] + c[:, 1]), 0.5 * (c[:, 1] + c[:, 2]), 0.5 * (c[:, 2] + c[:, 3])
    ab, bd = 0.5 * (a + b), 0.5 * (b + d)
    mid = 0.5 * (ab + bd)
    out = np.empty((len(order), 2, 4, 2))
    out[:, 0] = np.stack([c[:, 0], a, ab, mid], axis=1)
    out[:, 1] = np.stack([mid, bd, d, c[:, 3]], axis=1)
    q = order == 2
    if q.any():
        h0, h1 = 0.5 * (ctrl[q, 0] + ctrl[q, 1]), 0.5 * (ctrl[q, 1] + ctrl[q, 2])
        m = 0.5 * (h0 + h1)
        out[q, 0] = np.stack([ctrl[q, 0], h0, m, m], axis=1)
        out[q, 1] = np.stack([m, h1, ctrl[q, 2], ctrl[q, 2]], axis=1)
    return out


def _bent_curves(groups: list[tuple[list[CurveSubpath], list[list], float, np.ndarray]], two_rho2: float,
                 reach: float) -> list[list[tuple]]:
    """Each group's ``(curves, steps, tol, centres)``: ``curves`` (all of one element's)
    under the bump lists ``steps``, applied in turn (:func:`_bend`). A curved segment
    within ``reach`` of one of the bumps' ``centres`` is split in halves, exactly, until
    each bent half is within :data:`SPLIT_DISTANCE` × ``tol`` and :data:`SPLIT_ANGLE` of
    the bumped curve. Returns each group's bent curves, each as ``(order, ctrl, rounded,
    closed)``: ``rounded`` its control points rounded as the writer rounds them at
    ``tol`` (:func:`~repulsionpak.geometry.curves.round_curves`; None when ``tol`` is not
    positive), for :func:`_as_written`.

    Notes
    -----
    Bent through its end points and handles, a cubic is the Hermite interpolant of the
    bumped curve: exact at its ends only, its curvature off by ~|v|·L²/(4ρ⁴) along a
    segment of length L for a bump of size |v| and width ρ. A large copy's fitted
    segments are several ρ long: a disc bent with them turned 2.9° at one written joint
    and 0.9° at the next (400 samples) where the bumped outline turns a steady 2°. Lines
    stay lines: the outline the checks measure keeps them straight too.

    The groups are bent together (:class:`_Steps`): each segment exactly as if its
    element were bent alone; a group whose segments all fit stops changing, as it
    stopped splitting alone."""
    curves = [c for cv, _, _, _ in groups for c in cv]
    if not curves:
        return [[] for _ in groups]
    order = np.concatenate([c.order for c in curves]).astype(np.int64)
    ctrl = np.concatenate([c.ctrl for c in curves])
    owner = np.repeat(np.arange(len(curves)), [len(c.order) for c in curves])
    group = np.repeat(np.arange(len(groups)), [sum(len(c.order) for c in cv) for cv, _, _, _ in groups])
    steps = _Steps([st for _, st, _, _ in groups], two_rho2)
    distance = np.array([SPLIT_DISTANCE * tol for _, _, tol, _ in groups])
    check = _near_each(ctrl.min(axis=1), ctrl.max(axis=1), group, [c for _, _, _, c in groups], reach) & (order > 1)
    bent = _bend_all(order, ctrl, group, steps)
    for _ in range(SPLIT_DEPTH):
        if not check.any():
            break
        bad = np.zeros(len(order), bool)
        bad[check] = _off_curve(order[check], ctrl[check], bent[check], group[check], steps,
                                distance[group[check]], np.radians(SPLIT_ANGLE))
        if not bad.any():
            break
        idx = np.repeat(np.arange(len(order)), np.where(bad, 2, 1))
        order, ctrl, owner, group, bent, check = order[idx], ctrl[idx], owner[idx], group[idx], bent[idx], bad[idx]
        twice = np.flatnonzero(check)  # two rows per split segment, in order
        halves = _halves(order[twice[0::2]], ctrl[twice[0::2]])
        ctrl[twice[0::2]] = halves[:, 0]
        ctrl[twice[1::2]] = halves[:, 1]
        bent[check] = _bend_all(order[check], ctrl[check], group[check], steps)  # only the halves are new
    # rounded as written, all of a tolerance's decimals at once (np.round is elementwise)
    decimals = np.array([decimals_for(tol) if tol > 0 else -1 for _, _, tol, _ in groups])[group]
    rounded = np.full_like(bent, np.nan)
    for d in np.unique(decimals[decimals >= 0]).tolist():
        rows = decimals == d
        rounded[rows] = np.round(bent[rows], d)
    cut = np.searchsorted(owner, np.arange(len(curves) + 1)).tolist()  # owner is sorted
    flat = iter([(order[a:b], bent[a:b], rounded[a:b] if decimals[a] >= 0 else None, c.closed)
                 for c, a, b in zip(curves, cut[:-1], cut[1:])])
    return [[next(flat) for _ in cv] for cv, _, _, _ in groups]


def _as_written(a: ArtPath, curves: list[tuple], tol: float) -> ArtPath:
    """Path ``a`` with the bent ``curves`` (:func:`_bent_curves`) as the copy at curve
    tolerance ``tol`` writes it: ``refined(a with those curves, tol)``
    (:func:`~repulsionpak.render.placed.refined`), the same path to the bit.

    Notes
    -----
    The curves come rounded in one array over every bent element (:func:`_bent_curves`;
    ``np.round`` is elementwise, so the same numbers): rounded one subpath at a time, as
    :func:`refined` rounds them, with each curve made twice (bent, then rounded), that
    costs about half as much again as the bends themselves on a 1,000-element poster.
    :func:`~repulsionpak.render.placed.written` does the rest, as for :func:`refined`."""
    if tol > 0:
        # ``written`` reads only the style and the source of the path it is given, whose
        # curves it replaces: ``a`` serves as well as the path with the bent curves, which
        # is made only when it is returned (no curve flattens to two points)
        out = written(a, tuple(CurveSubpath(order, rounded, closed) for order, _, rounded, closed in curves), tol)
        if out is not a:
            return out
    return ArtPath(a.subpaths, a.closed, a.style, source=dataclasses.replace(
        a.source, curves=tuple(CurveSubpath(order, ctrl, closed) for order, ctrl, _, closed in curves)))


#: a path farther than this many ρ from every bump is left as it is: the bumps move it by
#: less than exp(−REACH²/2) ≈ 4·10⁻⁵ of their size
REACH = 4.5


def _near_each(lo: np.ndarray, hi: np.ndarray, group: np.ndarray, centres: list[np.ndarray],
               reach: float) -> np.ndarray:
    """(n,) bool: whether each bounding box ``lo``, ``hi`` (n, 2), e.g. of a segment's
    control points, comes within ``reach`` of one of the ``centres`` (m, 2) of its
    ``group``.

    Notes
    -----
    The centres are tried in turn, each on the boxes of the groups that have it and that
    no centre before it reached: most boxes near a bump are found by the first."""
    count = np.array([len(c) for c in centres], dtype=np.int64)
    first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    every = np.concatenate(centres).reshape(-1, 2) if len(centres) else np.zeros((0, 2))
    near = np.zeros(len(group), bool)
    todo = np.arange(len(group))
    for k in range(int(count.max()) if len(count) else 0):
        todo = todo[count[group[todo]] > k]
        if not len(todo):
            break
        c = every[first[group[todo]] + k]
        off = np.maximum(np.maximum(lo[todo] - c, c - hi[todo]), 0.0)
        hit = np.hypot(off[:, 0], off[:, 1]) < reach
        near[todo[hit]] = True
        todo = todo[~hit]
    return near


def _path_points(a: ArtPath) -> list[np.ndarray]:
    """The points whose bounding box stands for path ``a``: its curves' control points, or
    its subpaths' points when it has no curves."""
    if a.source is not None and a.source.curves:
        return [c.ctrl.reshape(-1, 2) for c in a.source.curves]
    return list(a.subpaths)


#: the most copies :func:`_bent_many` bends in one set of arrays: all of a 1,000-element
#: poster's at once raised the dents' peak memory by ~60 MB over batches of 64, which are
#: as fast
BATCH = 64


def _bent_many(jobs: list[tuple[PlacedArt, list[list]]], two_rho2: float) -> list[PlacedArt]:
    """Each job's ``placed`` with its art moved by each bump list of its ``steps`` in
    turn: curves through their control points, then flattened at the copy's tolerance
    (:func:`_as_written`, as :func:`~repulsionpak.render.placed.refined` does);
    art without curves through its points. Paths out of the bumps' reach (:data:`REACH`)
    are kept as they are, and a copy with none in reach is returned itself.

    Notes
    -----
    The curves of every job are bent together (:func:`_bent_curves`), each one as if its
    copy were bent alone: the same art, to the bit. At most :data:`BATCH` jobs share one
    set of arrays, which bounds their memory."""
    if not jobs:
        return []
    if len(jobs) > BATCH:
        return [q for k in range(0, len(jobs), BATCH) for q in _bent_many(jobs[k:k + BATCH], two_rho2)]
    reach = REACH * np.sqrt(0.5 * two_rho2)
    centres = [np.array([c for bumps in steps for c, _ in bumps]).reshape(-1, 2) for _, steps in jobs]
    # every path's bounding box, all at once
    points, path_job, sizes = [], [], []
    for j, (placed, _) in enumerate(jobs):
        for a in placed.paths:
            pts = _path_points(a)
            points += pts
            sizes.append(len(pts))
            path_job.append(j)
    if points:
        first = np.concatenate([[0], np.cumsum([len(p) for p in points])[:-1]]).astype(np.int64)
        starts = first[np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)]
        every = np.concatenate(points)
        hits = iter(_near_each(np.minimum.reduceat(every, starts), np.maximum.reduceat(every, starts),
                               np.array(path_job, dtype=np.int64), centres, reach).tolist())
    plans, groups = [], []
    for (placed, steps), cs in zip(jobs, centres):
        hit = [next(hits) for _ in placed.paths]
        curved = [h and a.source is not None and bool(a.source.curves) and placed.tolerance is not None
                  for a, h in zip(placed.paths, hit)]
        plans.append((hit, curved))
        if any(hit):
            groups.append(([c for a, cv in zip(placed.paths, curved) if cv for c in a.source.curves],
                           steps, placed.tolerance, cs))
    bent_groups = iter(_bent_curves([g for g in groups if g[0]], two_rho2, reach))
    out = []
    groups = iter(groups)
    for (placed, steps), (hit, curved) in zip(jobs, plans):
        if not any(hit):
            out.append(placed)
            continue
        bent = iter(next(bent_groups) if next(groups)[0] else ())
        paths = []
        for a, h, cv in zip(placed.paths, hit, curved):
            src = a.source
            if not h:
                paths.append(a)
            elif cv:
                paths.append(_as_written(a, [next(bent) for _ in src.curves], placed.tolerance))
            else:
                subs = a.subpaths
                for bumps in steps:
                    subs = tuple(_bumped(p, bumps, two_rho2) for p in subs)
                paths.append(ArtPath(subs, a.closed, a.style, source=None if src is None or src.curves else src))
        out.append(dataclasses.replace(placed, paths=tuple(paths)))
    return out


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


def _pair_bumps(geoms: np.ndarray, exact: np.ndarray, target: float, frozen: np.ndarray, push: float,
                reach: float, bumps: dict, which: np.ndarray) -> int:
    """Bumps that part the pairs of ``geoms`` (simplified outlines: their overlaps are
    taken on the ``exact`` ones) closer than ``target`` of which one is in ``which``;
    returns the number of such pairs too close.

    Apart, a pair parts along the line between its closest points. Overlapping (a limb
    pressed into a neighbour), it parts at the centroid of the overlap, along the line
    between the centroids of the two arts within ``reach`` of it, by the overlap's depth
    along that line plus ``target``.

    Notes
    -----
    The candidates are the pairs whose bounding boxes come within ``target`` (a little
    more, for rounding), each measured once: a ``dwithin`` query would measure every
    candidate, and the pairs it keeps would be measured again. Only the pairs measured
    closer than ``target`` count, in the order of their indices."""
    q, b = near_pairs(geoms, which, target * (1.0 + 1e-9) + 1e-12)
    a = which[q]
    keep = a != b
    if not keep.any():
        return 0
    pairs = np.unique(np.sort(np.column_stack([a[keep], b[keep]]), axis=1), axis=0)
    a, b = pairs[:, 0], pairs[:, 1]
    d = distances(geoms[a], geoms[b])
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
        lens = shapely.intersection(exact[ia], exact[ib])
        centre = shapely.centroid(lens)
        disc = shapely.buffer(centre, reach)
        ca = _xy(shapely.centroid(shapely.intersection(exact[ia], disc)))
        cb = _xy(shapely.centroid(shapely.intersection(exact[ib], disc)))
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


def _edge_bumps(geoms: np.ndarray, exact: np.ndarray, inner, inner_edges: Edges, frozen: np.ndarray,
                push: float, bumps: dict, which: np.ndarray) -> int:
    """Bumps that take the art of each element of ``which`` back inside ``inner`` (the
    container less the margin; ``inner_edges`` its boundary) at its deepest point
    outside it; returns the number of elements out.

    Notes
    -----
    The deepest point of the art outside ``inner`` is one of the art's vertices outside
    it (the other vertices of their difference lie on ``inner``'s boundary), and its
    depth is its distance to that boundary: both without an overlay with the whole
    container, whose cost grew with the container's detail (a logo's 45,000 vertices:
    23 ms an element)."""
    if inner.is_empty:  # a container narrower than twice the margin: nothing to bend into
        return 0
    out = which[~shapely.within(geoms[which], inner)]
    for i in out:
        if frozen[i]:
            continue
        xy = shapely.get_coordinates(exact[i])
        xy = xy[~shapely.contains_xy(inner, xy[:, 0], xy[:, 1])]
        if len(xy) == 0:
            continue
        pts = shapely.points(xy)
        depth = inner_edges.distance(pts)
        k = int(np.argmax(depth))
        if not depth[k] > 1e-9:
            continue
        p, q = shapely.get_coordinates(inner_edges.shortest_line(pts[k]))
        bumps.setdefault(int(i), []).append((p, (q - p) / depth[k] * min(OVERSHOOT * depth[k], push)))
    return len(out)


def dent(placed: list[PlacedArt], region, gap: float, margin: float, min_gap: float, *,
         rounds: int = 3, radius: float = 1.0, push: float = 0.5, budget: float = 3.0,
         slack: float = 0.06, frozen: np.ndarray | None = None, rest: list[PlacedArt] | None = None,
         limits: np.ndarray | None = None, distortions: np.ndarray | None = None
         ) -> tuple[list[PlacedArt], DentResult]:
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
        limit keeps the largest share of its bumps that fits it (:func:`_within_limit`),
        and the rounds go on from it, frozen, so that its neighbours give way alone.
    distortions : (n,) array, optional
        Each element's distortion as it comes (:func:`~repulsionpak.verify.straighten`
        returns them): with ``limits``, an element stops bending once its bumps
        (:data:`SWEEP` × |v|ρ of area each) would take it past its limit, and its
        neighbours give way alone, so that few elements are bent past it and bent back.

    Returns
    -------
    art : list of PlacedArt
        The art, bent where it helped.
    result : DentResult

    Notes
    -----
    The rounds measure distances on outlines simplified within 1 % of the gap
    (Douglas–Peucker, and that much more asked of every distance): on exact outlines of
    detailed art the distance queries were most of the cost. Overlaps and the parts
    outside the margin are taken on the exact outlines.
    """
    n = len(placed)
    if n == 0 or rounds <= 0:
        return list(placed), DentResult((), (), ())
    frozen = np.zeros(n, bool) if frozen is None else np.asarray(frozen, bool)
    eps = 0.01 * gap
    target = min_gap * (1.0 + slack) + eps
    inner = shapely.buffer(region, -(margin * (1.0 + slack) + 0.01 * gap + eps))
    shapely.prepare(inner)
    inner_edges = Edges(inner)
    room = np.full(n, np.inf)  # the distortion each element may still take
    if limits is not None and distortions is not None:
        room = np.asarray(limits, float) - np.asarray(distortions, float)
    rho = radius * gap
    args = (target, inner, inner_edges, rounds, rho, push * gap, budget * gap, eps, room)
    two_rho2 = 2.0 * rho ** 2  # as _rounds bends: _within_limit bends again with the same bumps
    out, counts, steps = _rounds(list(placed), np.arange(n), frozen, *args)
    beyond: dict = {}  # what _over_limit found of each art it measured
    over = _over_limit(placed, out, rest, limits, beyond)
    if over:  # bent back to their limit and frozen, the rounds go on: their neighbours give way alone
        frozen = frozen.copy()
        frozen[over] = True
        for i, q in zip(over, _within_limit([(placed[i], steps[i], rest[i], limits[i]) for i in over], two_rho2)):
            out[i] = q
            beyond[i] = (q, False)  # (measured within its limit, or unbent: not measured again)
        out, more, later = _rounds(out, np.array(over), frozen, *args)
        counts += more
        over2 = _over_limit(placed, out, rest, limits, beyond)
        for i, q in zip(over2, _within_limit([(placed[i], steps.get(i, []) + later.get(i, []), rest[i], limits[i])
                                              for i in over2], two_rho2)):
            out[i] = q
        over = sorted(set(over) | set(over2))
    dented = tuple(i for i in range(n) if out[i] is not placed[i])
    return out, DentResult(tuple(counts), dented, tuple(over))


#: :func:`_within_limit` aims this share of the limit on the outlines it bisects with, so
#: that the written art, flattened from the bent curves, lands within it
AIM = 0.98


def _within_limit(jobs: list[tuple[PlacedArt, list[list], PlacedArt, float]], two_rho2: float) -> list[PlacedArt]:
    """For each job ``(placed, steps, rest, limit)``: ``placed`` bent by ``steps`` with
    every bump scaled by the largest share (to 1/64) that keeps it within its shape
    ``limit``; ``placed`` itself when none does.

    Notes
    -----
    An element whose dents take it past its limit keeps what part of them fits: unbent
    whole, its contacts were left to the repair, which shrank it about its centroid (on
    the heart with 30 animals a dog to 0.89 of its size for four contacts).

    Each job is its own: the bisections (GEOS overlays) run on
    :func:`~repulsionpak.threads.thread_map`'s threads and the bends of every job are
    taken together (:func:`_bent_many`); each job's steps are those it took alone."""
    def scaled(steps, a):
        return [[(c, a * v) for c, v in bumps] for bumps in steps]

    def bisect(job) -> float:
        placed, steps, rest, limit = job
        lo, hi = 0.0, 1.0
        for _ in range(6):
            mid = 0.5 * (lo + hi)
            art = placed.art
            for bumps in scaled(steps, mid):
                art = _bumped_outline(art, bumps, two_rho2)
            if rest_distortion(rest, placed, art) <= AIM * limit:
                lo = mid
            else:
                hi = mid
        return lo

    out = [placed for placed, _, _, _ in jobs]
    share = thread_map(bisect, jobs)
    todo = [k for k, lo in enumerate(share) if lo > 0.0]
    while todo:
        bent = _bent_many([(jobs[k][0], scaled(jobs[k][1], share[k])) for k in todo], two_rho2)
        fits = thread_map(lambda kb: rest_distortion(jobs[kb[0]][2], jobs[kb[0]][0], kb[1].art) <= jobs[kb[0]][3],
                          list(zip(todo, bent)))
        for k, b, ok in zip(todo, bent, fits):
            if ok:
                out[k] = b
            else:
                share[k] = 0.5 * share[k] if share[k] > 1 / 16 else 0.0
        todo = [k for k, ok in zip(todo, fits) if not ok and share[k] > 0.0]
    return out


#: the area a bump of vector v is taken to add to its element's distortion, in units of
#: |v|·ρ: the stop that keeps most elements within their shape limit. Alone, a bump sweeps
#: √(2π) ≈ 2.5 |v|ρ along one side of an outline; but the distortion is measured against
#: the best similarity, which takes up part of every bend, and an element's bumps overlap.
#: Measured: 4 stopped the heart's animals early (30 of them, seeds 1-3: area 0.509
#: against 0.521), 2 still early (0.519); 1 bends as far as no stop at all (0.521) and
#: leaves 37 of 470 elements of mixed-square-300 to be unbent (none stop: 261)
SWEEP = 1.0


def _rounds(out, which, frozen, target, inner, inner_edges, rounds, rho, push, budget, eps, room):
    """The rounds of :func:`dent` on the art ``out`` (changed in place), measuring the
    elements ``which`` first, then those each round bends (lengths in container units);
    returns (art, violations found in each round, each bent element's bump lists)."""
    n = len(out)
    two_rho2 = 2.0 * rho ** 2
    used = np.zeros(n)  # how far each element's contact points have been moved in all
    swept = np.zeros(n)  # the distortion its bumps are estimated to add
    spent = np.zeros(n, bool)
    counts = []
    exact = np.array(thread_map(operator.attrgetter("art"), out), dtype=object)
    geoms = shapely.simplify(exact, eps, preserve_topology=False)  # for distances only
    steps: dict[int, list] = {}  # each element's bump lists, applied to its art at the end
    for _ in range(rounds):
        bumps: dict[int, list] = {}
        blocked = frozen | spent
        found = (_pair_bumps(geoms, exact, target, blocked, push, 2.0 * rho, bumps, which)
                 + _edge_bumps(geoms, exact, inner, inner_edges, blocked, push, bumps, which))
        counts.append(found)
        bent = []
        for i, bl in bumps.items():
            moved = sum(float(np.hypot(*v)) for _, v in bl)
            area = exact[i].area
            add = SWEEP * moved * rho / area if area > 0 else np.inf
            if used[i] + moved > budget or swept[i] + add > room[i]:
                spent[i] = True
                continue
            used[i] += moved
            swept[i] += add
            steps.setdefault(i, []).append(bl)
            bent.append(i)
        if not bent:  # what is still too close is between elements that may not bend further
            break
        # the outlines measured next round: the art's outline under the same map (to the
        # flattening tolerance what the bent paths' union gives)
        for i in bent:
            exact[i] = _bumped_outline(exact[i], bumps[i], two_rho2)
        geoms[bent] = shapely.simplify(exact[bent], eps, preserve_topology=False)
        which = np.array(sorted(bent))
    for i, q in zip(steps, _bent_many([(out[i], st) for i, st in steps.items()], two_rho2)):
        out[i] = q
    return out, counts, steps


def _over_limit(placed, out, rest, limits, known: dict | None = None) -> list[int]:
    """The elements that ``out`` bends beyond their shape ``limits`` (measured as
    :func:`~repulsionpak.verify.straighten` does, against ``rest`` moved onto ``placed``).

    ``known`` maps an element to ``(art, beyond)``, what an earlier call found of the
    copy ``art``: an element whose copy in ``out`` is that same object is not measured
    again (a measure is one GEOS overlay). Filled with what this call measures."""
    if rest is None or limits is None:
        return []
    known = {} if known is None else known
    which = [i for i, (p, q) in enumerate(zip(placed, out)) if q is not p and np.isfinite(limits[i])]
    todo = [i for i in which if i not in known or known[i][0] is not out[i]]
    beyond = thread_map(lambda i: rest_distortion(rest[i], placed[i], out[i].art) > limits[i], todo)
    known.update((i, (out[i], b)) for i, b in zip(todo, beyond))
    return [i for i in which if known[i][1]]
