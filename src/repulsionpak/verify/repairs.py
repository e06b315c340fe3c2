"""The repairs of a packing's promises: move, shrink, drop, grow, gather, straighten.

:func:`verify_and_repair` runs them on the art of every element, measuring with
:mod:`repulsionpak.verify.checks`. An element that breaks a promise is first *moved*
away from what it is too close to (local separation, a few rounds: a moved element may
make room for, or crowd, its neighbours; a round's moves stay only if they lower the sum
of what every element needs), then *shrunk* by just enough (both are
similarities: its shape is untouched) about its own centroid, or about the point of it
that moves its contacts away with clearly less shrink
(:func:`~repulsionpak.verify.checks._shrink_centre`). Of two primaries too close, the
smaller one shrinks, until it has shrunk half-way to ``min_scale``: then the other one
does. A primary that would have to shrink below ``min_scale``, or that still breaks a
promise after the rounds, is *put where there is room* (:func:`_rescue`: whole, or at
least at ``min_scale``, in one of the largest free parts); one that fits nowhere (and a
secondary below half ``min_scale``: small by nature) is *dropped*, with a warning naming
it. Then every element *grows* back into the room left around it (:func:`_inflate`) and
lonely elements *gather* towards their nearest neighbour (:func:`_gather`). What remains
is verified once more, exactly, and reported; the CLI exits non-zero if anything is
still violated (on valid input it never is). Before all this, :func:`straighten` replaces
a copy bent beyond its limit by its unbent, similar copy.
"""

from __future__ import annotations

import dataclasses
import operator
import warnings
from collections.abc import Callable

import numpy as np
import shapely

from ..art_area import _polygonal
from ..geometry.dilate import covering, room_left
from ..geometry.edges import Edges
from ..geometry.pairwise import near_pairs
from ..render.placed import refined, similarity_matrix
from ..threads import thread_map
from ..types import PlacedArt, transformed_paths
from .checks import (Rough, Verification, _check, _edge_distance, _nearest, _pair_distances, _shrink_centre,
                     distortion)

__all__ = ["scaled_art", "similar_copy", "straighten", "verify_and_repair"]


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
    paths = transformed_paths(placed.paths, f)
    frame = placed.frame
    if frame is not None:  # the same similarity, as a matrix
        m = np.eye(3)
        m[:2, :2] = r
        m[:2, 2] = t - r @ c
        frame = m @ frame
    return dataclasses.replace(placed, paths=paths, stroke_scale=placed.stroke_scale * scale, frame=frame)


def _similarity(rest: PlacedArt, placed: PlacedArt) -> tuple[np.ndarray, dict]:
    """The similarity (3, 3) of :func:`similar_copy`, and the copy's fields it sets
    besides its paths (its ``frame``, when both carry one)."""
    extra = {}
    if placed.frame is not None and rest.frame is not None:
        m = np.asarray(placed.frame, dtype=float) @ np.linalg.inv(np.asarray(rest.frame, dtype=float))
        extra["frame"] = m @ np.asarray(rest.frame, dtype=float)
    else:
        src = np.concatenate([p for a in rest.paths for p in a.subpaths])
        cur = np.concatenate([p for a in placed.paths for p in a.subpaths])
        m = similarity_matrix(src, cur)
    return m, extra


def similar_copy(rest: PlacedArt, placed: PlacedArt) -> PlacedArt:
    """The undeformed art ``rest`` moved, turned and scaled onto ``placed`` (least squares
    over their corresponding vertices, or the meshes' similarity ``frame`` when both carry
    one — rendered curves have no vertex correspondence): what the element would look like
    unbent."""
    m, extra = _similarity(rest, placed)
    rot, b = m[:2, :2], m[:2, 2]
    paths = transformed_paths(rest.paths, lambda pts: np.asarray(pts) @ rot.T + b)
    k = float(np.sqrt(abs(np.linalg.det(rot))))
    return dataclasses.replace(placed, paths=paths, stroke_scale=rest.stroke_scale * k, deformation=0.0, **extra)


def rest_distortion(rest: PlacedArt, placed: PlacedArt, art=None) -> float:
    """The distortion of ``art`` (default ``placed.art``): its symmetric difference with
    the rest art ``rest`` moved onto ``placed`` by their similarity, over its area."""
    m, _ = _similarity(rest, placed)
    moved = shapely.affinity.affine_transform(rest.art, [m[0, 0], m[0, 1], m[1, 0], m[1, 1], m[0, 2], m[1, 2]])
    return distortion(placed.art if art is None else art, moved)


