"""How many primaries each region of the container gets, where, and how big: size follows
the space.

The paper leaves the count to the user and gives every primary one common scale.
Without ``--count`` we pack container area / (``element_size`` · gap)² elements; in a
container narrower than that size (islands, peninsulas, a thin band) elements either
land nowhere near the narrow parts or cannot grow in them. Here the size an element
aims for follows the room around it: at a point of local width w (:mod:`repulsionpak.room`)
it is min(``element_size`` · gap, w); the count of each part is its area over that size
squared, at least one in every part wide enough for a primary (``min_element_size``
gaps); the positions are spread evenly for that size (farthest-point sampling in the
metric scaled by the local size); and each part gets its own scale, so its skins cover
``target_fraction`` of it, capped for each copy at what fits its local width.

A container that is even — one region, and less than ``UNEVEN_SHARE`` of it narrower
than the element size — is left to the paper's placement (:func:`is_even`), so round
containers pack exactly as before; so is a given count in one region, or in several
regions that are all wide (``repulsionpak.pack.room_placement``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from .params import PlacementParams
from .preprocess import Outline
from .room import Room
from .geometry.pockets import Pockets, fit_scales, outline_samples

#: a container whose share of area narrower than the element size is below this is even
UNEVEN_SHARE = 0.1

#: size classes of the primary templates (a copy's skin is built for its size ± 5 %)
SIZE_STEP = 1.1


@dataclass(frozen=True, eq=False)
class SizePlan:
    """Where the primaries go and at what scale (file → container units).

    ``position`` (M, 2), ``part`` (M,) index into ``room.parts``, ``library`` (M,) index into
    the element library, ``scale`` (M,) the nominal scale of each copy, already rounded to
    its size class (``SIZE_STEP``), ``size`` (M,) the local element size each copy aimed at,
    ``angle`` (M,) its start angle."""

    position: np.ndarray
    part: np.ndarray
    library: np.ndarray
    scale: np.ndarray
    size: np.ndarray
    angle: np.ndarray  # (M,) start angle of each copy (radians)


def size_field(room: Room, base: float, share: float = 1.0) -> np.ndarray:
    """(ny, nx) element size aimed at around every pixel: min(``base``, ``share`` × local
    width); 0 outside."""
    return np.where(room.part >= 0, np.minimum(base, share * room.width), 0.0)


def narrow_share(room: Room, base: float) -> float:
    """Share of the container's pixels whose local width is below ``base``."""
    inside = room.part >= 0
    return float((~room.wide(base)[inside]).mean()) if inside.any() else 0.0


def is_even(room: Room, base: float, share: float = UNEVEN_SHARE) -> bool:
    """True for one region whose area narrower than ``base`` is under ``share`` of it."""
    return len(room.parts) <= 1 and narrow_share(room, base) < share


def part_counts(room: Room, field: np.ndarray, gap: float, params: PlacementParams,
                count: int | None = None) -> np.ndarray:
    """(P,) primaries per part: the part's Σ pixel area / size², rounded, at least one in
    every part at least ``min_element_size`` gaps wide (none in the others). A given
    ``count`` is shared out in proportion to those numbers (largest remainders), one per
    holdable part first, widest parts first, while the count lasts."""
    P = len(room.parts)
    need = np.zeros(P)
    inside = (room.part >= 0) & (room.width >= params.min_element_size * gap)
    np.add.at(need, room.part[inside], room.h ** 2 / np.maximum(field[inside], room.h) ** 2)
    holdable = room.part_width() >= params.min_element_size * gap
    if not holdable.any():  # nothing is wide enough: the widest part takes them
        holdable[int(np.argmax(room.part_width()))] = True
    need[~holdable] = 0.0
    if count is None:
        return np.where(holdable, np.maximum(1, np.round(need)), 0).astype(np.int64)
    out = np.zeros(P, np.int64)
    order = np.argsort(-room.part_width(), kind="stable")
    for k in order:
        if holdable[k] and out.sum() < count:
            out[k] = 1
    left = count - int(out.sum())
    if left > 0:
        share = need / need.sum() * count - out
        share = np.maximum(share, 0.0)
        if share.sum() > 0:
            share = share / share.sum() * left
            base = np.floor(share).astype(np.int64)
            out += base
            rest = left - int(base.sum())
            out[np.argsort(-(share - base), kind="stable")[:rest]] += 1
    return out


