"""The simulation loop: forces → Euler step → growth → self-intersection fix → stopping rule.

:class:`Simulator` owns the scratch buffers (allocated once) and advances a
:class:`~repulsionpak.sim.model.State` over a :class:`~repulsionpak.sim.model.Model`.
:meth:`Simulator.run` calls ``on_snapshot`` every few iterations; progress bars, frame
writers and checkpoints are such consumers.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from ..errors import DivergedError, ParameterError
from ..params import SimParams
from .forces import (boundary_force, contact_query, contact_update, corner_candidates, corner_force,
                     edge_force, inversion_force, mark_corners_near, overlap_force, project_inside,
                     repulsion_force, shape_force)
from .grid import Grid, bin_points
from .integrate import (confined_contacts, count_inside, euler_step, grow, growth_speed_caps, skin_areas,
                        window_change)
from .._jit.kernels import parallel_ready, set_threads
from .threadgov import WINDOW as GOV_WINDOW
from .threadgov import ThreadGovernor
from .model import Model, State, element_ranges
from .controls import apply_controls, edge_force_stiff
from .selfintersect import relax_self_intersections
from .shape import limit_deformation
from .skinwidth import SKIN_RELAX, keep_skin_width

MAX_NEIGHBOURS = 24
CHUNK = 4  # skin segments per chunk in the full neighbour query


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
class RunResult:
    iterations: int
    area_fraction: float
    stopped_by: str  # "converged" | "max_iterations" | "interrupted"
    dt: float


def skin_topology(m: Model) -> tuple[np.ndarray, ...]:
    """Skin segments (a, b, element, next, previous) and chunks (a, b, element, first
    segment, segment count) of all meshes, as flat arrays. Segment k of a mesh runs from
    its skin vertex k to k+1; the segments of one mesh are consecutive."""
    seg, chunk = [], []
    base = 0
    for e in range(m.n_elements):
        s, n = int(m.elem_vstart[e]), int(m.elem_nskin[e])
        k = np.arange(n)
        seg.append(np.column_stack([s + k, s + (k + 1) % n, np.full(n, e), base + (k + 1) % n,
                                    base + (k - 1) % n]))
        j = np.arange(0, n, CHUNK)
        cnt = np.minimum(CHUNK, n - j)
        chunk.append(np.column_stack([s + j, s + (j + cnt) % n, np.full(len(j), e), base + j, cnt]))
        base += n
    seg, chunk = np.concatenate(seg).astype(np.int64), np.concatenate(chunk).astype(np.int64)
    return (seg[:, 0].copy(), seg[:, 1].copy(), seg[:, 2].astype(np.int32), seg[:, 3].copy(),
            seg[:, 4].copy(), chunk[:, 0].copy(), chunk[:, 1].copy(), chunk[:, 2].astype(np.int32),
            chunk[:, 3].copy(), chunk[:, 4].copy())


#: environment variable: the most threads a run with ``sim.threads = 0`` uses (e.g. 1 when
#: several packings run side by side on the same cores)
THREADS_ENV = "REPULSIONPAK_THREADS"


def auto_threads() -> int:
    """The most threads an automatic run may use: ``$REPULSIONPAK_THREADS`` if set, else
    numba's thread count (the cores this process may use)."""
    text = os.environ.get(THREADS_ENV, "").strip()
    if not text:
        return numba.config.NUMBA_NUM_THREADS
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise ParameterError(f"{THREADS_ENV} must be a positive whole number of threads, got {text!r}")
    return min(n, numba.config.NUMBA_NUM_THREADS)