#: a distortion this close to its limit is measured on the similar copy's own art
#: (:func:`straighten`), not on its rest art moved
DECIDE_EXACTLY = 1e-4


def straighten(placed: list[PlacedArt], rest: list[PlacedArt], limits: np.ndarray
               ) -> tuple[list[PlacedArt], np.ndarray, list[int]]:
    """Keep shapes: an element whose distortion (symmetric difference with its unbent,
    similar copy, over its area) exceeds ``limits[i]`` is replaced by that copy (the
    repair that follows makes room for it). Returns (art, distortion of each element as
    it is returned, indices replaced). A copy's curves are flattened as the placed art's
    were (:func:`refined` at its tolerance), so that the repair measures what is written.

    Notes
    -----
    The similar copy's art is its rest art (``rest[i].art``, measured once for the copies
    that share a rest object) moved by the similarity: the art of the moved paths up to
    rounding. A distortion within :data:`DECIDE_EXACTLY` of its limit is measured again
    on the moved paths' own art, so the choice is the one that art gives. The copies are
    measured on :func:`~repulsionpak.threads.thread_map`'s threads (GEOS overlays)."""
    for r in {id(r): r for r in rest}.values():  # the shared rest arts once, before the threads
        r.art  # noqa: B018

    def one(i: int) -> tuple[PlacedArt, float, bool]:
        p, r = placed[i], rest[i]
        d = rest_distortion(r, p)
        copy = None
        if abs(d - limits[i]) <= DECIDE_EXACTLY:
            copy = similar_copy(r, p)
            d = distortion(p.art, copy.art)
        if d > limits[i]:
            copy = similar_copy(r, p) if copy is None else copy
            return dataclasses.replace(copy, paths=tuple(refined(a, p.tolerance) for a in copy.paths)), 0.0, True
        return p, d, False

    done = thread_map(one, range(len(placed)))
    out = [o for o, _, _ in done]
    dist = np.array([d for _, d, _ in done], dtype=float)
    replaced = [i for i, (_, _, r) in enumerate(done) if r]
    return out, dist, replaced


def _moved(g, scale: float, angle: float, centre, dx: float, dy: float):
    """Outline ``g`` scaled by ``scale`` and turned by ``angle`` (radians) about ``centre``,
    then moved by (dx, dy): the similarity the repair, the growth and the gathering apply
    (:func:`scaled_art` applies it to the art)."""
    g = shapely.affinity.scale(g, scale, scale, origin=tuple(centre))
    if angle:
        g = shapely.affinity.rotate(g, angle, origin=tuple(centre), use_radians=True)
    return shapely.affinity.translate(g, dx, dy)


#: the free parts (largest first) where :func:`_rescue` looks for room for an element
RESCUE_PARTS = 4


def _rescue(i, geoms, base, scale, shift, angle, centre, room, lowest, eps, max_turn=None):
    """Put element ``i`` (not alive: the rounds could not keep it) where there is room.

    ``room`` is the free space: the container shrunk by the margin minus every alive
    outline dilated by the gap floor (:func:`~repulsionpak.geometry.dilate.room_left`). In each of its
    :data:`RESCUE_PARTS` largest parts the element is centred on the part's largest
    inscribed circle, turned as it is or by a multiple of 30° (within ``max_turn[i]``
    radians of no turn, when given) and scaled (about its centroid, bisection) to the
    largest share in [``lowest``, 1] of its size in ``base`` that the part contains. The
    largest fit is taken: ``scale``, ``shift``, ``angle`` and ``geoms`` are updated.
    Returns whether it fitted.

    Notes
    -----
    Moves and shrinks are local: an element squeezed into a neck of the container (a
    logo between the GitHub mark's tail and its rim) or into the tip of a crescent's horn
    cannot leave it, while room for it may be left elsewhere (the leftover fill then put
    small copies there). Only the rounds' outlines are used; the final check is exact."""
    parts = [q for q in getattr(room, "geoms", [room]) if isinstance(q, shapely.Polygon) and not q.is_empty]
    parts.sort(key=lambda q: -q.area)
    need_area = lowest ** 2 * base[i].area  # the element at its smallest
    turns = angle[i] + np.radians(30.0) * np.array([0, 1, -1, 2, -2, 3, -3, 4, -4, 5, -5, 6])
    if max_turn is not None:
        turns = turns[np.abs(turns) <= max_turn[i] + 1e-12]
    best = None
    for part in parts[:RESCUE_PARTS]:
        if part.area < need_area:
            break
        shapely.prepare(part)
        circle = shapely.maximum_inscribed_circle(part, eps)
        dx, dy = np.asarray(circle.coords[0]) - centre[i]
        for turn in turns:
            def fits(s):
                return part.contains(_moved(base[i], s, turn, centre[i], dx, dy))

            lo, hi = lowest if best is None else max(lowest, best[0]), 1.0
            if lo > hi or not fits(lo):
                continue
            if fits(hi):
                lo = hi
            else:
                for _ in range(10):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if fits(mid) else (lo, mid)
            if best is None or lo > best[0]:
                best = (lo, dx, dy, turn)
            if best[0] >= 1.0:  # whole: nothing fits larger
                break
        if best is not None and best[0] >= 1.0:
            break
    if best is None:
        return False
    scale[i], shift[i], angle[i] = best[0], (best[1], best[2]), best[3]
    geoms[i] = _moved(base[i], scale[i], angle[i], centre[i], shift[i][0], shift[i][1])
    return True