def spread(room: Room, field: np.ndarray, counts: np.ndarray, rng: np.random.Generator,
           candidates_per_point: int = 30, min_width: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Positions for ``counts[k]`` primaries in each part ``k``: farthest-point sampling of
    jittered pixel centres at least a third of the local size deep and where the container
    is at least ``min_width`` wide, in the metric scaled by the local size (so narrow places
    get proportionally closer points). A part of one primary gets its deepest point.
    Returns ((M, 2) positions, (M,) part index)."""
    pos, which = [], []
    for k, n in enumerate(counts):
        if n <= 0:
            continue
        in_part = room.part == k
        if (in_part & (room.width >= min_width)).any():
            in_part &= room.width >= min_width
        deep = in_part & (room.depth >= field / 3.0)
        if deep.sum() < n:
            deep = in_part & (room.depth >= 0.5 * room.depth[in_part].max())
        c = room.centres(deep)
        d = room.at(c, field)
        if n == 1:
            pos.append(c[[int(np.argmax(room.at(c, room.depth)))]])
            which.append(k)
            continue
        m = len(c)
        take = rng.permutation(m)[:max(64, n * candidates_per_point)]
        c = c[take] + rng.uniform(-0.5, 0.5, (len(take), 2)) * room.h
        d = d[take]
        chosen = [int(rng.integers(len(c)))]
        key = ((c - c[chosen[0]]) ** 2).sum(axis=1) / d ** 2
        for _ in range(1, n):
            chosen.append(int(np.argmax(key)))
            key = np.minimum(key, ((c - c[chosen[-1]]) ** 2).sum(axis=1) / d ** 2)
        pos.append(c[chosen])
        which.extend([k] * n)
    if not pos:
        return np.empty((0, 2)), np.empty(0, np.int64)
    return np.vstack(pos), np.asarray(which, np.int64)


def fit_widths(outlines: Sequence[Outline]) -> np.ndarray:
    """(L,) geometric mean of the sides of each element's minimum rotated rectangle (file
    units): about the width an element needs across a band, turned its best way."""
    out = []
    for o in outlines:
        env = shapely.oriented_envelope(o.geometry)
        xy = np.asarray(env.exterior.coords) if env.geom_type == "Polygon" else np.zeros((3, 2))
        out.append(float(np.sqrt(max(np.hypot(*(xy[1] - xy[0])) * np.hypot(*(xy[2] - xy[1])), 1e-300))))
    return np.array(out)


#: parts of at most this many copies are split into cells, each copy fitted to its own
#: (every part with ``room_everywhere``)
SMALL_PART = 3


#: angles tried per copy when fitting it to the room at its position
ANGLE_TRIES = 12
#: scales tried per angle, from half the inscribed-circle fit to four times it
_STEPS = np.geomspace(0.5, 4.0, 37)
#: a copy takes the least used element among those whose fitted art is at least this share
#: of the best one's (variety over a little area)
CLOSE_FIT = 0.8


def fit_in_room(room: Room, point: np.ndarray, samples: np.ndarray, angles: np.ndarray,
                offset: float, depth: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(A,) the largest scale (file → container units) at which the outline ``samples``
    (:func:`repulsionpak.geometry.pockets.outline_samples`), turned by each of ``angles`` and
    centred on ``point``, keeps ``offset`` from the container's edge — or, given ``depth``
    = (grid, origin) (a grid of ``room``'s pixels whose pixel (0, 0) has its corner at
    ``origin``, 0 off it), from wherever that falls to 0 — at every sample; the scales
    tried run from half to four times the inscribed-circle fit."""
    grid, origin = (room.depth, room.origin) if depth is None else depth
    pockets = Pockets(grid, float(origin[0]), float(origin[1]), room.h,
                      np.zeros(1), np.zeros(1, np.int64), np.zeros(1, np.int64))
    radius = float(np.sqrt((samples ** 2).sum(axis=1).max()))
    d = float(pockets.lookup(np.asarray(point, float)))
    s_round = max(d - offset, 0.25 * d) / max(radius, 1e-300)
    return fit_scales(pockets, point, samples, angles, offset, s_round, _STEPS)


