"""The whole method as one call: preprocess → place → simulate → (secondary) → render → verify → hole fill."""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import time
from collections.abc import Callable, Sequence

import numpy as np
import shapely

from .blas import with_one_blas_thread
from .controls import any_controls, prepare_controlled, setup_model, straighten_limits
from .errors import ParameterError
from .inputs import check_fineness, default_gap, load_inputs, margin_of
from .packing import Packing
from .params import Params
from .placement import Placement, assign_elements, estimate_count, final_scale, place
from .preprocess import Outline, Template, build_template, outline_of
from .render import is_convex
from .room import room_of
from .sim.art import placed_art, rest_art
from .sim.model import Model, SimFrame, State, build_model
from .sim.phase import bend_limits, neighbour_cell
from .sim.relocate import Relocator
from .sim.runner import Simulator, Snapshot, auto_threads
from .sizing import UNEVEN_SHARE, is_even, narrow_share, plan_sizes
from .types import Container, Element, PlacedArt
from .verify import dent, straighten, verify_and_repair


#: the automatic pocket fill's cap on its copies is 10 per primary, and at least this
AUTO_FILL_MIN = 50


def skin_excess(params: Params, gap: float) -> float:
    """How much wider than half the gap a skin can leave the room beside its art (container
    units): the skin's extra width (``preprocess.skin_offset`` beyond 0.5, meant to be
    taken up by the compression where meshes press on each other, which small, stiff meshes
    hardly show) and its sampling tolerance (a chord of the skin ring lies inside the exact
    offset). Where neither is taken up, two arts end 2× this further apart than the gap;
    the verification's growth closes it (:func:`repulsionpak.verify.verify_and_repair`)."""
    pp = params.preprocess
    return max(0.0, pp.skin_offset - 0.5) * gap + pp.skin_tolerance * gap


def primary_model(region, templates: Sequence[Template], placement: Placement, gap: float,
                  params: Params, frozen: np.ndarray | None = None) -> tuple[Model, State, SimFrame]:
    """The simulation model of the primary phase (sim units): grid cell from the typical
    element size, the edge margin beyond the skin as an extra boundary inset, each
    element's bend limit."""
    frame = SimFrame.for_region(region)
    region_sim = frame.to_sim(region)
    cell = neighbour_cell(templates, placement.template_index, gap, params) / frame.unit
    model, state = build_model(templates, placement, frame, region_sim, cell_size=cell,
                               gap=gap / frame.unit, frozen=frozen)
    # skins rest inside the container by boundary_inset; where the margin asks for more
    # than the skin's width, the rest of it moves the boundary in
    model.inset_extra = max(0.0, margin_of(params, gap) - params.preprocess.skin_offset * gap) / frame.unit
    model.bend_limit[:] = bend_limits(templates, model.template_index, params.sim)
    return model, state, frame


def primary_relocator(model: Model, region, frame: SimFrame, params: Params, filled: bool) -> Relocator | None:
    """The moves at convergence of the primary phase (:mod:`repulsionpak.sim.relocate`),
    or None: ``sim.relocations`` of them (None: :data:`RELOCATIONS_UNFILLED` when the pockets
    are not ``filled``, else none). Pinned, rigid and turn-limited elements stay where the
    simulation takes them, and a run following a flow field is not moved at all: their place
    and angle are the designer's."""
    n = params.sim.relocations
    if n is None:
        n = 0 if filled else RELOCATIONS_UNFILLED
    if n <= 0 or model.flow is not None:
        return None
    movable = ~model.frozen
    if model.rot_on is not None:
        movable &= ~model.rot_on
    if model.rigid is not None:
        movable &= ~model.rigid
    return Relocator(frame.to_sim(region), movable, n, turn=params.placement.rotate,
                     inset=params.preprocess.skin_offset * model.gap)


#: moves at convergence when nothing fills the pockets: the heart with 30 animals gained
#: 0.021 art area with 5 (every one of 12 seeds), the same with 8: the moves end where
#: no element fits the largest void
RELOCATIONS_UNFILLED = 5