#: the most the skins' extra width (``grow_reach``) lets the final growth scale an element
REACH_MAX_SCALE = 2.0


def _inflate(geoms, base, alive, scale, shift, centre, region, edges, target, margin,
             max_scale, tol, rounds, inner=None, fixed=None, reach=0.0, memo=None):
    """Grow every element about its centroid into the room around it, never closer than
    ``target`` to another element nor ``margin`` to the edge, and no bigger than
    ``max_scale`` of its size — or than the size at which its outermost point has moved
    ``reach`` (container units), when that is more, up to :data:`REACH_MAX_SCALE` (small
    elements: see :func:`verify_and_repair`): each round, an element with slack s (half the spare
    distance to its nearest neighbour, or the spare distance to the edge) grows by
    1 + s/R, R its largest radius, so none of its points moves further than s (all grow at
    once, so a pair never closes more than its spare distance). ``memo``: pair distances
    of unchanged outlines (:func:`~repulsionpak.verify.checks._pair_distances`): the
    elements that stopped growing keep theirs."""
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
        edge = edges.distance(arr[q])  # inside: the rounds before made sure
        # a round grows an element by at most 1.5 targets: neighbours farther than 4
        # targets cannot limit it
        slack = np.full(len(idx), np.inf)
        slack[q] = np.minimum(edge - margin, 1.5 * target)
        a, b = near_pairs(arr, q, 4.0 * target)
        a = q[a]
        keep = a != b
        pairs = np.unique(np.sort(np.stack([a[keep], b[keep]], axis=1), axis=1), axis=0)
        if len(pairs):  # each pair measured once, for whichever of the two may grow
            d = 0.5 * (_pair_distances(arr[pairs[:, 0]], arr[pairs[:, 1]], memo) - target)
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