def _nearest(c: np.ndarray, p: np.ndarray, chunk: int = 16384) -> np.ndarray:
    """(K,) index of the nearest of points ``p`` (n, 2) to each of ``c`` (K, 2), in chunks."""
    out = np.empty(len(c), np.int64)
    pp = (p ** 2).sum(axis=1)
    for a in range(0, len(c), chunk):
        q = c[a:a + chunk]
        out[a:a + chunk] = np.argmin(pp[None, :] - 2.0 * q @ p.T, axis=1)
    return out


#: a cell's bisectors are taken with this many nearest other copies
CELL_NEIGHBOURS = 12


def cells(room: Room, part: int, points: np.ndarray, rounds: int = 8) -> tuple[np.ndarray, list]:
    """Split part ``part`` among ``points`` (n, 2): a few rounds of Lloyd's relaxation
    (each point moves to the centroid of the pixels nearest it), then each cell's depth
    grid — the distance to the container's edge or to the bisector with another cell
    (its ``CELL_NEIGHBOURS`` nearest), whichever is nearer, 0 outside the cell — and its
    deepest point (the centre of the largest disc in the cell). Returns ((n, 2) centres,
    n (grid, origin) pairs: each grid covers its cell's bounding box only, ``origin`` its
    corner)."""
    mask = room.part == part
    c = room.centres(mask)
    jj, ii = np.nonzero(mask)
    p = np.asarray(points, float).copy()
    n = len(p)
    near = np.zeros(len(c), np.int64)
    for _ in range(rounds if n > 1 else 0):
        near = _nearest(c, p)
        sums = np.zeros((n, 2))
        np.add.at(sums, near, c)
        cnt = np.bincount(near, minlength=n)
        p[cnt > 0] = sums[cnt > 0] / cnt[cnt > 0, None]
    if n > 1:
        near = _nearest(c, p)
    grids, centres = [], []
    for k in range(n):
        sel = np.nonzero(near == k)[0]
        if len(sel) == 0:  # an empty cell: its point, no room
            grids.append((np.zeros((1, 1)), room.origin))
            centres.append(p[k])
            continue
        ck = c[sel]
        d = room.depth[jj[sel], ii[sel]].copy()
        others = np.argsort(((p - p[k]) ** 2).sum(axis=1))[1:CELL_NEIGHBOURS + 1]
        for j in others:
            u = p[j] - p[k]
            L = float(np.hypot(*u))
            if L > 0:
                d = np.minimum(d, ((0.5 * (p[k] + p[j]) - ck) @ u) / L)
        j0, i0 = int(jj[sel].min()), int(ii[sel].min())
        g = np.zeros((int(jj[sel].max()) - j0 + 1, int(ii[sel].max()) - i0 + 1))
        g[jj[sel] - j0, ii[sel] - i0] = np.maximum(d, 0.0)
        grids.append((g, room.origin + room.h * np.array([i0, j0])))
        centres.append(ck[int(np.argmax(d))])
    return np.array(centres), grids