def checked_gap(container: Container, elements: Sequence[Element], params: Params) -> float:
    """The gap of a run (``params.gap``, else :func:`default_gap`), refused with a clear
    error when it cannot work; also refuses an empty element list."""
    if not elements:
        raise ParameterError("no elements given")
    gap = params.gap if params.gap is not None else default_gap(container, params.placement)
    minx, miny, maxx, maxy = container.bounds
    if gap * 4 >= min(maxx - minx, maxy - miny):
        raise ParameterError(f"the gap ({gap:g}) is absurdly large for a container of "
                             f"{maxx - minx:g}×{maxy - miny:g} units; use a gap of about 1% of its size")
    check_fineness(container, gap, params)
    margin = margin_of(params, gap)
    tol = 1e-3 * max(maxx - minx, maxy - miny)  # the largest inscribed circle to this (ms, any detail)
    deepest = max((float(shapely.maximum_inscribed_circle(p, tol).length)
                   for p in shapely.get_parts(container.region) if not p.is_empty), default=0.0)
    if deepest + tol <= margin:
        raise ParameterError(f"the edge margin ({margin:g}) leaves no room in the container: no point of it is "
                             f"more than {deepest:.4g} from its edge" + ("" if params.margin is not None else
                             " (the margin is half the gap by default: use a smaller gap)"))
    if deepest + tol <= margin + 0.5 * gap:  # art under a gap across: every copy would be dropped
        most = 2 * (deepest - margin) if params.margin is not None else deepest
        raise ParameterError(
            f"the container is too narrow for a gap of {gap:g}: its widest point is {2 * deepest:.4g} across "
            f"(its largest inscribed circle), which leaves less than a gap for an element's art between the "
            f"edge margins ({margin:g} on each side); use a gap below {most:.3g}")
    return gap


def prepare(container: Container, elements: Sequence[Element], params: Params,
            rng: np.random.Generator) -> tuple[list[Template], Placement, float]:
    """Preprocess the library and place the primary elements (sec. 4).

    Returns the templates (one per library element), the placement and the gap.
    """
    gap = checked_gap(container, elements, params)
    outlines: list[Outline] = [outline_of(e) for e in elements]
    planned = room_placement(container, outlines, gap, params, rng)
    if planned is not None:
        return planned[0], planned[1], gap
    count = estimate_count(container.area, gap, params.placement)
    assignment = assign_elements(len(elements), count, rng)
    scale = final_scale(outlines, assignment, container.area, params.preprocess.skin_offset * gap,
                        params.placement.target_fraction)
    templates = [build_template(o, scale, gap, params.preprocess) for o in outlines]
    placement = place(templates, assignment, container.region, params.placement, rng)
    return templates, placement, gap


def room_placement(container: Container, outlines: Sequence[Outline], gap: float, params: Params,
                   rng: np.random.Generator) -> tuple[list[Template], Placement] | None:
    """The primaries sized and counted by the room the container has (:mod:`repulsionpak.sizing`),
    or None where the paper's placement applies (unless ``placement.room_everywhere``):
    ``placement.follow_room`` off, an even
    container (one region, nearly all of it at least ``element_size`` gaps wide), or a
    given count in a single region or in regions that are all wide (a tenth or less of the
    container narrower than the size the count gives: the paper's blue noise shares it out
    by area, as well as the room's policy measured on the suite's two-region scenes).

    Returns the templates (one per library element and size class: a copy's skin is built
    for about its own size) and the placement (one common shrink, so every copy starts at
    the same share of its nominal size)."""
    pl = params.placement
    if not pl.follow_room:
        return None
    force = pl.room_everywhere  # even containers and given counts too
    if pl.count is not None and len(shapely.get_parts(container.region)) <= 1 and not force:
        return None
    base = pl.element_size * gap if pl.count is None else math.sqrt(container.area / pl.count)
    room = room_of(container.region, gap)
    if not force and (is_even(room, base) or (pl.count is not None and (
            len(room.parts) <= 1 or narrow_share(room, base) < UNEVEN_SHARE))):
        return None
    pl_base = pl if pl.count is None else dataclasses.replace(pl, element_size=base / gap)
    plan = plan_sizes(room, outlines, gap, params.preprocess.skin_offset * gap, pl_base, rng, count=pl.count)
    if len(plan.position) == 0:
        return None
    keys: dict[tuple[int, float], int] = {}
    templates: list[Template] = []
    assignment = np.empty(len(plan.position), np.int64)
    for k, (lib, s) in enumerate(zip(plan.library, plan.scale)):
        key = (int(lib), float(s))
        if key not in keys:
            keys[key] = len(templates)
            templates.append(build_template(outlines[int(lib)], float(s), gap, params.preprocess))
        assignment[k] = keys[key]
    placement = place(templates, assignment, container.region, pl, rng, angle_fn=lambda a: plan.angle,
                      positions=plan.position)
    return templates, placement