def _gather(geoms, base, alive, scale, shift, angle, centre, region, edges, target, threshold,
            margin, tol, rounds=6, fixed=None, max_turn=None):
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
    from every element. Only the elements whose bounding boxes come within ``reach`` of
    its own are measured; the others are at least ``reach`` away, so a move is bounded by
    (min(distance, reach) − target). A straight move that would come closer than
    ``margin`` to the edge is tried again turned (about the element's centre, by up to
    the angle that moves its farthest point as far as the step: an element that fills the
    width of a curved band slides along it only so), at half the step so the travel bound
    holds, and
    halved until the margin is kept. None crosses what is not the container (the segment
    between the two nearest points must lie in ``region``). Elements move one at a time,
    the loneliest first; the rounds repeat while moves help. ``max_turn[i]`` (radians)
    bounds the total turn of element ``i``: 0 for an element whose rotation the designer
    fixed or limited, which therefore only slides."""
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
            # what lies beyond ``reach`` was not measured: it is at least that far, and a
            # nearest neighbour farther than that does not bound the move by itself
            budget = min(d, reach) - target - tol
            g = moved_copy(i, budget, u, 0.0)
            ok = edges.distance(g) - margin > tol
            step, v, turn = budget, u, 0.0
            if not ok and i not in stuck:  # turned: the step and the turn share the travel budget
                c = np.asarray(shapely.get_coordinates(geoms[i])) - (centre[i] + shift[i])
                radius = float(np.sqrt((c ** 2).sum(axis=1).max())) if len(c) else 0.0
                for step in (0.5 * budget, 0.25 * budget, 0.125 * budget) if radius > 0 else ():
                    for cb, sb, k in tries:
                        v = np.array([u[0] * cb - u[1] * sb, u[0] * sb + u[1] * cb])
                        turn = k * step / radius
                        if max_turn is not None and abs(angle[i] + turn) > max_turn[i]:
                            continue
                        g = moved_copy(i, step, v, turn)
                        if edges.distance(g) - margin > tol:
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


def _drop_violators(geoms, alive, need, region, edges, min_gap: float, margin: float, tol: float,
                    fixed, rank, memo) -> None:
    """Drop the elements that still violate a promise after the repair (``need > 0``),
    as few as keep the rest: one outside or nearer the edge than ``margin`` goes; of
    elements nearer each other than ``min_gap``, the lower ranked (a pocket copy), else
    the smaller, goes first, and one whose every such neighbour went stays. A pinned
    element (``fixed``) is never dropped. Updates ``alive`` in place.

    Notes
    -----
    Both elements of a pair a little too close carry a need, so dropping every element
    with one lost both where one was enough (a repair stopped by the user early, or a
    pair the rounds could not part).
    """
    bad = [int(i) for i in np.flatnonzero((need > 0) & alive) if fixed is None or not fixed[i]]
    if not bad:
        return
    idx = np.flatnonzero(alive)
    arr = np.array([geoms[i] for i in idx], dtype=object)
    rows = np.searchsorted(idx, bad)
    a, b = near_pairs(arr, rows, min_gap)
    a = rows[a]
    keep = a != b
    a, b = a[keep], b[keep]
    d = _pair_distances(arr[a], arr[b], memo)  # (the final check's memo: measured there)
    close = d < min_gap - tol
    partners: dict[int, list[int]] = {}
    for p, q in zip(idx[a[close]], idx[b[close]]):
        partners.setdefault(int(p), []).append(int(q))
    for i in sorted(bad, key=lambda k: (rank[k], geoms[k].area, k)):
        if (_edge_distance(edges, region, geoms[i]) < margin - tol
                or any(alive[j] for j in partners.get(i, ()))):
            alive[i] = False


def verify_and_repair(placed: list[PlacedArt], region, gap: float, margin: float, min_gap: float,
                      min_scale: float = 0.5, rounds: int = 24, repair: bool = True,
                      straightened: list | None = None, grow_to: float = 0.0,
                      max_scale: float = 1.15, should_stop: Callable[[], bool] | None = None,
                      grow_reach: float = 0.0, gather: float = 0.0,
                      max_turn: np.ndarray | None = None) -> tuple[list[PlacedArt], Verification]:
    """Check (and, with ``repair``, enforce) the promises on the art of ``placed``.

    Parameters
    ----------
    placed : list of PlacedArt
        The packing's art.
    region : shapely geometry
        The container.
    gap : float
        The gap asked for (container units); the rounds simplify outlines by 1 % of it.
    margin, min_gap : float
        The edge margin and the gap floor enforced (container units).
    min_scale : float
        Below this share of its size a primary is dropped (half of it for secondaries).
    rounds : int
        Repair rounds (moves first, then shrinks).
    repair : bool
        False: only check.
    straightened : list of int, optional
        Indices :func:`straighten` replaced, passed into the result.
    grow_to : float
        > 0: elements then grow into the room left around them (:func:`_inflate`) until
        they are this far from their neighbours, up to ``max_scale`` of their size, or
        until their outermost point has moved ``grow_reach`` when that is more (at most
        :data:`REACH_MAX_SCALE`).
    max_scale, grow_reach : float
        The growth's limits (see ``grow_to``).
    should_stop : callable, optional
        ``should_stop()`` true ends the repair rounds early (Ctrl-C while very detailed
        art is repaired): what still violates is then dropped.
    gather : float
        > ``grow_to``: elements farther than this from their nearest neighbour then move
        towards it until they are ``grow_to`` apart (:func:`_gather`).
    max_turn : (n,) array, optional
        The most the gathering may turn each element (radians; default: any turn). The
        simulation keeps a fixed or limited rotation; the repair must not undo it.

    Returns
    -------
    art : list of PlacedArt
        The art, moved or shrunk where repaired, without the dropped elements.
    verification : Verification
        The exact check of what is returned.

    Notes
    -----
    The room the skins' extra width leaves between two arts is the same in container
    units whatever the elements' size, so an element not much wider than the gap needs
    more than ``max_scale`` to close it: hence ``grow_reach``. Whatever is still violated
    after the rounds is dropped (never a pinned copy; of a pair too close, the lower
    ranked or smaller one: :func:`_drop_violators`), so the promises hold on the returned
    art even when the rounds are stopped.
    """
    region = _polygonal(region)
    edges = Edges(region)  # the container's edge, indexed: distances cost what is near
    shapely.prepare(region)
    tol = 1e-9 * max(1.0, float(np.ptp(np.asarray(region.bounds))))
    n = len(placed)
    exact = thread_map(operator.attrgetter("art"), placed)
    centre = [np.asarray(g.centroid.coords[0]) if not g.is_empty else np.zeros(2) for g in exact]
    # the rounds work on outlines simplified by eps and ask eps more of every distance
    # (exact checks are the slow part with detailed art); the final check is exact
    eps = 0.01 * max(min_gap, gap * 0.5)
    base = thread_map(lambda g: shapely.simplify(g, eps, preserve_topology=True), exact)  # (GEOS: on threads)
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
    shapes: dict = {}  # and what else the checks measure of them

    def check(exact_edges=False, contacts=None):
        return _check(geoms, alive, region, edges, w_gap, w_margin, tol, inner, exact_edges, fixed, rank,
                      contacts, scale < halfway, memo, shapes=shapes)

    def move(i, ln):
        """The step that takes element i its need (plus the slack) along its push (length ln)."""
        return push[i] * min(1.0 + slack / need[i], (need[i] + slack) / ln)

    def undo(moves, mark_stuck):
        for i, step in moves:
            shift[i] -= step
            stuck[i] |= mark_stuck
            place(i)

    def keep_helpful(moved, before, mark_stuck):
        """Undo the moves that did not lower their own element's need below ``before``,
        then the others too if together they did not lower the sum of every need (in a
        jam, a move clears its own contact by pressing the neighbour behind it)."""
        after = check()[0]
        kept = [(i, step) for i, step in moved if after[i] < before[i]]
        unhelpful = [(i, step) for i, step in moved if after[i] >= before[i]]
        undo(unhelpful, mark_stuck)
        if kept and (check()[0] if unhelpful else after).sum() >= before.sum():
            undo(kept, mark_stuck)

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
    if repair and not stopped:  # a primary the rounds could not keep may fit elsewhere
        need = check()[0]  # (asks eps more of every distance: the exact check may pass below it)
        lost = [i for i in np.flatnonzero((~alive | (need > eps)) & (rank > 0))
                if not exact[i].is_empty and (fixed is None or not fixed[i])]
        if lost:  # the room the others leave, measured once; then each one's in turn
            others = np.ones(n, bool)
            others[lost] = False
            reach = covering(w_gap + eps)
            room = room_left(inner, [geoms[j] for j in np.flatnonzero(alive & others)], reach)
            for i in lost:
                was = alive[i], scale[i], shift[i].copy(), angle[i]
                alive[i] = False
                free = room_left(room, [geoms[j] for j in lost if j != i and alive[j]], reach)
                if _rescue(i, geoms, base, scale, shift, angle, centre, free, float(lowest[i]), eps,
                           max_turn):
                    alive[i] = True
                else:
                    alive[i], scale[i], shift[i], angle[i] = was
                    place(i)
    if repair and grow_to > 0 and not stopped:  # give back the room the repair (or the simulation) left
        _inflate(geoms, base, alive, scale, shift, centre, region, edges, grow_to + 2 * eps,
                 w_margin, max_scale, tol, rounds=8, inner=inner, fixed=fixed, reach=grow_reach, memo=memo)
        if gather > grow_to:
            _gather(geoms, base, alive, scale, shift, angle, centre, region, edges, grow_to + 2 * eps,
                    gather + 2 * eps, w_margin, tol, fixed=fixed, max_turn=max_turn)
    # final verification, exact, on what is returned; the rounds' outlines (each within
    # eps of its exact one, scaled as it is) tell which pairs need no exact measure
    rough = Rough(geoms, eps * scale, memo)
    geoms = [transform(exact[i], i) for i in range(n)]
    final: dict = {}  # a second check after drops measures no pair again
    need, rel, push, counts, dmin, emin = _check(geoms, alive, region, edges, min_gap, margin, tol,
                                                 exact_edges=True, fixed=fixed, rank=rank, memo=final,
                                                 rough=rough)
    if repair and (need > 0).any():  # what still violates after the rounds is dropped
        _drop_violators(geoms, alive, need, region, edges, min_gap, margin, tol, fixed, rank, final)
        need, rel, push, counts, dmin, emin = _check(geoms, alive, region, edges, min_gap, margin,
                                                     tol, exact_edges=True, fixed=fixed, rank=rank,
                                                     memo=final, rough=rough)
        if (need > 0).any():  # (not expected: every violator dropped, as a last resort)
            for i in np.flatnonzero(need > 0):
                if fixed is None or not fixed[i]:
                    alive[i] = False
            need, rel, push, counts, dmin, emin = _check(geoms, alive, region, edges, min_gap, margin,
                                                         tol, exact_edges=True, fixed=fixed, rank=rank,
                                                         memo=final, rough=rough)
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