def plan_sizes(room: Room, outlines: Sequence[Outline], gap: float, offset: float, params: PlacementParams,
               rng: np.random.Generator, count: int | None = None) -> SizePlan:
    """The primaries of a container, placed by the room it has: count per part
    (:func:`part_counts`), positions (:func:`spread`, then :func:`cells`), elements, scales
    and start angles.

    A part of at most ``SMALL_PART`` copies (every part with ``room_everywhere``) is split
    into one cell per copy; each copy is centred on its cell's deepest point and fitted to
    the cell (:func:`fit_in_room`, its art ``offset`` + 0.1 gap from
    the cell's edge, where the skin rests): it takes the element whose fitted copy holds
    the most art (the least used of those within ``CLOSE_FIT`` of the best, and no element
    more than ``variety`` × its share of the copies while others are left), and the angle
    of that fit; the copies of larger parts cycle through the shuffled library at random
    angles, capped at the local width across them (on the suite's uneven default-count
    scenes, cells there lost up to 0.05 of area). Each part's copies share one scale at
    which their skins cover ``target_fraction`` of the part, each capped (the common scale is solved with
    the caps, so copies that cannot reach it leave their share to the others); a copy
    starts at the first of its angles that fits that scale. Scales are rounded down to
    classes ``SIZE_STEP`` apart, so copies of one element share a few templates.

    Notes
    -----
    The paper assigns the elements cyclically at random angles and lets the simulation
    sort them; in a jam it cannot: an animal whose limbs point at its neighbours stays
    stunted. Chosen for its cell, each copy starts where it fits.
    """
    base = params.element_size * gap
    field = size_field(room, base, params.width_share)
    counts = part_counts(room, field, gap, params, count)
    position, part = spread(room, field, counts, rng, params.candidates_per_point,
                            params.min_element_size * gap)
    samples = [outline_samples(o) for o in outlines]
    art = np.array([o.geometry.area for o in outlines])
    edge = offset + 0.1 * gap
    M = len(position)
    L = len(outlines)
    order = rng.permutation(L)
    library = order[np.arange(M) % L]
    size = room.at(position, field)
    angles = rng.uniform(0.0, 2 * np.pi, (M, ANGLE_TRIES)) if params.rotate else np.zeros((M, 1))
    celled = (counts[part] <= SMALL_PART) | params.room_everywhere
    depth_of: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for k in np.unique(part[celled]):
        idx = np.nonzero(part == k)[0]
        centres, grids = cells(room, int(k), position[idx])
        for i, c, g in zip(idx, centres, grids):
            position[i], depth_of[int(i)] = c, g
    fits = {}  # (copy, element) -> (A,) fitted scales

    def fit(k, i):
        if (k, i) not in fits:
            fits[k, i] = fit_in_room(room, position[k], samples[i], angles[k], edge, depth_of[k])
        return fits[k, i]

    most = max(1, int(np.ceil(params.variety * M / L)))
    used = np.zeros(L, np.int64)
    roomy = np.array([float(depth_of[k][0].max()) if celled[k] else np.inf for k in range(M)])
    for k in np.argsort(roomy, kind="stable"):  # the tightest cells choose first
        if not celled[k]:  # a copy of a large part: the shuffled cycle, as the paper's
            used[library[k]] += 1
            continue
        best = np.array([art[i] * fit(k, i).max() ** 2 for i in range(L)])
        free = used < most
        pool = best if not free.any() else np.where(free, best, -1.0)
        close = np.nonzero(pool >= CLOSE_FIT * pool.max())[0]
        library[k] = close[np.argmin(used[close])]
        used[library[k]] += 1
    # each copy's largest scale: its fit to its cell, or (a copy of a large part, which will
    # move) the local width across it, turned its best way
    fitw = fit_widths(outlines)
    local = room.at(position, room.width)
    cap = np.array([float(fit(k, int(library[k])).max()) if celled[k] else
                    max(local[k] - 2.0 * edge, 0.5 * gap) / fitw[library[k]] for k in range(M)])
    areas = room.part_area()
    scale = np.zeros(M)
    for k in np.unique(part):
        idx = np.nonzero(part == k)[0]
        target = params.target_fraction * areas[k]

        def total(s, idx=idx):
            return sum(outlines[library[i]].skin_area(min(s, cap[i]), offset) for i in idx)

        lo, hi = 0.0, 1.0
        while total(hi) < target and total(hi) < total(2.0 * hi):
            hi *= 2.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if total(mid) < target else (lo, mid)
        scale[idx] = np.minimum(0.5 * (lo + hi), cap[idx])
    angle = angles[:, 0].copy()
    for k in np.nonzero(celled)[0]:
        f = fit(k, int(library[k]))
        ok = np.nonzero(f >= scale[k] * (1.0 - 1e-9))[0]
        angle[k] = angles[k, int(ok[0]) if len(ok) else int(np.argmax(f))]
    ref = float(scale.max())
    cls = np.floor(np.log(scale / ref) / np.log(SIZE_STEP) + 1e-9)
    scale = ref * SIZE_STEP ** cls
    return SizePlan(position, part, library, scale, size, angle)