class Simulator:
    """Advance a packing. ``phase`` is a label ("primary"/"secondary") for snapshots."""

    templates: list | None = None  # the model's templates, set by pack() for snapshot renderers

    def __init__(self, model: Model, state: State, params: SimParams, phase: str = "primary"):
        self.model, self.state, self.params, self.phase = model, state, params, phase
        m = model
        N, M = m.n_vertices, m.n_elements
        moving = ~m.frozen
        self.moving = moving.copy()
        self.relaxed = self._relaxed()
        vmask = moving[m.vert_elem]
        self.active_all = np.flatnonzero(vmask).astype(np.int64)
        self.active_skin = np.flatnonzero(vmask & m.is_skin).astype(np.int64)
        # skin segments of every element (also frozen ones: they repel), their ring
        # neighbours, and chunks of CHUNK consecutive segments for the full-query scan
        (self.seg_a, self.seg_b, self.seg_elem, self.seg_next, self.seg_prev, self.chunk_a,
         self.chunk_b, self.chunk_elem, self.chunk_first, self.chunk_count) = skin_topology(m)
        self.grid = Grid(m.grid_origin, m.grid_extent, m.cell_size, m.tri_cell_size, len(self.chunk_a), len(m.tris))
        self.F = np.zeros((N, 2))
        # reflex corners near a moving mesh (``corner_active[:n_corner_active]``) and their
        # candidate triangles, gathered at each full query (see _gather_corner_triangles)
        self.corner_active = np.zeros(len(m.corners), np.int64)
        self.n_corner_active = 0
        self.corner_ptr = np.zeros(len(m.corners) + 1, np.int64)
        self.corner_tris = np.zeros(1024, np.int64)  # grown on demand
        self.live_tris = np.flatnonzero(~m.frozen[m.tri_elem]).astype(np.int64)
        self._corner_bins = None  # the corners binned into the current triangle cells
        self._corner_mark = np.zeros(len(m.corners), np.int64)
        self._corner_stamp = 0
        self.inside = np.zeros(N, np.bool_)
        self.blocking = np.zeros(N, np.bool_)  # the inside vertices that stop growth (confined_contacts)
        self.outside = np.zeros(N, np.bool_)
        self.nb_count = np.zeros(N, np.int64)
        self.nb_elem = np.zeros((N, MAX_NEIGHBOURS), np.int32)
        self.nb_d2 = np.zeros((N, MAX_NEIGHBOURS))
        self.nb_q = np.zeros((N, MAX_NEIGHBOURS, 2))
        self.nb_seg = np.zeros((N, MAX_NEIGHBOURS), np.int64)
        self.growth = np.ones(M)
        self.areas = np.zeros(M)
        self.moving_area = 0.0
        self.relax_order = np.arange(N, dtype=np.int64)
        self.sp_ptr = element_ranges(m.spring_elem, M)
        self.tri_ptr = element_ranges(m.tri_elem, M)
        # each element's mean edge rest length (before growth): the relaxation's length scale
        edge_elem = m.spring_elem[m.spring_is_edge]
        self.edge_rest = (np.bincount(edge_elem, weights=m.rest0[m.spring_is_edge], minlength=M)
                          / np.maximum(np.bincount(edge_elem, minlength=M), 1))
        # each element's velocity cap at the parameters' Δt (scaled with Δt: see ``dt``)
        self.vmax = growth_speed_caps(m.x_rest, m.elem_vstart, m.elem_nskin, params.velocity_cap,
                                      params.dt, params.k_growth, params.growth_headroom)
        self.dt = params.dt
        self.max_growth = m.max_growth * params.max_size
        self.far2 = (params.far_update * m.gap) ** 2
        # a vertex this close to a neighbouring skin gets a point-in-mesh test every step
        # (frozen elements do not move: only the moving ones' caps bound an approach)
        self.near2 = (4.0 * float(self.vmax[moving].max(initial=0.0)) * params.dt
                      * max(1, params.requery_every)) ** 2
        self.allow_growth = True
        self.settle_left: int | None = None  # iterations left in the settle phase
        self.stopped_by = "max_iterations"
        self._good: State | None = None
        self._recoveries = 0

    @property
    def dt(self) -> float:
        """The time step (halved by a divergence recovery); the velocity caps follow it."""
        return self._dt

    @dt.setter
    def dt(self, value: float) -> None:
        self._dt = float(value)
        self._vmax_dt = self.vmax * (self._dt / self.params.dt)

    def update_contacts(self, full: bool) -> None:
        """The contact state of every active skin vertex (inside another mesh, the nearest
        points of the neighbouring skins): a full query (cell lists rebuilt) or the cheap
        walk that follows the last one (:func:`contact_update`)."""
        m, x, g = self.model, self.state.x, self.grid
        if full:
            g.fit_triangles(x, m.tris)
            g.rebuild_triangles(x, m.tris, m.tri_elem)
            if len(m.corners):
                self._gather_corner_triangles()
            g.rebuild_segments(x, self.chunk_a, self.chunk_b, self.chunk_elem)
            contact_query(x, self.active_skin, m.vert_elem,
                          g.segs.xy, g.segs.elem, g.segs.start, g.segs.order, *g.segs.params,
                          g.tris.xy, g.tris.elem, g.tris.start, *g.tris.params,
                          self.chunk_first, self.chunk_count, self.seg_a, self.seg_b,
                          self.seg_next, self.seg_prev,
                          self.inside, self.nb_count, self.nb_elem, self.nb_d2, self.nb_q, self.nb_seg)
        else:
            contact_update(x, self.active_skin, m.vert_elem, self.seg_a, self.seg_b,
                           self.seg_next, self.seg_prev, m.tris, m.vtri_ptr, m.vtri, self.tri_ptr,
                           self.near2, self.far2, self.inside, self.nb_count, self.nb_elem, self.nb_d2,
                           self.nb_q, self.nb_seg)

    # -- one iteration -------------------------------------------------------------
    def step(self) -> float:
        """Advance one iteration; return the area fraction of the meshes."""
        m, st, p = self.model, self.state, self.params
        x, F = st.x, self.F
        self.update_contacts(st.iteration % p.requery_every == 0)
        F[:] = 0.0
        # F = F_r + F_e + F_b + F_o  (Eq. 1)
        repulsion_force(x, self.active_skin, self.inside, self.nb_count, self.nb_q,
                        p.k_repulsion, p.soft, F)
        if m.stiff_edges:  # designer controls: stiffness per element
            edge_force_stiff(x, m.springs, m.rest0, self.sp_ptr, self.growth, self.moving, p.k_edge,
                             m.stiffness, F)
        else:
            edge_force(x, m.springs, m.rest0, self.sp_ptr, self.growth, self.moving, p.k_edge, F)
        if p.k_shape > 0:
            shape_force(x, m.x_rest, m.elem_vstart, self.moving, m.stiffness, p.k_shape, F)
        boundary_force(x, self.active_all, m.field.values, m.field.ox, m.field.oy,
                       1.0 / m.field.h, p.k_boundary, F, self.outside,
                       p.outside_block * m.gap, p.boundary_inset * m.gap + m.inset_extra)
        overlap_force(x, self.active_skin, self.inside, m.tris, m.vtri_ptr, m.vtri, self.nb_count, self.nb_d2,
                      self.nb_q, p.k_overlap, F)
        if p.min_triangle_area > 0:
            inversion_force(x, m.tris, self.tri_ptr, m.tri_rest, self.growth, self.moving,
                            p.min_triangle_area, p.k_overlap, F)
        if len(m.corners):
            corner_force(x, m.corners, self.corner_active, self.n_corner_active, self.corner_ptr,
                         self.corner_tris, m.tris, m.tri_elem, self.moving, p.k_corner, F)
        euler_step(x, st.v, F, self.active_all, self.dt, self._vmax_dt, m.vert_elem)
        if p.hard_boundary and not self.allow_growth:  # while settling
            project_inside(x, self.active_all, m.field.values, m.field.ox, m.field.oy,
                           1.0 / m.field.h, 0.0)
        if p.skin_width > 0 and m.anchor_tri is not None:
            keep_skin_width(x, m.tris, m.anchor_tri, m.anchor_bary, m.anchor_w, m.ring_sign,
                            self.active_skin, m.vert_elem, m.elem_vstart, m.elem_nskin, self.growth,
                            p.skin_width, SKIN_RELAX)
        if m.bend_limit.any():
            limit_deformation(x, m.x_rest, m.elem_vstart, self.moving, m.bend_limit, self.inside)
        if m.rot_on is not None:  # designer controls: rotation limits, rigid bodies
            apply_controls(x, st.v, m.x_rest, m.elem_vstart, self.moving, m.rot_on, m.rot_lo,
                           m.rot_hi, m.rigid)
        blocking = self.inside
        if p.one_sided_growth > 0.0 and self.allow_growth:  # contacts from one side do not stop growth
            confined_contacts(x, self.inside, m.elem_vstart, m.elem_nskin, self.moving, p.one_sided_growth,
                              self.blocking)
            blocking = self.blocking
        grow(blocking, self.outside, m.elem_vstart, m.elem_nskin, self.moving, st.n_grow,
             self.growth, p.k_growth * p.dt, self.allow_growth, self.max_growth)
        if p.relax_passes > 0:
            relax_self_intersections(x, m.elem_vstart, m.elem_nskin, self.relaxed, self.edge_rest,
                                     self.growth, m.vnbr_ptr, m.vnbr, p.relax_passes, p.relax_fraction,
                                     self.relax_order)
        total, moving = skin_areas(x, m.elem_vstart, m.elem_nskin, self.moving, self.areas)
        st.iteration += 1
        self.moving_area = moving / m.container_area
        return total / m.container_area

    def _gather_corner_triangles(self, by_cells: bool | None = None) -> None:
        """The reflex corners near a moving mesh and their candidate triangles, from the
        freshly built triangle grid (the buffer grows when the windows hold more than it
        has room for). Only corners within a cell of a live triangle cost anything: a
        jagged container's thousands of corners away from the moving meshes are never
        looked at (a step cost ~O(corners × triangles per window) before). The corners
        are binned into the triangle cells once per cell size."""
        m, t = self.model, self.grid.tris
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
                                        m.frozen, t.order, t.start, t.gx, t.gy, self.corner_active,
                                        self.corner_ptr, self.corner_tris)
            if need <= len(self.corner_tris):
                break
            self.corner_tris = np.zeros(2 * need, np.int64)
        self.n_corner_active = n

    def _relaxed(self) -> np.ndarray:
        """The elements whose skins the self-intersection relaxation may move: not rigid
        bodies, which keep exactly the similarity of their rest shape the controls give
        them (a rest skin does not self-intersect; relaxed, a rigid letter's narrow
        notches were pushed apart after every projection and its copies bent by ~1 %)."""
        rigid = self.model.rigid
        return self.moving if rigid is None else self.moving & ~rigid

    def set_moving(self, elem: int, moving: bool) -> None:
        """Pin (``moving=False``) or release element ``elem`` between iterations: a pinned
        element neither moves nor grows but still repels (the live view's pin)."""
        m = self.model
        self.moving[elem] = bool(moving) and not m.frozen[elem]
        self.relaxed = self._relaxed()
        vmask = self.moving[m.vert_elem]
        self.active_all = np.flatnonzero(vmask).astype(np.int64)
        self.active_skin = np.flatnonzero(vmask & m.is_skin).astype(np.int64)

    def begin_settle(self) -> None:
        """Stop growing; the last iterations only resolve overlaps and even out gaps."""
        self.allow_growth = False

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
        return int(count_inside(self.inside, self.active_skin))

    def refresh_growth(self) -> None:
        """Recompute growth factors from the counters (after loading a state)."""
        # same expression as grow() so a restored run is bit-identical
        self.growth[:] = 1.0 + self.state.n_grow * (self.params.k_growth * self.params.dt)

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
        small secondary elements is judged by its own growth, not by the frozen primaries'. ``should_stop()`` returning True (or
        KeyboardInterrupt) ends the run early with ``stopped_by="interrupted"``.

        ``on_checkpoint(self)`` is called every ``checkpoint_every`` iterations (rounded
        up to a multiple of ``requery_every``, where the state is complete: the next step
        starts with a full neighbour query), so a run resumed from it with
        :meth:`restore` continues exactly as the uninterrupted one.
        """
        p, st = self.params, self.state
        self.refresh_growth()
        start, most = self.thread_range()
        threads = set_threads(start)
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
        probe = int(self.active_all[0]) if len(self.active_all) else -1  # NaN check of one vertex
        if checkpoint_every > 0:
            checkpoint_every = -(-checkpoint_every // p.requery_every) * p.requery_every
        self._good = st.copy()
        try:
            while True:
                gov.begin()
                a = self.step()
                switch = gov.end()
                if switch is not None:
                    set_threads(switch)
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
                    self._good = st.copy()
                if on_snapshot is not None and st.iteration % every == 0:
                    on_snapshot(Snapshot(self.phase, st.iteration, a, rms, self.model.n_elements,
                                         self.n_inside, st, model=self.model, sim=self))
                if self.settle_left is None:
                    converged = (st.iteration >= p.min_iterations and len(hist) > w
                                 and min(rms, 2.0 * trend) < p.stop_epsilon)
                    if converged or st.iteration >= p.max_iterations:
                        self.stopped_by = "converged" if converged else "max_iterations"
                        self.settle_left = p.settle_iterations
                        self.begin_settle()
                if self.settle_left is not None:
                    if self.settle_left <= 0:
                        break
                    self.settle_left -= 1
                if on_checkpoint is not None and checkpoint_every and st.iteration % checkpoint_every == 0:
                    on_checkpoint(self)
                if should_stop is not None and should_stop():
                    self.stopped_by = "interrupted"
                    break
        except KeyboardInterrupt:
            self.stopped_by = "interrupted"
        finally:
            set_threads(threads)
        if on_snapshot is not None:
            on_snapshot(Snapshot(self.phase, st.iteration, a, rms, self.model.n_elements,
                                 self.n_inside, st, done=True, model=self.model, sim=self))
        return RunResult(st.iteration, a, self.stopped_by, self.dt)

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
                                 self.stopped_by, self.dt)

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
        """Everything that evolves during :meth:`run`, as plain arrays and numbers."""
        st = self.state
        # the vertices inside a mesh keep the skin segment they entered by (contact_query)
        ins = np.flatnonzero(self.inside)
        return {"x": st.x.copy(), "v": st.v.copy(), "n_grow": st.n_grow.copy(),
                "area_history": np.asarray(st.area_history, dtype=float),
                "inside_idx": ins, "inside_nb_count": self.nb_count[ins],
                "inside_nb_elem": self.nb_elem[ins], "inside_nb_seg": self.nb_seg[ins],
                "iteration": st.iteration, "dt": self.dt, "settle_left": self.settle_left,
                "stopped_by": self.stopped_by, "phase": self.phase}

    def restore(self, saved: dict) -> None:
        """Continue from :meth:`snapshot_state` output (same model)."""
        st = self.state
        if saved["x"].shape != st.x.shape or saved["n_grow"].shape != st.n_grow.shape:
            raise ValueError("the saved state does not match this model")
        st.x[:] = saved["x"]
        st.v[:] = saved["v"]
        st.n_grow[:] = saved["n_grow"]
        st.area_history[:] = [float(a) for a in saved["area_history"]]
        st.iteration = int(saved["iteration"])
        self.dt = float(saved["dt"])
        self.settle_left = None if saved["settle_left"] is None else int(saved["settle_left"])
        self.stopped_by = str(saved["stopped_by"])
        self.inside[:] = False
        if "inside_idx" in saved:  # (older checkpoints lack it: their resumed run differs a little)
            ins = np.asarray(saved["inside_idx"], np.int64)
            self.inside[ins] = True
            self.nb_count[ins] = saved["inside_nb_count"]
            self.nb_elem[ins] = saved["inside_nb_elem"]
            self.nb_seg[ins] = saved["inside_nb_seg"]
        self.refresh_growth()
        self.allow_growth = self.settle_left is None

    # -- divergence --------------------------------------------------------------------
    def _check_exploded(self) -> None:
        x = self.state.x[self.active_all]
        if not np.isfinite(x).all():
            self._recover()
            return
        f = self.model.field
        ny, nx = f.values.shape
        lo = np.array([f.ox, f.oy]) - 1000.0
        hi = np.array([f.ox + nx * f.h, f.oy + ny * f.h]) + 1000.0
        if (x < lo).any() or (x > hi).any():
            self._recover()

    def _recover(self) -> None:
        """Restore the last good state and halve the time step; give up after 4 tries."""
        self._recoveries += 1
        if self._good is None or self._recoveries > 4:
            raise DivergedError(
                f"the simulation diverged at iteration {self.state.iteration} (NaN or exploding "
                f"positions) even with Δt reduced to {self.dt:g}; try a smaller sim.dt or "
                "weaker force constants")
        good = self._good.copy()
        self.state.x[:] = good.x
        self.state.v[:] = 0.0
        self.state.n_grow[:] = good.n_grow
        self.state.iteration = good.iteration
        del self.state.area_history[len(good.area_history):]
        self.dt *= 0.5
        self.refresh_growth()
