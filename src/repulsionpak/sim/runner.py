"""The simulation loop: contacts → forces (Eq. 1) → Euler step → growth → self-intersection fix → stopping rule.

:class:`Simulator` advances a :class:`~repulsionpak.sim.model.State` (every array that
changes) over a :class:`~repulsionpak.sim.model.Model` (the arrays that do not); it owns
only scratch buffers and the cell lists. The force terms are the list
:func:`~repulsionpak.sim.terms.terms_of` gives, each called as ``term(model, state,
forces)``. :meth:`Simulator.run` calls ``on_snapshot`` every few iterations; progress
bars, frame writers and checkpoints are such consumers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from .._jit.kernels import parallel_ready, set_threads
from ..errors import DivergedError
from ..params import SimParams
from ..threads import thread_cap
from .contacts import find_contacts, follow_contacts
from .controls import apply_controls
from .forces import corner_candidates, mark_corners_near, project_inside
from .grid import Grid, bin_points
from .integrate import (confined_contacts, count_inside, deep_contacts, euler_step, grow, growth_speed_caps,
                        growth_steps, skin_areas, window_change)
from .model import Model, State
from .relocate import Relocator
from .selfintersect import relax_self_intersections
from .shape import limit_deformation
from .skinwidth import SKIN_RELAX, keep_skin_width, narrow_grown_skins
from .terms import terms_of
from .threadgov import WINDOW as GOV_WINDOW
from .threadgov import ThreadGovernor

#: Between full queries a vertex gets a point-in-mesh test against a neighbour whose skin
#: is within this many velocity-capped steps (``vmax · dt``) of it. The contacts refresh
#: every neighbour's distance each step (within ``sim.far_update``), and in one step a
#: vertex and a skin close in by at most two such steps under the Euler update; the rest
#: is room for the constraints' corrections. A vertex farther out was outside the mesh a
#: step ago and cannot have crossed its skin since. (The reach between full queries,
#: 4 × 32 steps, would test every refreshed pair: half of the refresh's time on a jam of
#: 300 elements. The heart's inside flags differ from that radius's in 5 vertex-steps of
#: about 9 million, each caught by the next full query.)
NEAR_STEPS = 8.0


def stop_threshold(epsilon: float, moving_vertices: int, reference: int) -> float:
    """The stopping rule's threshold for a phase of ``moving_vertices``.

    Parameters
    ----------
    epsilon : float
        The threshold per iteration (``sim.stop_epsilon``).
    moving_vertices : int
        The vertices of the phase's moving meshes.
    reference : int
        ``sim.stop_vertices``; 0: off.

    Returns
    -------
    float
        ``epsilon`` up to ``reference`` vertices (and when ``reference`` is 0),
        ``epsilon × moving_vertices / reference`` beyond.

    Notes
    -----
    The paper samples the area once per second, so its rule asks a fixed gain of each
    second of work. At a fixed threshold per iteration, a large scene, each of whose
    iterations costs in proportion to its vertices, walked its last creep at that cost:
    the 1,000-element poster spent the second half of its iterations on 0.01 of art area.
    Up to ``reference`` (above every scene of the suites) the threshold is the one per
    iteration, so those scenes stop where they did.
    """
    if reference <= 0 or moving_vertices <= reference:
        return epsilon
    return epsilon * (moving_vertices / reference)


@dataclass(frozen=True)
class Snapshot:
    """What consumers see of a running simulation (arrays are live views: copy to keep)."""

    phase: str
    iteration: int
    area_fraction: float
    rms: float
    n_elements: int
    n_inside: int
    state: State
    done: bool = False
    model: Model | None = None  # whose element layout ``state.x`` follows (frame writers)
    sim: "Simulator | None" = None  # the simulator itself (the live view steers through it)


@dataclass(frozen=True)
class GoodState:
    """What a divergence recovery restores (:meth:`Simulator.mark_good`): positions,
    growth counters, the iteration and the length of the area history then."""

    x: np.ndarray
    n_grow: np.ndarray
    iteration: int
    history: int


@dataclass(frozen=True)
class RunResult:
    iterations: int
    area_fraction: float
    stopped_by: str  # "converged" | "max_iterations" | "interrupted"
    dt: float


def auto_threads() -> int:
    """The most threads an automatic run may use: ``$REPULSIONPAK_THREADS`` if set
    (:func:`repulsionpak.threads.thread_cap`), else numba's thread count (the cores this
    process may use)."""
    cap = thread_cap()
    return numba.config.NUMBA_NUM_THREADS if cap is None else min(cap, numba.config.NUMBA_NUM_THREADS)


class Simulator:
    """Advance a packing. ``phase`` is a label ("primary"/"secondary") for snapshots."""

    templates: list | None = None  # the model's templates, set by pack() for snapshot renderers
    #: moves of cramped elements into voids at convergence (:mod:`~repulsionpak.sim.relocate`)
    relocator: Relocator | None = None

    def __init__(self, model: Model, state: State, params: SimParams, phase: str = "primary"):
        self.model, self.state, self.params, self.phase = model, state, params, phase
        m = model
        N = m.n_vertices
        state.begin(m, params.dt)
        #: the force terms summed every step (Eq. 1 and the ones beyond the paper)
        self.terms = terms_of(params)
        self.relaxed = self._relaxed()
        self.grid = Grid(m.grid_origin, m.grid_extent, m.cell_size, m.tri_cell_size, len(m.skin.chunk_a),
                         len(m.tris))
        self.F = np.zeros((N, 2))  # the force accumulator of a step
        self.live_tris = np.flatnonzero(~m.frozen[m.tri_elem]).astype(np.int64)
        self._corner_bins = None  # the corners binned into the current triangle cells
        self._corner_mark = np.zeros(len(m.corners), np.int64)
        self._corner_stamp = 0
        self.moving_area = 0.0
        self.relax_order = np.arange(N, dtype=np.int64)
        self.edge_rest = self._edge_rest()
        #: k_g (``sim.k_growth``, None: the filled runs' rate, :meth:`SimParams.growth_rate`)
        self.k_growth = kg = params.growth_rate()
        # each element's velocity cap at the parameters' Δt (scaled with Δt: see ``dt``)
        self.vmax = growth_speed_caps(m.x_rest, m.elem_vstart, m.elem_nskin, params.velocity_cap,
                                      params.dt, kg, params.growth_headroom)
        # the caps of an element growing fast (``fast_growth`` steps an iteration: it has room)
        self.vmax_fast = growth_speed_caps(m.x_rest, m.elem_vstart, m.elem_nskin, params.velocity_cap,
                                           params.dt, kg * params.fast_growth,
                                           params.growth_headroom)
        self.grow_steps = np.ones(m.n_elements, np.int64)  # growth steps per element this iteration
        self.n_fast = 0  # elements growing fast this iteration
        self.dt = params.dt
        self.max_growth = m.max_growth * params.growth_cap()
        # fast growth ends this far along from the placed size to the largest
        self.fast_until = 1.0 + (self.max_growth - 1.0) * params.fast_growth_until
        self.far2 = (params.far_update * m.gap) ** 2
        # a vertex this close to a neighbouring skin gets a point-in-mesh test every step
        # (:data:`NEAR_STEPS`; frozen elements do not move: only the moving ones' caps bound
        # an approach, a fast grower's the higher)
        fastest = self.vmax_fast if params.fast_growth > 1 else self.vmax
        self.near2 = (NEAR_STEPS * float(fastest[state.moving].max(initial=0.0)) * params.dt) ** 2
        self._good: GoodState | None = None
        self._recoveries = 0

    @property
    def dt(self) -> float:
        """The time step (``state.dt``, halved by a divergence recovery); the velocity caps follow it."""
        return self.state.dt

    @dt.setter
    def dt(self, value: float) -> None:
        self.state.dt = float(value)
        self._vmax_dt = self.vmax * (self.state.dt / self.params.dt)
        self._vmax_fast_dt = self.vmax_fast * (self.state.dt / self.params.dt)
        self._vmax_step = self._vmax_dt.copy()  # this iteration's caps (fast growers': higher)

    # -- one iteration -------------------------------------------------------------
    def step(self) -> float:
        """Advance one iteration (sec. 5–8); return the area fraction of the meshes."""
        m, st, p, F = self.model, self.state, self.params, self.F
        self.update_contacts(full=st.iteration % p.requery_every == 0)
        vmax = self._growth_rates()
        F[:] = 0.0
        for term in self.terms:  # F = F_r + F_e + F_b + F_o (Eq. 1), and the terms beyond it
            term(m, st, F)
        euler_step(st.x, st.v, F, st.active_all, self.dt, vmax, m.vert_elem)
        self._constrain()
        self._grow()
        if p.relax_passes > 0:  # fix self-intersections (sec. 7)
            relax_self_intersections(st.x, m.elem_vstart, m.elem_nskin, self.relaxed, self.edge_rest,
                                     st.growth, m.vnbr_ptr, m.vnbr, p.relax_passes, p.relax_fraction,
                                     self.relax_order)
        total, moving = skin_areas(st.x, m.elem_vstart, m.elem_nskin, st.moving, st.areas)
        st.iteration += 1
        self.moving_area = moving / m.container_area
        return total / m.container_area

    def update_contacts(self, full: bool) -> None:
        """The contact state of every active skin vertex: a full query over cell lists
        rebuilt on the current positions (:func:`~repulsionpak.sim.contacts.find_contacts`,
        with the reflex corners' candidate triangles), or the cheap walk that follows the
        last one (:func:`~repulsionpak.sim.contacts.follow_contacts`)."""
        m, st, g = self.model, self.state, self.grid
        if full:
            if len(m.corners):  # (the centroid cells serve only the corners)
                g.fit_triangles(st.x, m.tris)
                g.rebuild_triangles(st.x, m.tris, m.tri_elem)
                self._gather_corner_triangles()
            g.cover.rebuild(st.x, m.tris, m.tri_elem)
            g.rebuild_segments(st.x, m.skin.chunk_a, m.skin.chunk_b, m.skin.chunk_elem)
            find_contacts(m, st, g)
        else:
            follow_contacts(m, st, self.near2, self.far2)

    def _constrain(self) -> None:
        """The constraints after the Euler step, beyond the paper: vertices back inside the
        container while settling, skins kept wide, deformation limits, and the designer's
        rotation limits and rigid bodies."""
        m, st, p = self.model, self.state, self.params
        if p.hard_boundary and not st.allow_growth:  # while settling
            f = m.field
            project_inside(st.x, st.active_all, f.values, f.ox, f.oy, 1.0 / f.h, 0.0)
        if p.skin_width > 0 and m.anchor_tri is not None:
            keep_skin_width(st.x, m.tris, m.anchor_tri, m.anchor_bary, m.anchor_w, m.ring_sign,
                            st.moving, m.elem_vstart, m.elem_nskin, st.growth, p.skin_width, SKIN_RELAX)
        if m.bend_limit.any():
            limit_deformation(st.x, m.x_rest, m.elem_vstart, st.moving, m.bend_limit, st.inside)
        if m.rot_on is not None:  # designer controls: rotation limits, rigid bodies
            if m.flow is not None:  # the windows of copies that follow a flow field move with them
                m.flow.update(st.x, m)
            apply_controls(st.x, st.v, m.x_rest, m.elem_vstart, st.moving, m.rot_on, m.rot_lo,
                           m.rot_hi, m.rigid)

    def _grow(self) -> None:
        """Growth (sec. 6): every element without a blocking contact (a vertex inside
        another mesh, or too far outside the container) counts one more step of growth."""
        m, st, p = self.model, self.state, self.params
        blocking = st.inside
        if p.contact_depth > 0.0 and st.allow_growth:  # shallow overlaps do not stop growth
            deep_contacts(st.inside, st.nb_count, st.nb_d2, (p.contact_depth * m.gap) ** 2, st.blocking)
            blocking = st.blocking
        if p.one_sided_growth > 0.0 and st.allow_growth:  # contacts from one side do not stop growth
            confined_contacts(st.x, blocking, m.elem_vstart, m.elem_nskin, st.moving, p.one_sided_growth,
                              st.blocking)
            blocking = st.blocking
        grow(blocking, st.outside, m.elem_vstart, m.elem_nskin, st.moving, st.n_grow,
             st.growth, self.k_growth * p.dt, st.allow_growth, self.max_growth, self.grow_steps)

    def _growth_rates(self) -> np.ndarray:
        """Each element's growth steps this iteration (``self.grow_steps``: ``fast_growth``
        for one with room, :func:`~repulsionpak.sim.integrate.growth_steps`, else 1) and
        the velocity caps that go with them (returned: a fast grower's vertices must keep
        up with its rest lengths)."""
        m, st, p = self.model, self.state, self.params
        fast = p.fast_growth if st.allow_growth else 1
        if fast <= 1:  # every element at the paper's rate: one step each (the default)
            if self.n_fast:
                self.grow_steps[:] = 1
                self.n_fast = 0
            return self._vmax_dt
        f = m.field
        self.n_fast = growth_steps(st.x, m.elem_vstart, m.elem_nskin, st.moving, st.nb_count, st.nb_d2,
                                   f.values, f.ox, f.oy, 1.0 / f.h, p.fast_growth_clearance * m.gap,
                                   fast, st.growth, self.fast_until, self.grow_steps)
        if self.n_fast == 0:
            return self._vmax_dt
        np.copyto(self._vmax_step, self._vmax_dt)
        np.copyto(self._vmax_step, self._vmax_fast_dt, where=self.grow_steps > 1)
        return self._vmax_step

    def _gather_corner_triangles(self, by_cells: bool | None = None) -> None:
        """The reflex corners near a moving mesh and their candidate triangles, from the
        freshly built triangle grid (the buffer grows when the windows hold more than it
        has room for). Only corners within a cell of a live triangle cost anything: a
        jagged container's thousands of corners away from the moving meshes are never
        looked at (a step cost ~O(corners × triangles per window) before). The corners
        are binned into the triangle cells once per cell size."""
        m, st, t = self.model, self.state, self.grid.tris
        bins = self._corner_bins
        if bins is None or bins[0] is not t:  # new cells (fit_triangles): bin the corners again
            key = np.zeros(len(m.corners), np.int64)
            start = np.zeros(t.gx * t.gy + 1, np.int64)
            order = np.zeros(len(m.corners), np.int64)
            corners = np.ascontiguousarray(m.corners, dtype=np.float64)
            bin_points(corners[:, 0].copy(), corners[:, 1].copy(), *t.params, start, order, key)
            bins = self._corner_bins = (t, key, start, order, np.zeros(t.gx * t.gy, np.int64))
        _, key, start, order, cell_mark = bins
        if by_cells is None:  # from the live triangles' cells when that is cheaper (the same lists)
            by_cells = len(self.live_tris) < 9 * len(m.corners)
        while True:
            self._corner_stamp += 1
            if by_cells:
                mark_corners_near(self.live_tris, t._keys, t.gx, t.gy, start, order, cell_mark,
                                  self._corner_mark, self._corner_stamp)
            n, need = corner_candidates(key, by_cells, self._corner_mark, self._corner_stamp, m.tri_elem,
                                        m.frozen, t.order, t.start, t.gx, t.gy, st.corner_active,
                                        st.corner_ptr, st.corner_tris)
            if need <= len(st.corner_tris):
                break
            st.corner_tris = np.zeros(2 * need, np.int64)
        st.n_corner_active = n

    def _relaxed(self) -> np.ndarray:
        """The elements whose skins the self-intersection relaxation may move: not rigid
        bodies, which keep exactly the similarity of their rest shape the controls give
        them (a rest skin does not self-intersect; relaxed, a rigid letter's narrow
        notches were pushed apart after every projection and its copies bent by ~1 %)."""
        rigid = self.model.rigid
        moving = self.state.moving
        return moving if rigid is None else moving & ~rigid

    def set_moving(self, elem: int, moving: bool) -> None:
        """Pin (``moving=False``) or release element ``elem`` between iterations: a pinned
        element neither moves nor grows but still repels (the live view's pin)."""
        now = self.state.moving.copy()
        now[elem] = bool(moving)
        self.state.set_moving(self.model, now)
        self.relaxed = self._relaxed()

    def begin_settle(self) -> None:
        """Stop growing; the last iterations only resolve overlaps and even out gaps (and,
        with ``sim.narrow_skins``, pull in the skins of the copies grown past their planned
        size: :func:`~repulsionpak.sim.skinwidth.narrow_grown_skins`)."""
        self.state.allow_growth = False
        self._narrow_skins()

    def _narrow_skins(self) -> None:
        """Narrow the grown copies' skins (``sim.narrow_skins``) and take the relaxation's
        length scale from the new rest lengths."""
        if self.params.narrow_skins and narrow_grown_skins(self.model, self.state):
            self.edge_rest = self._edge_rest()

    def _edge_rest(self) -> np.ndarray:
        """Each element's mean edge rest length (before growth): the relaxation's length scale."""
        m = self.model
        edge_elem = m.spring_elem[m.spring_is_edge]
        return (np.bincount(edge_elem, weights=m.rest0[m.spring_is_edge], minlength=m.n_elements)
                / np.maximum(np.bincount(edge_elem, minlength=m.n_elements), 1))

    def threads(self) -> int:
        """numba threads this run starts on (see :meth:`thread_range`)."""
        return self.thread_range()[0]

    def thread_range(self) -> tuple[int, int]:
        """``(start, most)``: the threads this run starts on and the most it may use.

        A chosen count (``sim.threads > 0``) is kept: ``start == most``. An automatic run
        (``sim.threads = 0``) uses one thread below ``parallel_threshold`` vertices (on
        small scenes handing work between threads costs more than it saves) or while the
        parallel builds are not cached or the threading layer does not suit them
        (:func:`repulsionpak._jit.kernels.parallel_ready`); otherwise it starts on one thread
        and a :class:`~repulsionpak.sim.threadgov.ThreadGovernor` moves it between one and
        the cores allowed (:func:`auto_threads`) as measured iteration times say: a
        thread sharing its core with another busy process holds up every parallel loop, and
        which processes run changes during a run."""
        if self.params.threads > 0:
            n = min(self.params.threads, numba.config.NUMBA_NUM_THREADS)
            return n, n
        limit = auto_threads()
        if limit < 2 or self.model.n_vertices < self.params.parallel_threshold or not parallel_ready():
            return 1, 1
        return 1, limit

    @property
    def n_inside(self) -> int:
        return int(count_inside(self.state.inside, self.state.active_skin))

    def refresh_growth(self) -> None:
        """Recompute growth factors from the counters (after loading a state)."""
        self.state.refresh_growth(self.k_growth * self.params.dt)

    def stop_threshold(self) -> float:
        """The stopping rule's threshold for this phase's moving vertices now
        (:func:`stop_threshold`)."""
        p, act = self.params, self.state.active_all
        return stop_threshold(p.stop_epsilon, 0 if act is None else len(act), p.stop_vertices)

    # -- the loop --------------------------------------------------------------------
    def run(self, on_snapshot: Callable[[Snapshot], None] | None = None, every: int = 25,
            should_stop: Callable[[], bool] | None = None,
            on_checkpoint: Callable[["Simulator"], None] | None = None,
            checkpoint_every: int = 0) -> RunResult:
        """Iterate until the stopping rule of sec. 8 holds (or ``max_iterations``), then
        settle without growth for ``settle_iterations``.

        Stopping rule (sec. 8): the RMS of the per-iteration change of the area fraction of
        the moving meshes over the last ``stop_window`` iterations, relative to that area
        fraction, < ``stop_epsilon`` — or the net change over the window (per iteration,
        relative) below it: meshes that only jitter against their neighbours have stopped
        consuming space even if the RMS of their jitter stays up. Relative, so a phase of
        small secondary elements is judged by its own growth, not by the frozen primaries'.
        The threshold grows with a large scene's moving vertices (:meth:`stop_threshold`).
        ``should_stop()`` returning True (or KeyboardInterrupt) ends the run early with
        ``stopped_by="interrupted"``.

        ``on_checkpoint(self)`` is called every ``checkpoint_every`` iterations (rounded
        up to a multiple of ``requery_every``, where the state is complete: the next step
        starts with a full neighbour query), so a run resumed from it with
        :meth:`restore` continues exactly as the uninterrupted one.
        """
        p, st = self.params, self.state
        self.refresh_growth()
        start, most = self.thread_range()
        threads = set_threads(start, load=True)
        # a chosen thread count is kept; an automatic one follows the machine's load
        gov = ThreadGovernor(most if p.threads == 0 else 1, start,
                             window=p.requery_every * -(-GOV_WINDOW // p.requery_every))
        hist = st.area_history
        w = p.stop_window
        a = hist[-1] if hist else 0.0
        rms = trend = math.inf
        # numpy mirror of the history for the stopping rule (the list is what checkpoints keep)
        hbuf = np.zeros(max(2 * len(hist), 1024))
        hbuf[:len(hist)] = hist
        probe = int(st.active_all[0]) if len(st.active_all) else -1  # NaN check of one vertex
        if checkpoint_every > 0:
            checkpoint_every = -(-checkpoint_every // p.requery_every) * p.requery_every
        self.mark_good()
        try:
            while True:
                gov.begin()
                a = self.step()
                switch = gov.end()
                if switch is not None:
                    set_threads(switch, load=True)
                if not math.isfinite(a) or (probe >= 0 and not math.isfinite(st.x[probe, 0])):
                    self._recover()
                    continue
                hist.append(self.moving_area)
                n = len(hist)
                if n > len(hbuf):
                    hbuf = np.concatenate([hbuf, np.zeros(len(hbuf))])
                hbuf[n - 1] = self.moving_area
                if n > w:
                    rms, trend = window_change(hbuf, n, w)
                    rms /= max(self.moving_area, 1e-12)
                    trend /= max(self.moving_area, 1e-12)
                if st.iteration % 200 == 0:
                    self._check_exploded()
                    self.mark_good()
                if on_snapshot is not None and st.iteration % every == 0:
                    on_snapshot(Snapshot(self.phase, st.iteration, a, rms, self.model.n_elements,
                                         self.n_inside, st, model=self.model, sim=self))
                if st.settle_left is None:
                    converged = (st.iteration >= p.min_iterations and len(hist) > w
                                 and min(rms, 2.0 * trend) < self.stop_threshold())
                    if converged and self.relocator is not None and self.relocator.at_convergence(self):
                        converged = False  # a move into a void is being tried: growth goes on
                    if converged or st.iteration >= p.max_iterations:
                        if self.relocator is not None:
                            self.relocator.judge(self)  # a move still pending at the bound
                        st.stopped_by = "converged" if converged else "max_iterations"
                        st.settle_left = p.settle_iterations
                        self.begin_settle()
                if st.settle_left is not None:
                    if st.settle_left <= 0:
                        break
                    st.settle_left -= 1
                if (on_checkpoint is not None and checkpoint_every and st.iteration % checkpoint_every == 0
                        and (self.relocator is None or self.relocator.pending is None)):
                    on_checkpoint(self)
                if should_stop is not None and should_stop():
                    st.stopped_by = "interrupted"
                    break
        except KeyboardInterrupt:
            st.stopped_by = "interrupted"
        finally:
            set_threads(threads)
        if on_snapshot is not None:
            on_snapshot(Snapshot(self.phase, st.iteration, a, rms, self.model.n_elements,
                                 self.n_inside, st, done=True, model=self.model, sim=self))
        return RunResult(st.iteration, a, st.stopped_by, self.dt)

    def run_resumable(self, saved: dict | None, on_checkpoint: Callable[[dict], None] | None,
                      checkpoint_every: int, **run_kw) -> RunResult:
        """:meth:`run`, continuing from ``saved`` (a checkpointed phase state) if given.

        ``on_checkpoint(state)`` receives :meth:`snapshot_state` plus ``done`` and
        ``area`` periodically and once when the phase ends (not when it is interrupted:
        the last periodic checkpoint is the one to resume from)."""
        if saved is not None:
            self.restore(saved)
            if saved.get("done"):
                return RunResult(self.state.iteration, float(saved.get("area", 0.0)),
                                 self.state.stopped_by, self.dt)

        def save(s: "Simulator", done: bool = False) -> None:
            if on_checkpoint is not None:
                on_checkpoint(dict(s.snapshot_state(), done=done, area=s.moving_area))

        res = self.run(on_checkpoint=save, checkpoint_every=checkpoint_every if on_checkpoint else 0,
                       **run_kw)
        if res.stopped_by != "interrupted":
            save(self, done=True)
        return res

    # -- checkpoints -------------------------------------------------------------------
    def snapshot_state(self) -> dict:
        """The state as a checkpoint (:meth:`~repulsionpak.sim.model.State.saved`), this
        phase's label and the moves' bookkeeping (:meth:`Relocator.saved`)."""
        out = dict(self.state.saved(), phase=self.phase)
        if self.relocator is not None:
            out["relocate"] = self.relocator.saved()
        return out

    def restore(self, saved: dict) -> None:
        """Continue from :meth:`snapshot_state` output (same model)."""
        self.state.load(saved, self.k_growth * self.params.dt)
        self.dt = self.state.dt  # the velocity caps follow the saved time step
        if not self.state.allow_growth:  # saved while settling: the skins as they were narrowed
            self._narrow_skins()
        if self.relocator is not None and "relocate" in saved:
            self.relocator.load(saved["relocate"])

    # -- divergence --------------------------------------------------------------------
    def _check_exploded(self) -> None:
        x = self.state.x[self.state.active_all]
        if not np.isfinite(x).all():
            self._recover()
            return
        f = self.model.field
        ny, nx = f.values.shape
        lo = np.array([f.ox, f.oy]) - 1000.0
        hi = np.array([f.ox + nx * f.h, f.oy + ny * f.h]) + 1000.0
        if (x < lo).any() or (x > hi).any():
            self._recover()

    def mark_good(self) -> None:
        """Remember the current state as the one a divergence recovery restores (every 200
        iterations of a run, and after an edit that changes the model: the live view's,
        the studio's). Only what :meth:`_recover` puts back is copied: a whole
        :class:`State` copy took ~9 % of a poster's secondary phase."""
        st = self.state
        self._good = GoodState(st.x.copy(), st.n_grow.copy(), st.iteration, len(st.area_history))

    def _recover(self) -> None:
        """Restore the last good state and halve the time step; give up after 4 tries."""
        self._recoveries += 1
        if self._good is None or self._recoveries > 4:
            raise DivergedError(
                f"the simulation diverged at iteration {self.state.iteration} (NaN or exploding "
                f"positions) even with Δt reduced to {self.dt:g}; try a smaller sim.dt or "
                "weaker force constants")
        good = self._good
        self.state.x[:] = good.x
        self.state.v[:] = 0.0
        self.state.n_grow[:] = good.n_grow
        self.state.iteration = good.iteration
        del self.state.area_history[good.history:]
        self.dt *= 0.5
        self.refresh_growth()