def _check_arguments(container, elements, secondary, params) -> None:
    """ParameterError naming the argument of :func:`pack` of the wrong kind (they failed
    deep inside with an AttributeError or a TypeError)."""
    import os  # noqa: PLC0415

    if not isinstance(container, (Container, str, os.PathLike)):
        raise ParameterError(f"pack(): the container must be a Container (load_container(path) reads one) "
                             f"or its file's path, got {type(container).__name__}")
    for name, seq in (("elements", elements), ("secondary", secondary)):
        if isinstance(seq, (str, os.PathLike)) and name == "elements":
            continue
        if isinstance(seq, (str, bytes, os.PathLike, Element)) or not hasattr(seq, "__iter__"):
            raise ParameterError(f"pack(): {name} must be a list of Element (load_elements(paths) reads "
                                 f"them) or of paths, got {type(seq).__name__}")
        kinds = {isinstance(e, Element) for e in seq if isinstance(e, (Element, str, os.PathLike))}
        for e in seq:
            if not isinstance(e, (Element, str, os.PathLike)) or len(kinds) > 1:
                raise ParameterError(f"pack(): {name} must be a list of Element (load_elements(paths) reads "
                                     f"them) or of paths, got a {type(e).__name__} in it")
    if not isinstance(params, Params):
        raise ParameterError(f"pack(): params must be a Params (params_from_dict(d) builds one from a dict), "
                             f"got {type(params).__name__}")


def _kernels_loaded_ahead(func: Callable) -> Callable:
    """Decorator: installs the kernels compiled with the package, then runs ``func`` while
    a second thread loads the simulation's kernels from numba's cache
    (:func:`repulsionpak._jit.loading.loading_ahead`), their parallel builds too when more
    than one thread is allowed (:func:`~repulsionpak.sim.runner.auto_threads`); not beside
    a warm-up process, which shares the compiling with this one by claims."""
    @functools.wraps(func)
    def wrapped(*args, **kwargs):
        from ._jit import kernels, loading, prebuilt, warmup

        prebuilt.install()  # kernels compiled when the package was built, if any (once)
        ahead = kernels.calls_to_load_ahead(parallel=auto_threads() > 1) if warmup.running() is None else []
        with loading.loading_ahead(ahead):
            return func(*args, **kwargs)
    return wrapped


