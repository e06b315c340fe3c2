"""Secondary elements (sec. 9): seed the pockets the primaries left, grow them with the
primaries frozen (they still repel and can be overlapped into, but never move)."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np
import shapely

from .controls import any_controls, controls_of, initial_angles, setup_model, weighted_assignment
from .measure.raster import rasterize
from .geometry.edt import distance_transform
from .geometry.pockets import Pockets, best_fit, outline_samples
from .params import SecondaryParams
from .placement import Placement
from .preprocess import build_template, outline_of
from .sim.model import build_model
from .sim.phase import bend_limits, neighbour_cell
from .sim.runner import Simulator, Snapshot
from .types import Element


#: seeds in a pocket of half-width d (distance to the primaries' skins): a copy there
#: grows until its skin (0.6 gap) fills the width, about 2(d − 0.6 gap) across, so copies
#: a gap apart stand 2d − 0.2 gap apart; seeds taken in random order with an exclusion
#: radius r end 1.34 r apart on average (random sequential adsorption in a row), so
#: r = (2d − 0.2 gap) / 1.34 = _SPACING·d − 0.15 gap
_SPACING = 2.0 / 1.34


def pocket_seeds(region, skins: Sequence[np.ndarray], gap: float, params: SecondaryParams) -> Pockets:
    """Seed points far from every mesh and from the container boundary.

    Distance transform of the negative space on a grid of ``params.grid`` pixels along
    the container's longer side (more for a small gap, :func:`pocket_grid`); candidates
    are pixels whose distance is above d_min = ``params.d_min``·gap, taken by decreasing
    distance and kept when no kept seed claims them: a seed at distance d claims the disc
    of radius d_sep = ``params.d_sep``·gap (sec. 9) or, when more, 2d/1.34 − 0.15·gap
    (:data:`_SPACING`): a round pocket gets one seed that grows to fill it, and a band of
    half-width d a row of seeds about as far apart as copies as wide as the band, a gap
    apart, stand (a claim of radius d alone gives twice as many, smaller copies in wide
    bands, each with its own gap ring: the suite's mean area 0.559 against 0.563).
    """
    polys = [shapely.make_valid(shapely.Polygon(s)) for s in skins]
    bounds = region.bounds
    grid = pocket_grid(bounds, gap, params.grid)
    cont, info = rasterize([region], bounds, grid=grid)
    occ, _ = rasterize(polys, bounds, grid=grid)
    h = info["pixel_size"]
    neg = cont & ~occ
    dist = distance_transform(neg, h)
    d_min = params.d_min * gap
    d_sep = params.d_sep * gap
    none = np.zeros(0, np.int64)
    iy, ix = np.nonzero(dist > d_min)
    if len(iy) == 0:
        return Pockets(dist, info["x0"], info["y0"], h, np.zeros(0), none, none)
    d = dist[iy, ix]
    order = np.argsort(-d, kind="stable")
    iy, ix, d = iy[order], ix[order], d[order]
    # greedy, deepest first: a kept seed claims the room its copy will take (see above),
    # so a large pocket gets one seed, not a crowd of them
    blocked = np.zeros(dist.shape, bool)
    ny, nx = dist.shape
    out = []
    at = iy * nx + ix  # the candidates' pixels in the raveled raster
    k = _next_free(blocked.ravel(), at, 0)
    while k < len(d):
        if params.max_count is not None and len(out) >= params.max_count:
            break  # (checked first: max_count = 0 still seeded one)
        out.append(k)
        r = max(d_sep, _SPACING * float(d[k]) - 0.15 * gap) / h
        y0, y1 = max(0, int(iy[k] - r)), min(ny, int(iy[k] + r) + 1)
        x0, x1 = max(0, int(ix[k] - r)), min(nx, int(ix[k] + r) + 1)
        yy, xx = np.ogrid[y0:y1, x0:x1]
        blocked[y0:y1, x0:x1] |= (yy - iy[k]) ** 2 + (xx - ix[k]) ** 2 < r * r
        k = _next_free(blocked.ravel(), at, k + 1)
    out = np.asarray(out, dtype=np.int64)
    return Pockets(dist, info["x0"], info["y0"], h, d[out], iy[out], ix[out])


#: the pocket raster has at least this many pixels across a gap (its longer side at least
#: ``secondary.grid`` pixels, more where the gap is small beside the container) ...
PIXELS_PER_GAP = 6.0
#: ... up to this many pixels along its longer side
MAX_POCKET_GRID = 4000


def pocket_grid(bounds, gap: float, grid: int) -> int:
    """Pixels along the longer side of the pocket raster of a container with ``bounds``
    (minx, miny, maxx, maxy) at ``gap``: ``grid``, or more where that leaves fewer than
    :data:`PIXELS_PER_GAP` pixels across a gap (at most :data:`MAX_POCKET_GRID`).

    Notes
    -----
    A copy's fit is read off the distance transform (:func:`best_fit`), so its error is
    about a pixel. At the default gap (1 % of the longer side) 1,000 pixels give 10 across
    a gap; a poster of 1,000 elements has a gap of 0.17 % of it, 1.7 pixels: its pockets,
    a few pixels deep, measured a fifth of a gap too deep, their copies' fits came out far
    too large, and most copies simulated ended below the size floor (2,052 simulated,
    401 kept).
    """
    longer = max(bounds[2] - bounds[0], bounds[3] - bounds[1])
    if not (gap > 0 and longer > 0):
        return int(grid)
    need = int(np.ceil(PIXELS_PER_GAP * longer / gap))
    return int(max(grid, min(need, MAX_POCKET_GRID)))


def _next_free(blocked: np.ndarray, at: np.ndarray, k: int) -> int:
    """The first index ``j >= k`` with ``blocked[at[j]]`` False (``len(at)`` if none):
    the next candidate no kept seed claims.

    Notes
    -----
    The seeding visits the candidates deepest first; a heart's negative space has ~53,000
    above the depth floor for ~100 seeds. Skipping the claimed ones a slice at a time
    (doubling) instead of one Python step each took ~20 ms off its seeding."""
    step = 256
    while k < len(at):
        taken = blocked[at[k:k + step]]
        if not taken.all():
            return k + int(np.argmin(taken))
        k += step
        step *= 2
    return len(at)


def pocket_axes(pockets: Pockets) -> np.ndarray:
    """The long axis (radians, in container coordinates) of the pocket around each seed
    (:func:`pocket_axis` of each)."""
    if not len(pockets.iy):
        return np.zeros(0)
    gy, gx = np.gradient(pockets.dist)
    return np.array([pocket_axis(pockets, k, (gy, gx)) for k in range(len(pockets.iy))])


def pocket_axis(pockets: Pockets, k: int, gradient: tuple[np.ndarray, np.ndarray] | None = None) -> float:
    """The long axis (radians, in container coordinates) of the pocket around seed ``k``.

    Within twice the seed's distance, the gradient of the distance transform points away
    from the walls of the pocket: in a sliver between two elements those gradients are
    (anti)parallel, across the sliver. The pocket runs along the eigenvector of the
    smallest eigenvalue of their structure tensor Σ ∇d ∇dᵀ. In a round pocket the
    tensor is isotropic and the axis is arbitrary, which is harmless: nothing there
    favours one orientation. ``gradient``: ``np.gradient(pockets.dist)``, when known.
    """
    dist = pockets.dist
    gy, gx = np.gradient(dist) if gradient is None else gradient
    ny, nx = dist.shape
    cy, cx = pockets.iy[k], pockets.ix[k]
    r = max(2.0, 2.0 * float(pockets.distance[k]) / pockets.h)
    y0, y1 = max(0, int(cy - r)), min(ny, int(cy + r) + 1)
    x0, x1 = max(0, int(cx - r)), min(nx, int(cx + r) + 1)
    yy, xx = np.ogrid[y0:y1, x0:x1]
    w = ((yy - cy) ** 2 + (xx - cx) ** 2 < r * r) & (dist[y0:y1, x0:x1] > 0)
    ax, ay = gx[y0:y1, x0:x1][w], gy[y0:y1, x0:x1][w]
    jxx, jyy, jxy = float(ax @ ax), float(ay @ ay), float(ax @ ay)
    # the largest eigenvector is at 0.5·atan2(2jxy, jxx − jyy); the pocket runs ⟂ to it
    return float(0.5 * np.arctan2(2.0 * jxy, jxx - jyy) + 0.5 * np.pi)


def art_size(geom) -> float:
    """An element's size: the square root of its art's area (container units).

    Notes
    -----
    The ink a copy puts down decides whether it reads as a shape or as a speck, whatever
    its outline: a bounding circle would count a mouse's whiskers or a sword's length as
    size, and a copy that is mostly whisker would pass any floor on it."""
    return float(np.sqrt(max(float(geom.area), 0.0)))


def mesh_sizes(packing, kind: str | None = None) -> np.ndarray:
    """:func:`art_size` of the copies from their meshes (container units): the template's
    art size × the mesh's growth (RMS radius of its vertices about their mean, over the
    template's at its nominal scale). In element order; only the copies of ``kind``
    (``"primary"``, ``"secondary"``) when given.

    Notes
    -----
    Read before any art is mapped: to choose which pockets get a copy, and which copies
    are worth mapping (:func:`worth_mapping`). Within 5 % of the mapped art's size on the
    heart and the 1,000-element poster; the final floor is set again on the mapped art
    (:func:`size_floor`)."""
    m, st, fr = packing.model, packing.state, packing.frame
    nominal: dict[int, tuple[float, float]] = {}  # per template: art size, RMS radius
    out = []
    for e in range(m.n_elements):
        if kind is not None and m.kind[e] != kind:
            continue
        ti = int(m.template_index[e])
        if ti not in nominal:
            t = packing.templates[ti]
            r_nom = float(np.sqrt(((t.verts - t.verts.mean(axis=0)) ** 2).sum(axis=1).mean()))
            nominal[ti] = (float(np.sqrt(t.outline.area) * t.scale), r_nom)
        size, r_nom = nominal[ti]
        v = st.x[m.elem_vstart[e]:m.elem_vstart[e + 1]] * fr.unit
        r_now = float(np.sqrt(((v - v.mean(axis=0)) ** 2).sum(axis=1).mean()))
        out.append(size * (r_now / r_nom if r_nom > 0 else 1.0))
    return np.asarray(out, dtype=float)


#: how far a copy's mesh size may fall short of its mapped art's (4 % at most measured)
MESH_SIZE_SLACK = 1.06


def worth_mapping(packing, share: float, max_grow: float) -> np.ndarray:
    """The copies whose art is worth mapping, verifying and writing: every one but the
    pocket copies that end below the size floor (``share`` × the median primary,
    :func:`size_floor`) even if the verification grew them by ``max_grow``. Element
    indices, increasing.

    Notes
    -----
    The pocket phase seeds every pocket whose fitted copy could reach the floor, and most
    copies are pressed below it as their neighbours grow: on the 1,000-element poster
    1,962 copies were simulated and 433 kept. The floor drops them after the verification;
    mapping, denting and verifying them first cost more than the rest of the copies. The
    mesh sizes (:func:`mesh_sizes`) are close enough to tell the hopeless ones
    (:data:`MESH_SIZE_SLACK`); the floor on the mapped art still decides."""
    m = packing.model
    sizes = mesh_sizes(packing)
    primary = np.array([k == "primary" for k in m.kind], bool)
    floor = size_floor(sizes[primary], share)
    return np.flatnonzero(primary | (sizes * max_grow * MESH_SIZE_SLACK >= floor))


def size_floor(primary_sizes, share: float) -> float:
    """The smallest pocket copy allowed: ``share`` × the median of ``primary_sizes``
    (container units); 0 without primaries or with ``share`` 0."""
    sizes = np.asarray(primary_sizes, dtype=float)
    return float(share * np.median(sizes)) if share > 0 and len(sizes) else 0.0


def add_secondary(packing, elements: Sequence[Element], rng: np.random.Generator,
                  on_snapshot: Callable[[Snapshot], None] | None = None,
                  should_stop: Callable[[], bool] | None = None,
                  on_checkpoint: Callable[[dict], None] | None = None, checkpoint_every: int = 0,
                  saved: dict | None = None, snapshot_every: int = 25, min_size: float = 0.0) -> int:
    """Run the secondary phase on ``packing`` in place; returns the number of elements added.

    ``on_checkpoint(state)`` / ``saved``: as in :func:`repulsionpak.pack.pack`, for this phase.
    ``min_size`` (container units): pockets whose best fitted copy is smaller
    (:func:`art_size` at its nominal scale) get none."""
    p = packing.params
    sp = p.secondary
    gap = packing.gap
    t0 = time.perf_counter()
    pockets = pocket_seeds(packing.container.region, packing.skins(), gap, sp)
    seeds = pockets.seeds
    packing.seconds["seeding"] = time.perf_counter() - t0
    if len(seeds) == 0:
        packing.stopped_by["secondary"] = "no_pockets"
        return 0
    outlines = [outline_of(e) for e in elements]
    ctrls = controls_of(elements)
    controlled = any_controls(elements) or packing.model.rot_on is not None
    weights = [c.weight for c in ctrls]
    if controlled and len(set(weights)) > 1:  # designer controls: frequencies
        if not sum(weights) > 0:
            packing.stopped_by["secondary"] = "no_elements"
            return 0
        assign = weighted_assignment(weights, len(seeds), rng)
    else:
        order = rng.permutation(len(outlines))
        assign = order[np.arange(len(seeds)) % len(outlines)]
    k = len(outlines) if sp.candidates is None else min(sp.candidates, len(outlines))
    if not controlled and k > 1:
        # each pocket also tries the next elements of the shuffled cycle and keeps the one
        # whose fitted copy covers the most art
        cand = order[(np.arange(len(seeds))[:, None] + np.arange(k)[None, :]) % len(outlines)]
    else:
        cand = assign[:, None]
    fits = _PocketFits(pockets, outlines, cand, ctrls if controlled else None,
                       p.preprocess.skin_offset * gap, p.placement.rotate, rng)
    # one template per element and size class (factor SIZE_STEP): every copy's skin is
    # built for about its own final size, so it keeps about half a gap around its art
    # however small or large its pocket is
    m0 = packing.model
    # the phase simulates at most as many vertices as the primary phase did (the deepest
    # pockets first): with one detailed primary, 50 copies of it cost many times its run;
    # the pockets are fitted in that order until the copies reach it
    v_prim = sum(int(m0.elem_vstart[e + 1] - m0.elem_vstart[e]) for e in range(m0.n_elements)
                 if m0.kind[e] == "primary")
    chosen, templates, tindex, shrink = _copies_within(fits, outlines, max(v_prim, MIN_WORK_VERTICES),
                                                        gap, p, min_size)
    if not chosen:  # no specks: a pocket too small for a copy of the floor's size stays empty
        packing.stopped_by["secondary"] = "no_pockets"
        return 0
    seeds = seeds[chosen]
    angles = np.array([fits(k)[0] for k in chosen])
    assign = np.array([fits(k)[2] for k in chosen], dtype=cand.dtype)
    base_index = len(packing.templates)
    placement = Placement(tindex + base_index, seeds, angles, shrink)
    all_templates = list(packing.templates) + templates
    region_sim = packing.frame.to_sim(packing.container.region)

    model, state = build_model(all_templates, placement, packing.frame, region_sim,
                               cell_size=neighbour_cell(all_templates, placement.template_index,
                                                        gap, p) / packing.frame.unit,
                               gap=m0.gap,
                               kinds=["secondary"] * len(seeds),
                               frozen=np.ones(m0.n_elements, bool), base=(m0, packing.state))
    # a secondary's nominal size is the largest that fits its pocket (it starts at
    # initial_fraction of it): big pockets get big secondaries
    model.max_growth[m0.n_elements:] = 1.0 / sp.initial_fraction
    model.bend_limit[m0.n_elements:] = bend_limits(all_templates, placement.template_index, p.sim)
    if controlled:
        setup_model(model, [ctrls[int(i)] for i in assign], angles, base=m0)
    t1 = time.perf_counter()
    # ... and at most SECONDARY_WORK of the primary phase's vertex-iterations, and not more
    # iterations than it (each costs a fixed ~0.5 ms besides its vertices; the copies of
    # one detailed primary ran 2.7 times its iterations)
    v_sec = max(model.n_vertices - m0.n_vertices, 1)
    primary_its = max(int(packing.iterations.get("primary", 0)), 1)
    work = max(v_prim * primary_its, MIN_WORK_VERTICES * MIN_WORK_ITERATIONS)
    its = min(int(SECONDARY_WORK * work / v_sec), max(primary_its, MIN_WORK_ITERATIONS))
    cap = min(p.sim.max_iterations, max(its, p.sim.min_iterations))
    # the pocket phase's copies fill pockets: the filled runs' growth cap, k_r and k_g at this gap
    sim = Simulator(model, state, dataclasses.replace(p.sim.for_run(True, gap=m0.gap), max_iterations=cap,
                                                      stop_epsilon=sp.stop_epsilon,
                                                      settle_iterations=sp.settle_iterations),
                    phase="secondary")
    sim.templates = all_templates
    res = sim.run_resumable(saved, on_checkpoint, checkpoint_every, on_snapshot=on_snapshot,
                            should_stop=should_stop, every=snapshot_every)
    packing.templates = all_templates
    packing.model, packing.state = model, state
    packing.iterations["secondary"] = res.iterations
    packing.seconds["secondary"] = time.perf_counter() - t1 + packing.seconds["seeding"]
    packing.stopped_by["secondary"] = ("work_bound" if res.stopped_by == "max_iterations" and cap < p.sim.max_iterations
                                       else res.stopped_by)
    packing.area_fraction_meshes = res.area_fraction
    return len(seeds)


#: the secondary phase's copies have at most as many mesh vertices as the primaries (the
#: copies of the deepest pockets first), and it runs at most this share of the primary
#: phase's vertex-iterations (its growing ones; the settling ones follow): the heart's
#: copies have 0.3 of its primaries' vertices and run 0.4 of their iterations, far below;
#: one detailed element alone in a circle (--count 1) got 50 copies of itself, which ran
#: 2.7 times its iterations
SECONDARY_WORK = 0.5
#: ... but never less room than this many vertices and iterations (about 2 s): a narrow
#: band whose default count is one small primary still gets its row of copies, which
#: grow from half their fit to it in about 1,000 iterations
MIN_WORK_VERTICES, MIN_WORK_ITERATIONS = 4000, 1000
#: size classes of the secondary templates (a copy's skin is built for its size ± 10 %)
SIZE_STEP = 1.2
#: random start angles tried per pocket, besides the two along the pocket's long axis
ANGLE_TRIES = 6
#: scales tried per angle, from half the inscribed-circle fit to four times it
_STEPS = np.geomspace(0.5, 4.0, 37)


def _copies_within(fits: "_PocketFits", outlines, room: int, gap: float, p, min_size: float
                   ) -> tuple[list[int], list, np.ndarray, np.ndarray]:
    """The pockets that get a copy, in seed order, and the copies' templates.

    A pocket whose fitted copy stays below ``min_size`` (:func:`art_size` at its nominal
    scale × the growth cap, ``sim.max_size``: a copy may grow past its fit where its neighbours leave
    room; those that end below the floor are dropped after the verification) gets none.
    The copies' templates (one per element and size class) are built as they come, until
    the copies' mesh vertices pass ``room`` (the first copy always fits). Returns (the
    pockets chosen, the new templates, each copy's template index among them, each
    copy's start shrink)."""
    sp = p.secondary
    templates: list = []
    key_index: dict[tuple[int, int], int] = {}
    chosen, tindex, shrink = [], [], []
    used = 0
    for k in range(fits.n):
        _, sc, i = fits(k)
        if min_size > 0 and not np.sqrt(outlines[i].area) * sc * p.sim.growth_cap() >= min_size:
            continue
        b = int(np.round(np.log(sc) / np.log(SIZE_STEP)))
        if (i, b) not in key_index:
            key_index[(i, b)] = len(templates)
            templates.append(build_template(outlines[i], SIZE_STEP ** b, gap, p.preprocess))
        t = key_index[(i, b)]
        used += len(templates[t].verts)
        if used > room and chosen:  # this copy would take the phase past the primaries' size
            break
        chosen.append(k)
        tindex.append(t)
        shrink.append(sp.initial_fraction * sc / SIZE_STEP ** b)  # starts at a share of its fit
    return chosen, templates, np.asarray(tindex, np.int64), np.asarray(shrink, dtype=float)


class _PocketFits:
    """Each pocket's copy (:func:`_fit_to_pockets`), fitted when first asked for.

    The random start angles of every pocket are drawn when it is made (the generator
    ends where fitting them all would leave it); ``fits(k)`` is pocket k's
    (angle, scale, element)."""

    def __init__(self, pockets: Pockets, outlines, candidates: np.ndarray, ctrls, offset: float,
                 rotate: bool, rng: np.random.Generator):
        self.pockets, self.candidates, self.offset, self.rotate = pockets, candidates, offset, rotate
        self.n = n = len(candidates)
        self.seeds = pockets.seeds
        used = np.unique(candidates)
        self.samples = {int(i): outline_samples(outlines[int(i)]) for i in used}
        self.radius = {i: float(np.sqrt((smp ** 2).sum(axis=1).max())) for i, smp in self.samples.items()}
        self.art = {int(i): float(outlines[int(i)].geometry.area) for i in used}
        angles = rng.uniform(0.0, 2.0 * np.pi, (n, ANGLE_TRIES)) if rotate else np.zeros((n, 1))
        self.axes = None
        if ctrls is not None:
            angles = initial_angles(ctrls, candidates[:, 0], angles[:, 0], rng)[:, None]
        elif rotate:  # and the pocket's long axis, both ways (:meth:`_angles`)
            self.axes = np.gradient(pockets.dist)
        self.angles = angles
        self.done: dict[int, tuple[float, float, int]] = {}

    def _angles(self, k: int) -> np.ndarray:
        if self.axes is None:
            return self.angles[k]
        axis = pocket_axis(self.pockets, k, self.axes)
        return np.concatenate([self.angles[k], [axis, axis + np.pi]])

    def __call__(self, k: int) -> tuple[float, float, int]:
        if k not in self.done:
            self.done[k] = self._fit(k)
        return self.done[k]

    def _fit(self, k: int) -> tuple[float, float, int]:
        """Pocket k's copy: of its candidates, the one whose fitted copy covers the most
        art (the first of equals), at its best angle (the first of equals).

        Notes
        -----
        A candidate whose art at its inscribed-circle fit already beats the best before
        it has every angle fitted (:func:`best_fit`); any other counts only with an
        angle that fits beyond the smallest winning scale, and the fit stops at once
        for the candidates that have none — most of them. The same choice as fitting
        every candidate at every angle (the scales, a step of ``_STEPS`` apart, differ
        by far more than the 1e-9 within which two count as equal)."""
        pockets, offset = self.pockets, self.offset
        angles = self._angles(k)
        best_area, out = -1.0, (0.0, 0.0, int(self.candidates[k, 0]))
        for i in map(int, self.candidates[k]):
            # the inscribed-circle fit: the circumscribed skin radius equals the distance
            s_round = max(pockets.distance[k] - offset, 0.5 * pockets.distance[k]) / max(self.radius[i], 1e-300)
            to_beat = best_area * (1.0 + 1e-9)
            above = -1
            if not self.art[i] * s_round * s_round > to_beat:  # only a fit of more art than the best counts
                wins = self.art[i] * (s_round * _STEPS) * (s_round * _STEPS) > to_beat
                above = int(np.argmax(wins)) - 1 if wins.any() else len(_STEPS) - 1
            a, sc = best_fit(pockets, self.seeds[k], self.samples[i], angles, offset, s_round, _STEPS, above)
            if a < 0:
                continue
            sc = max(sc, s_round)
            if self.art[i] * sc * sc > to_beat:
                best_area = self.art[i] * sc * sc
                out = (float(angles[a]), sc, i)
        return out


def _fit_to_pockets(pockets: Pockets, outlines, candidates: np.ndarray, ctrls, offset: float, rotate: bool,
                    rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Element, start angle and nominal scale (file → container units) of each pocket's copy.

    ``candidates`` (n, k): the library elements pocket j may take; the one whose fitted copy
    has the largest art area is chosen (k = 1: the assignment as given). The nominal scale
    is the largest at which the copy's art, centred on the seed, keeps
    its skin offset (``offset``) from every primary skin and the boundary — measured on
    the pocket's distance transform at samples on and inside its outline
    (:func:`~repulsionpak.geometry.pockets.outline_samples`) — so its skin just fills the pocket. Free copies try their
    pocket's long axis (both ways) and ``ANGLE_TRIES`` random angles and take the angle
    with the largest fit: a bar lies along a sliver, a star turns its tips into the
    corners of a pocket. Rotation-controlled copies keep the
    angles their controls give (:func:`repulsionpak.controls.initial_angles`).
    Returns (angles, scales, chosen elements), each (n,).
    """
    fits = _PocketFits(pockets, outlines, candidates, ctrls, offset, rotate, rng)
    out = [fits(k) for k in range(fits.n)]
    return (np.array([o[0] for o in out]), np.array([o[1] for o in out]),
            np.array([o[2] for o in out], dtype=candidates.dtype))
