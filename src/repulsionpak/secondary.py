"""Secondary elements (sec. 9): seed the pockets the primaries left, grow them with the
primaries frozen (they still repel and can be overlapped into, but never move)."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np
import shapely

from .controls import any_controls, controls_of, initial_angles, setup_model, weighted_assignment
from .evaluate import rasterize
from .geometry.edt import distance_transform
from .params import SecondaryParams
from .placement import Placement
from .preprocess import build_template, outline_of
from .sim.model import build_model
from .sim.runner import Simulator, Snapshot
from .types import Element


def pocket_seeds(region, skins: Sequence[np.ndarray], gap: float, params: SecondaryParams
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Seed points far from every mesh and from the container boundary.

    Distance transform of the negative space on a grid of ``params.grid`` pixels along
    the container's longer side; candidates are pixels whose distance is above
    d_min = ``params.d_min``·gap, taken by decreasing distance and kept when no kept seed
    is within d_sep = ``params.d_sep``·gap (sec. 9) nor within its own pocket (the disc of
    its distance): a large pocket gets one seed that grows to fill it.

    Returns (seeds (K, 2), distances (K,)) in container units.
    """
    polys = [shapely.make_valid(shapely.Polygon(s)) for s in skins]
    bounds = region.bounds
    cont, info = rasterize([region], bounds, grid=params.grid)
    occ, _ = rasterize(polys, bounds, grid=params.grid)
    h = info["pixel_size"]
    neg = cont & ~occ
    dist = distance_transform(neg, h)
    d_min = params.d_min * gap
    d_sep = params.d_sep * gap
    iy, ix = np.nonzero(dist > d_min)
    if len(iy) == 0:
        return np.zeros((0, 2)), np.zeros(0)
    d = dist[iy, ix]
    order = np.argsort(-d, kind="stable")
    iy, ix, d = iy[order], ix[order], d[order]
    pts = np.column_stack([info["x0"] + (ix + 0.5) * h, info["y0"] + (iy + 0.5) * h])
    # greedy, deepest first: a kept seed claims the disc of its own pocket (radius its
    # distance, at least d_sep), so a large pocket gets one seed, not a crowd of them
    blocked = np.zeros(dist.shape, bool)
    ny, nx = dist.shape
    out = []
    for k in range(len(d)):
        if blocked[iy[k], ix[k]]:
            continue
        out.append(k)
        if params.max_count is not None and len(out) >= params.max_count:
            break
        r = max(d_sep, float(d[k])) / h
        y0, y1 = max(0, int(iy[k] - r)), min(ny, int(iy[k] + r) + 1)
        x0, x1 = max(0, int(ix[k] - r)), min(nx, int(ix[k] + r) + 1)
        yy, xx = np.ogrid[y0:y1, x0:x1]
        blocked[y0:y1, x0:x1] |= (yy - iy[k]) ** 2 + (xx - ix[k]) ** 2 < r * r
    out = np.asarray(out, dtype=np.int64)
    return pts[out], d[out]


def add_secondary(packing, elements: Sequence[Element], rng: np.random.Generator,
                  on_snapshot: Callable[[Snapshot], None] | None = None,
                  should_stop: Callable[[], bool] | None = None,
                  on_checkpoint: Callable[[dict], None] | None = None, checkpoint_every: int = 0,
                  saved: dict | None = None, snapshot_every: int = 25) -> int:
    """Run the secondary phase on ``packing`` in place; returns the number of elements added.

    ``on_checkpoint(state)`` / ``saved``: as in :func:`repulsionpak.pack.pack`, for this phase."""
    p = packing.params
    sp = p.secondary
    gap = packing.gap
    t0 = time.perf_counter()
    seeds, dist = pocket_seeds(packing.container.region, packing.skins(), gap, sp)
    packing.seconds["seeding"] = time.perf_counter() - t0
    if len(seeds) == 0:
        packing.stopped_by["secondary"] = "no_pockets"
        return 0
    outlines = [outline_of(e) for e in elements]
    # templates at the scale of a typical pocket: skin radius ~ median pocket radius
    target_r = float(np.median(dist))
    templates = []
    for o in outlines:
        r_art = float(np.sqrt(o.area / np.pi))
        scale = max(target_r - p.preprocess.skin_offset * gap, 0.5 * target_r) / max(r_art, 1e-12)
        templates.append(build_template(o, scale, gap, p.preprocess))
    ctrls = controls_of(elements)
    controlled = any_controls(elements) or packing.model.rot_on is not None
    weights = [c.weight for c in ctrls]
    if controlled and len(set(weights)) > 1:  # designer controls: frequencies
        if not sum(weights) > 0:
            packing.stopped_by["secondary"] = "no_elements"
            return 0
        assign = weighted_assignment(weights, len(seeds), rng)
    else:
        order = rng.permutation(len(templates))
        assign = order[np.arange(len(seeds)) % len(templates)]
    radius = np.array([templates[i].radius for i in assign])
    shrink = sp.initial_fraction * dist / radius  # each starts at a share of its own pocket
    angles = rng.uniform(0, 2 * np.pi, len(seeds)) if p.placement.rotate else np.zeros(len(seeds))
    if controlled:
        angles = initial_angles(ctrls, assign, angles, rng)
    base_index = len(packing.templates)
    placement = Placement(assign + base_index, seeds, angles, shrink)
    all_templates = list(packing.templates) + templates
    region_sim = shapely.affinity.scale(packing.container.region, 1 / packing.frame.unit,
                                        1 / packing.frame.unit, origin=(0, 0))
    m0 = packing.model
    model, state = build_model(all_templates, placement, packing.frame, region_sim,
                               cell_size=m0.cell_size, gap=m0.gap,
                               kinds=["secondary"] * len(seeds),
                               frozen=np.ones(m0.n_elements, bool), base=(m0, packing.state))
    # a secondary's nominal size is its pocket (it starts at initial_fraction of it), not
    # the template's: big pockets get big secondaries
    model.max_growth[m0.n_elements:] = 1.0 / sp.initial_fraction
    from .pack import bend_limits  # noqa: PLC0415  (pack imports this module lazily too)

    model.bend_limit[m0.n_elements:] = bend_limits(all_templates, placement.template_index, p.sim)
    if controlled:
        setup_model(model, [ctrls[int(i)] for i in assign], angles, base=m0)
    t1 = time.perf_counter()
    sim = Simulator(model, state, p.sim, phase="secondary")
    sim.templates = all_templates
    res = sim.run_resumable(saved, on_checkpoint, checkpoint_every, on_snapshot=on_snapshot,
                            should_stop=should_stop, every=snapshot_every)
    packing.templates = all_templates
    packing.model, packing.state = model, state
    packing.iterations["secondary"] = res.iterations
    packing.seconds["secondary"] = time.perf_counter() - t1 + packing.seconds["seeding"]
    packing.stopped_by["secondary"] = res.stopped_by
    packing.area_fraction_meshes = res.area_fraction
    return len(seeds)