@_kernels_loaded_ahead
@with_one_blas_thread
def pack(container: Container | str | os.PathLike, elements: Sequence[Element] | Sequence[str | os.PathLike],
         params: Params = Params(), secondary: Sequence[Element] | Sequence[str | os.PathLike] = (),
         on_snapshot: Callable[[Snapshot], None] | None = None,
         should_stop: Callable[[], bool] | None = None,
         on_checkpoint: Callable[[dict], None] | None = None, checkpoint_every: int = 500,
         resume: dict | None = None, snapshot_every: int = 25,
         on_stage: Callable[[str], None] | None = None, sources: dict | None = None,
         flow=None) -> Packing:
    """Fill ``container`` with deformed copies of ``elements`` (and ``secondary`` ones).

    Parameters
    ----------
    container : Container or path
        Read (or read again) as every run reads it: flattened to a thousandth of the gap
        (:func:`repulsionpak.inputs.run_container`).
    elements, secondary : sequence of Element, or of paths
        Paths: files, folders and element manifests, as the command line takes them.
        Without ``secondary`` the pockets get small copies of the elements
        (``params.secondary.auto``).
    params : Params
        ``gap`` None: the container's default gap; ``seed`` None: drawn at random and
        recorded in the result (a packing can always be made again).
    sources : dict, optional
        The inputs' names for the report (default: the paths given, or the files the
        container and elements were read from).
    flow : path or FlowField, optional
        A guide SVG (``--flow``) or a :class:`repulsionpak.flow.FlowField`: elements turn
        to follow its field (their controls' ``flow``, ``axis``; docs/flow.md).

    Returns
    -------
    Packing
        Byte-identical files (:meth:`Packing.save`) to ``repulsionpak pack`` given the
        same inputs, seed and parameters.

    Notes
    -----
    ``on_snapshot`` receives progress snapshots (every ``snapshot_every`` iterations, and
    at the end of each phase); ``should_stop()`` (or Ctrl-C) ends the current phase early
    and the result is marked partial.

    ``on_checkpoint(states)`` receives ``{"primary": ..., "secondary": ...}`` simulator
    states every ``checkpoint_every`` iterations and when a phase ends (see
    :mod:`repulsionpak.checkpoint`); passing such a dict back as ``resume`` (with the same
    inputs and parameters) continues the run and ends with the same packing as an
    uninterrupted one. ``on_stage(name)`` is told when a stage without snapshots begins
    ("meshing and placing" before the simulation, "placing secondary copies" before the
    secondary one; "mapping the art", "verifying", "filling pockets", "filling holes" after
    them): they take seconds on large scenes.
    """
    from ._jit import warmup

    secondary = () if secondary is None else secondary
    _check_arguments(container, elements, secondary, params)
    params = params.validate()
    if params.seed is None:  # drawn here, so that the packing records the seed that made it
        import secrets  # noqa: PLC0415

        params = dataclasses.replace(params, seed=secrets.randbelow(2**31))
    inputs = load_inputs(container, elements, params, secondary)  # the gap; the container re-read for it
    container, elements, secondary, params = inputs.container, inputs.elements, inputs.secondary, inputs.params
    asked, given_secondary = params, tuple(secondary)
    for e in secondary:
        if getattr(e, "controls", None) is not None and e.controls.pins:
            raise ParameterError(f"{e.source}: pins are for primary elements; give the pinned "
                                 "element among the elements, not as a secondary one")
    if snapshot_every < 1:
        raise ParameterError(f"snapshot_every must be >= 1, got {snapshot_every}")
    rng = np.random.default_rng(params.seed)
    stage = on_stage or (lambda name: None)
    t0 = time.perf_counter()
    stage("meshing and placing")  # (seconds on large scenes, before any snapshot)
    ctrl = None
    if flow is not None:  # a flow field (flow/): the elements follow it
        from .flow.hook import check_elements, run_field  # noqa: PLC0415

        check_elements(elements)
        flow = run_field(flow, container)
    if flow is not None or any_controls(elements):  # designer controls (controls.py); none: the paper's way
        gap = checked_gap(container, elements, params)
        templates, placement, pinned, ctrl = prepare_controlled(container, elements, params, rng, gap, flow=flow)
    else:
        templates, placement, gap = prepare(container, elements, params, rng)
    model, state, frame = primary_model(container.region, templates, placement, gap, params,
                                        frozen=None if ctrl is None else pinned)
    if ctrl is not None:
        setup_model(model, ctrl, placement.angle, pinned)
    if flow is not None:
        from .flow.hook import attach  # noqa: PLC0415

        attach(model, flow, placement, ctrl, elements, pinned, frame.unit, params, templates)
    t1 = time.perf_counter()
    filled = bool(secondary) or params.secondary.auto  # the pockets get copies
    sim = Simulator(model, state, params.sim.for_run(filled, gap=model.gap), phase="primary")
    sim.templates = templates
    sim.relocator = primary_relocator(model, container.region, frame, params, filled=filled)
    warmup.compile_forward(serial=sim.threads() == 1)  # first run: this process's share of the kernels
    res = sim.run_resumable((resume or {}).get("primary"),
                            None if on_checkpoint is None else lambda st: on_checkpoint({"primary": st}),
                            checkpoint_every, on_snapshot=on_snapshot, should_stop=should_stop,
                            every=snapshot_every)
    t2 = time.perf_counter()
    packing = Packing(container, gap, [], templates, model, state, frame, params,
                      iterations={"primary": res.iterations, "secondary": 0},
                      seconds={"preprocess": t1 - t0, "primary": t2 - t1, "secondary": 0.0},
                      stopped_by={"primary": res.stopped_by}, area_fraction_meshes=res.area_fraction,
                      asked=asked, elements=tuple(elements), secondary=given_secondary,
                      sources=inputs.sources if sources is None else sources, flow=flow,
                      moves=[] if sim.relocator is None else list(sim.relocator.moves))
    user_cap = params.secondary.max_count  # a bound on every secondary copy, the fills' too
    auto = not secondary and params.secondary.auto  # pockets get copies of the primaries
    if auto:
        secondary = elements  # the pockets get small copies of the primaries (sec. 9)
        # at most 10 copies per primary, but never fewer than AUTO_FILL_MIN: a narrow
        # container's default count can be one or two primaries, whose band of pockets
        # then held 10 copies seeded at random points, the slack between them showing
        # in the median gap (docs/algorithm.md, narrow bands)
        cap = max(10 * len(placement.template_index), AUTO_FILL_MIN)
        mc = params.secondary.max_count
        params = dataclasses.replace(params, secondary=dataclasses.replace(
            params.secondary, max_count=cap if mc is None else min(mc, cap)))
        packing.params = params
    elif secondary and params.secondary.candidates is None:
        # given secondaries are the designer's mix: assigned at random, as in the paper
        params = dataclasses.replace(params, secondary=dataclasses.replace(params.secondary, candidates=1))
        packing.params = params
    if secondary and res.stopped_by != "interrupted":
        from .secondary import add_secondary, mesh_sizes, size_floor  # noqa: PLC0415

        primary_state = dict(sim.snapshot_state(), done=True, area=res.area_fraction)  # frozen from now on
        stage("placing secondary copies")
        add_secondary(packing, secondary, rng, on_snapshot=on_snapshot, should_stop=should_stop,
                      on_checkpoint=(None if on_checkpoint is None else
                                     lambda st: on_checkpoint({"primary": primary_state, "secondary": st})),
                      checkpoint_every=checkpoint_every, saved=(resume or {}).get("secondary"),
                      snapshot_every=snapshot_every,
                      min_size=size_floor(mesh_sizes(packing, "primary"), params.secondary.min_size) if auto else 0.0)
    t3 = time.perf_counter()
    stage("mapping the art")
    warmup.wait()  # first run: the render kernels are being compiled by the warm-up process
    v = params.verify
    m = packing.model
    drawn = np.arange(m.n_elements)  # the copies mapped: pocket copies sure to end below the floor are not
    if auto and params.secondary.min_size > 0 and packing.iterations.get("secondary"):
        from .secondary import worth_mapping  # noqa: PLC0415

        drawn = worth_mapping(packing, params.secondary.min_size, v.max_grow if v.repair else 1.0)
    placed = placed_art(packing.templates, m, packing.state, frame, elements=drawn, params=params.render)
    if m.pinned is not None:
        placed = [dataclasses.replace(p, pinned=True) if m.pinned[e] else p for e, p in zip(drawn, placed)]
    t4 = time.perf_counter()
    straightened: list[int] = []
    if v.repair:  # shapes kept: elements bent too far are replaced by their unbent copy
        sp = params.sim
        limits = np.array([(sp.bend_limit_convex if is_convex(packing.templates[ti]) else sp.bend_limit)
                           for ti in m.template_index]) * v.straighten
        limits[limits <= 0] = np.inf
        limits = straighten_limits(m, limits)[drawn]
        rest = rest_art(packing.templates, m, elements=drawn)
        placed, distortions, straightened = straighten(placed, rest, limits)
        if v.dent > 0:  # contacts of a limb or a back are bent away, not shrunk away
            frozen = np.zeros(m.n_elements, bool)  # pinned and rigid copies keep their shape
            for mask in (m.rigid, m.pinned):
                if mask is not None:
                    frozen |= mask
            placed, _ = dent(placed, container.region, gap, margin_of(params, gap), v.min_gap * gap,
                             rounds=v.dent, radius=v.dent_radius, frozen=frozen[drawn], rest=rest,
                             limits=limits, distortions=distortions)
    # a stop asked for during the verification ends its repair rounds; one asked for
    # during the simulation does not (the partial packing is repaired in full)
    stop_repair = None if should_stop is None or should_stop() else should_stop
    stage("verifying")
    packing.placed, packing.verification = verify_and_repair(
        placed, container.region, gap, margin_of(params, gap), v.min_gap * gap,
        min_scale=v.min_scale, repair=v.repair, straightened=straightened,
        grow_to=v.grow_to * gap, max_scale=v.max_grow, should_stop=stop_repair,
        grow_reach=skin_excess(params, gap), gather=v.gather * gap,
        max_turn=None if m.rot_on is None else np.where(m.rot_on, 0.0, np.inf)[drawn])
    if stop_repair is not None and v.repair and stop_repair():
        packing.stopped_by["verify"] = "interrupted"  # a partial packing (exit 130), promises kept
    packing.seconds["verify"] = time.perf_counter() - t4
    sec = params.secondary
    floor = 0.0
    if auto and sec.min_size > 0:  # the floor on the mapped art: copies pressed below it go
        from .secondary import art_size, size_floor  # noqa: PLC0415

        floor = size_floor([art_size(q.art) for q in packing.placed if q.kind == "primary"], sec.min_size)
        packing.placed = [q for q in packing.placed if q.kind == "primary" or art_size(q.art) >= floor]
    if (sec.fill_holes or sec.fill_leftover) and secondary and not packing.partial:
        from .holes import HoleLibrary, budget_for, fill_holes, fill_pockets  # noqa: PLC0415

        library = HoleLibrary.of(secondary)
        # the fills' work is bounded by the primary simulation's (holes.FillBudget)
        m = packing.model
        sizes = np.diff(m.elem_vstart)
        budget = budget_for(int(sum(int(n) for n, k in zip(sizes, m.kind) if k == "primary")),
                            max(int(packing.iterations.get("primary", 0)), 1))
        if library is not None and sec.fill_leftover:  # what the verification left (holes.py)
            t5 = time.perf_counter()
            stage("filling pockets")
            packing.placed = packing.placed + fill_pockets(
                packing.placed, library, container.region, gap, margin_of(params, gap), rng,
                sec.hole_min_radius * gap, params.render, limit=_room(user_cap, packing.placed),
                min_size=floor, into_holes=sec.fill_holes, budget=budget)
            packing.seconds["leftover"] = time.perf_counter() - t5
        if library is not None and sec.fill_holes:  # the holes of the art are pockets too (holes.py)
            t5 = time.perf_counter()
            stage("filling holes")
            packing.placed = packing.placed + fill_holes(
                packing.placed, library, gap, rng, sec.hole_min_radius * gap, sec.hole_depth, params.render,
                limit=_room(user_cap, packing.placed), min_size=floor, budget=budget)
            packing.seconds["holes"] = time.perf_counter() - t5
    packing.seconds["render"] = t4 - t3
    packing.seconds["total"] = time.perf_counter() - t0
    if not packing.placed and packing.verification is not None and packing.verification.dropped:
        raise ParameterError(
            f"no element fits: the final verification dropped all {len(packing.verification.dropped)}, "
            f"which could not keep the gap ({gap:g}) and the edge margin ({margin_of(params, gap):g}) in "
            "this container even shrunk to half their size; use a smaller gap, a smaller margin or "
            "fewer, smaller elements")
    return packing


def _room(cap: int | None, placed: list[PlacedArt]) -> int | None:
    """How many more secondary copies ``cap`` allows beside ``placed`` (None: no cap)."""
    return None if cap is None else max(0, cap - sum(1 for p in placed if p.kind == "secondary"))


__all__ = ["pack", "prepare"]
