"""Static simulation model and time-varying state, as flat arrays (structure of arrays).

Everything here is in *simulation units*: container units divided by ``SimFrame.unit``,
chosen so that the container's larger bounding-box side is 1000 — the scale the paper's
force constants are tuned for (sec. 5).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple
from dataclasses import dataclass, field, fields

import numpy as np
import shapely

from ..geometry.edges import Edges
from ..geometry.edt import distance_transform
from ..geometry.mesh import triangle_areas
from ..placement import Placement, placed_vertices
from ..preprocess import Template
from .alignment import align_weights
from .forces import ring_table, segment_triangles
from .skinwidth import skin_depths


@dataclass(frozen=True)
class SimFrame:
    """Map between container units and simulation units: ``sim = container / unit``."""

    unit: float

    @staticmethod
    def for_region(region) -> "SimFrame":
        minx, miny, maxx, maxy = region.bounds
        return SimFrame(max(maxx - minx, maxy - miny) / 1000.0)

    def to_sim(self, geom):
        """``geom`` (container units) in simulation units."""
        return shapely.affinity.scale(geom, 1 / self.unit, 1 / self.unit, origin=(0, 0))


@dataclass(frozen=True, eq=False)
class Field:
    """Signed distance to the container boundary on a regular grid (positive outside).

    ``values[j, i]`` is the distance at (ox + i·h, oy + j·h).
    """

    values: np.ndarray
    ox: float
    oy: float
    h: float


def container_field(region, h: float, margin: float, max_cells: int = 2_000_000) -> Field:
    """Sample the signed distance of ``region`` (sim units) on a grid of spacing ~h."""
    minx, miny, maxx, maxy = region.bounds
    minx, miny, maxx, maxy = minx - margin, miny - margin, maxx + margin, maxy + margin
    nx = int(np.ceil((maxx - minx) / h)) + 1
    ny = int(np.ceil((maxy - miny) / h)) + 1
    if nx * ny > max_cells:
        f = np.sqrt(nx * ny / max_cells)
        h *= f
        nx = int(np.ceil((maxx - minx) / h)) + 1
        ny = int(np.ceil((maxy - miny) / h)) + 1
    xs = minx + h * np.arange(nx)
    ys = miny + h * np.arange(ny)
    gx, gy = np.meshgrid(xs, ys)
    px, py = gx.ravel(), gy.ravel()
    inside = shapely.contains_xy(region, px, py).reshape(ny, nx)
    # distances by the Euclidean distance transform of the inside/outside raster, exact
    # (shapely) within ~4 cells of the boundary, where the boundary force acts
    d_in = distance_transform(inside, h)
    d_out = distance_transform(~inside, h)
    d = np.where(inside, d_in, d_out).ravel()
    near = np.flatnonzero(d < 6.0 * h)  # EDT overestimates by up to ~1.5 h
    d[near] = Edges(region).distance_xy(px[near], py[near], 8.0 * h)
    sd = np.where(inside.ravel(), -d, d).reshape(ny, nx)
    return Field(np.ascontiguousarray(sd), float(minx), float(miny), float(h))


@dataclass(eq=False)
class Model:
    """Static arrays of all meshes concatenated (shapes in brackets; N vertices, S springs,
    T triangles, M elements)."""

    vert_elem: np.ndarray  # (N,) int32 owning element
    elem_vstart: np.ndarray  # (M+1,) int32 first vertex of each element
    elem_nskin: np.ndarray  # (M,) int32 number of skin vertices (first in each block)
    is_skin: np.ndarray  # (N,) bool
    springs: np.ndarray  # (S, 2) int32 global vertex indices
    rest0: np.ndarray  # (S,) float64 rest lengths at placement (before growth)
    spring_elem: np.ndarray  # (S,) int32
    spring_is_edge: np.ndarray  # (S,) bool: mesh edge (True) or auxiliary spring
    tris: np.ndarray  # (T, 3) int32 global vertex indices
    tri_elem: np.ndarray  # (T,) int32
    tri_rest: np.ndarray  # (T,) signed rest area at placement (before growth), > 0
    vtri_ptr: np.ndarray  # (N+1,) CSR: triangles incident to each vertex
    vtri: np.ndarray  # (K,)
    vnbr_ptr: np.ndarray  # (N+1,) CSR: vertices joined to each vertex by a spring
    vnbr: np.ndarray  # (K2,)
    frozen: np.ndarray  # (M,) bool: vertices of frozen elements never move
    template_index: np.ndarray  # (M,) int32 into the template list
    max_growth: np.ndarray  # (M,) growth factor at which an element reaches its nominal size
    x_rest: np.ndarray  # (N, 2) positions at placement: each mesh's rest shape (shape matching)
    stiffness: np.ndarray  # (M,) multiplier of the shape-keeping forces per element
    bend_limit: np.ndarray  # (M,) largest deformation allowed (sim/shape.py), 0 = none
    kind: list[str]  # (M,) "primary" | "secondary"
    field: Field  # container signed distance
    container_area: float
    gap: float  # the requested gap, simulation units
    corners: np.ndarray  # (C, 2) reflex corners of the container (pointing inwards)
    cell_size: float  # segment grid cell width (repulsion range)
    tri_cell_size: float  # triangle grid cell width (>= the longest mesh edge)
    grid_origin: tuple[float, float]
    grid_extent: tuple[float, float]
    inset_extra: float = 0.0  # sim units added to the boundary inset (the edge margin's share)
    # skins kept wide (sim/skinwidth.py): per vertex, the triangle (-1: not a skin vertex)
    # and barycentric coordinates of the nearest art point and the rest width outside it
    # (at placement, before growth); per element, the skin ring's orientation
    anchor_tri: np.ndarray | None = None  # (N,) int32
    anchor_bary: np.ndarray | None = None  # (N, 3)
    anchor_w: np.ndarray | None = None  # (N,)
    ring_sign: np.ndarray | None = None  # (M,) +1 counter-clockwise
    # designer controls (repulsionpak.controls.setup_model); None/False: none (the default)
    rot_on: np.ndarray | None = None  # (M,) bool: rotation limited to [rot_lo, rot_hi]
    rot_lo: np.ndarray | None = None  # (M,) radians relative to the rest shape
    rot_hi: np.ndarray | None = None  # (M,)
    rigid: np.ndarray | None = None  # (M,) bool: shape matched every step
    pinned: np.ndarray | None = None  # (M,) bool: pinned copies (also frozen)
    stiff_edges: bool = False  # spring constants scaled by ``stiffness``
    controls: list | None = None  # (M,) ElementControls of each element
    flow: object | None = None  # repulsionpak.flow.steer.FlowSteer: rotation windows follow a flow field
    # derived by build_model: the skin rings (SkinTopology) and each element's springs and
    # triangles, ``spring_ptr[e]:spring_ptr[e+1]`` and ``tri_ptr[e]:tri_ptr[e+1]`` (element_ranges)
    skin: "SkinTopology | None" = None
    contact: "ContactTopology | None" = None  # what the contact kernels walk (sim/contacts.py)
    align_weight: np.ndarray | None = None  # (M,) how strongly each element turns (sim/alignment.py)
    spring_ptr: np.ndarray | None = None  # (M+1,) int64
    tri_ptr: np.ndarray | None = None  # (M+1,) int64
    # skins narrowed when growth stops (sim/skinwidth.narrow_grown_skins; None: none yet):
    # per skin vertex its band width over the width built, per inner vertex in a band the
    # skin vertex of that band (-1: none) and its share of its width; the rest arrays as built
    band_scale: np.ndarray | None = None  # (N,)
    band_near: np.ndarray | None = None  # (N,) int64
    band_share: np.ndarray | None = None  # (N,)
    skins_built: tuple | None = None  # (x_rest, tri_rest, anchor_w, anchor_bary) before narrowing

    def ensure_bands(self) -> None:
        """Give the narrowed-skin arrays (``band_scale``, ``band_near``, ``band_share``)
        their as-built values for every vertex (scale 1, no band), where there are none yet."""
        if self.band_scale is None:
            n = self.n_vertices
            self.band_scale = np.ones(n)
            self.band_near = np.full(n, -1, np.int64)
            self.band_share = np.zeros(n)

    @property
    def n_vertices(self) -> int:
        return len(self.vert_elem)

    @property
    def n_elements(self) -> int:
        return len(self.elem_nskin)

    def skin_rings(self, x: np.ndarray) -> list[np.ndarray]:
        """Each element's skin ring at positions ``x`` (N, 2), in order: views into ``x``."""
        return [x[s:s + n] for s, n in zip(self.elem_vstart[:-1], self.elem_nskin)]


#: the most neighbouring meshes a skin vertex keeps contact with (the nearest win; the
#: farther ones, whose repulsion is the weakest, are dropped). A skin vertex sees the
#: meshes with skin in the 3×3 cells around it (cells 0.65 × the element size,
#: ``sim.cell_size``): 6–8 on a jammed poster, at most 12, the median of them 10 gaps
#: away. Every contact kernel reads these rows, (N, K) and (N, K, 2), on every step, so
#: their width is memory traffic: at 24 the primary phase of 150 poster elements took
#: ~16 % longer on one thread (``docs/algorithm.md``, the table of changes)
MAX_NEIGHBOURS = 12


@dataclass(eq=False)
class State:
    """Every array that changes while a simulation runs (N vertices, M elements, K =
    :data:`MAX_NEIGHBOURS`); the :class:`Model` holds what does not.

    A checkpoint is this state (:meth:`saved`, :meth:`load`). ``x``, ``v`` and ``n_grow``
    come from :func:`build_model`; the run arrays are (re)allocated by :meth:`begin`, which
    the :class:`~repulsionpak.sim.runner.Simulator` calls when it takes the state.

    Notes
    -----
    *Kinematics and growth*: ``x`` (N, 2) positions, ``v`` (N, 2) velocities, ``n_grow``
    (M,) int64 growth counters n_M (sec. 6) and ``growth`` (M,) the rest-length factor
    they give, 1 + n_M·k_growth·Δt. *Pins*: ``moving`` (M,) the elements that move and
    grow (not frozen, not pinned by the live view), ``active_all``/``active_skin`` their
    vertices and skin vertices. *Contacts* (:mod:`repulsionpak.sim.contacts`), per skin
    vertex: ``inside`` (N,) it lies in another mesh; ``nb_count`` (N,), ``nb_elem``,
    ``nb_d2``, ``nb_seg`` (N, K) and ``nb_q`` (N, K, 2): its neighbouring meshes, the
    squared distance, skin segment and closest point on each; the container's reflex
    corners near a moving mesh (``corner_active[:n_corner_active]``) and their candidate
    triangles (``corner_tris[corner_ptr[j]:corner_ptr[j+1]]``). *Per step*: ``outside``
    (N,) a vertex too far outside the container, ``blocking`` (N,) the contacts that stop
    growth, ``areas`` (M,) skin areas. *Counters*: ``iteration``, ``area_history`` (the
    moving meshes' area fraction per iteration, for the stopping rule), ``dt`` (halved by
    a divergence recovery), ``settle_left`` (iterations left in the settle phase, None
    before it), ``stopped_by``, ``allow_growth``.
    """

    x: np.ndarray
    v: np.ndarray
    n_grow: np.ndarray
    iteration: int = 0
    area_history: list[float] = field(default_factory=list)
    growth: np.ndarray | None = None
    moving: np.ndarray | None = None
    active_all: np.ndarray | None = None
    active_skin: np.ndarray | None = None
    inside: np.ndarray | None = None
    nb_count: np.ndarray | None = None
    nb_elem: np.ndarray | None = None
    nb_d2: np.ndarray | None = None
    nb_q: np.ndarray | None = None
    nb_seg: np.ndarray | None = None
    corner_active: np.ndarray | None = None
    n_corner_active: int = 0
    corner_ptr: np.ndarray | None = None
    corner_tris: np.ndarray | None = None
    outside: np.ndarray | None = None
    blocking: np.ndarray | None = None
    areas: np.ndarray | None = None
    dt: float = 0.0
    settle_left: int | None = None
    stopped_by: str = "max_iterations"
    allow_growth: bool = True

    def begin(self, model: "Model", dt: float) -> None:
        """Allocate the run arrays for ``model`` (contacts empty, nothing growing yet:
        :meth:`refresh_growth`) and reset the run's counters: every element not frozen
        moves, the time step is ``dt``, growth allowed, no settle phase."""
        N, M, K = model.n_vertices, model.n_elements, MAX_NEIGHBOURS
        self.growth = np.ones(M)
        self.set_moving(model, ~model.frozen)
        self.inside = np.zeros(N, np.bool_)
        self.nb_count = np.zeros(N, np.int64)
        self.nb_elem = np.zeros((N, K), np.int32)
        self.nb_d2 = np.zeros((N, K))
        self.nb_q = np.zeros((N, K, 2))
        self.nb_seg = np.zeros((N, K), np.int64)
        self.corner_active = np.zeros(len(model.corners), np.int64)
        self.n_corner_active = 0
        self.corner_ptr = np.zeros(len(model.corners) + 1, np.int64)
        self.corner_tris = np.zeros(1024, np.int64)  # grown on demand
        self.outside = np.zeros(N, np.bool_)
        self.blocking = np.zeros(N, np.bool_)
        self.areas = np.zeros(M)
        self.dt = float(dt)
        self.settle_left = None
        self.stopped_by = "max_iterations"
        self.allow_growth = True

    def set_moving(self, model: "Model", moving: np.ndarray) -> None:
        """The elements that move (``moving``, (M,) bool; a frozen one never does) and
        their vertices."""
        self.moving = np.asarray(moving, np.bool_) & ~model.frozen
        vmask = self.moving[model.vert_elem]
        self.active_all = np.flatnonzero(vmask).astype(np.int64)
        self.active_skin = np.flatnonzero(vmask & model.is_skin).astype(np.int64)

    def refresh_growth(self, k_growth_dt: float) -> None:
        """The growth factors from the counters (after loading a state): the expression
        of :func:`~repulsionpak.sim.integrate.grow`, so a restored run is bit-identical."""
        self.growth[:] = 1.0 + self.n_grow * k_growth_dt

    def copy(self) -> "State":
        """A deep copy (arrays copied, not shared)."""
        out = State(self.x.copy(), self.v.copy(), self.n_grow.copy(), self.iteration,
                    list(self.area_history))
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name not in ("x", "v", "n_grow", "iteration", "area_history"):
                setattr(out, f.name, value.copy() if isinstance(value, np.ndarray) else value)
        return out

    def assign(self, other: "State") -> None:
        """Become ``other`` (a :meth:`copy` of this state), in place: arrays of the same
        shape are copied into the ones held (the runner holds ``area_history`` and the
        contact arrays), everything else is set. The run then goes on exactly as from
        ``other``."""
        for f in fields(self):
            value, mine = getattr(other, f.name), getattr(self, f.name)
            if isinstance(value, np.ndarray) and isinstance(mine, np.ndarray) and mine.shape == value.shape:
                np.copyto(mine, value)
            elif f.name == "area_history":
                mine[:] = value
            else:
                setattr(self, f.name, value.copy() if isinstance(value, np.ndarray) else value)

    def saved(self) -> dict:
        """This state as a checkpoint (plain arrays and numbers, :mod:`repulsionpak.checkpoint`).

        Notes
        -----
        Checkpoints are taken where the next step starts with a full contact query, which
        recomputes the contacts of every vertex but one inside a mesh: that one keeps the
        skin segment it entered by. So only those vertices' contacts are saved, and the
        growth factors follow from the counters; the per-step arrays are recomputed.
        """
        ins = np.flatnonzero(self.inside)
        return {"x": self.x.copy(), "v": self.v.copy(), "n_grow": self.n_grow.copy(),
                "area_history": np.asarray(self.area_history, dtype=float),
                "inside_idx": ins, "inside_nb_count": self.nb_count[ins],
                "inside_nb_elem": self.nb_elem[ins], "inside_nb_seg": self.nb_seg[ins],
                "iteration": self.iteration, "dt": self.dt, "settle_left": self.settle_left,
                "stopped_by": self.stopped_by}

    def load(self, saved: dict, k_growth_dt: float) -> None:
        """Continue from :meth:`saved` output (a state of the same model)."""
        if saved["x"].shape != self.x.shape or saved["n_grow"].shape != self.n_grow.shape:
            raise ValueError("the saved state does not match this model")
        self.x[:] = saved["x"]
        self.v[:] = saved["v"]
        self.n_grow[:] = saved["n_grow"]
        self.area_history[:] = [float(a) for a in saved["area_history"]]
        self.iteration = int(saved["iteration"])
        self.dt = float(saved["dt"])
        self.settle_left = None if saved["settle_left"] is None else int(saved["settle_left"])
        self.stopped_by = str(saved["stopped_by"])
        self.inside[:] = False
        if "inside_idx" in saved:  # (older checkpoints lack it: their resumed run differs a little)
            ins = np.asarray(saved["inside_idx"], np.int64)
            self.inside[ins] = True
            # a checkpoint of a build that kept more neighbours per vertex: the first K
            elem, seg = np.asarray(saved["inside_nb_elem"]), np.asarray(saved["inside_nb_seg"])
            k = min(self.nb_elem.shape[1], elem.shape[1])
            self.nb_count[ins] = np.minimum(saved["inside_nb_count"], k)
            self.nb_elem[ins, :k] = elem[:, :k]
            self.nb_seg[ins, :k] = seg[:, :k]
        self.refresh_growth(k_growth_dt)
        self.allow_growth = self.settle_left is None


def reflex_corners(region, max_angle_deg: float = 160.0) -> np.ndarray:
    """Vertices of the container's rings where the region's interior angle exceeds 180°
    + (180 − max_angle_deg), i.e. sharp corners pointing into the container, and the unit
    bisector of each pointing into the container: (C, 4) rows x, y, nx, ny."""
    out = []
    polys = getattr(region, "geoms", [region])
    for poly in polys:
        rings = [(np.asarray(poly.exterior.coords)[:-1], True)]
        rings += [(np.asarray(r.coords)[:-1], False) for r in poly.interiors]
        for pts, is_outer in rings:
            if len(pts) < 3:
                continue
            x, y = pts[:, 0], pts[:, 1]
            area = 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
            sign = 1.0 if area > 0 else -1.0  # orientation of this ring
            prev, nxt = np.roll(pts, 1, axis=0), np.roll(pts, -1, axis=0)
            u, w = pts - prev, nxt - pts
            z = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]  # turn at the vertex
            # unit vectors along the two edges from the vertex
            ua, ub = prev - pts, nxt - pts
            ua /= np.maximum(np.hypot(*ua.T), 1e-300)[:, None]
            ub /= np.maximum(np.hypot(*ub.T), 1e-300)[:, None]
            ang = np.degrees(np.arccos(np.clip((ua * ub).sum(axis=1), -1, 1)))  # angle between the two edges
            # outer ring: a turn against its orientation is reflex; a hole: the opposite
            reflex = (z * sign < 0) if is_outer else (z * sign > 0)
            # the outside is the wedge between the two edges; the inside is opposite it
            n = -(ua + ub)
            n /= np.maximum(np.hypot(*n.T), 1e-300)[:, None]
            keep = reflex & (ang < max_angle_deg)
            out.extend(np.c_[pts[keep], n[keep]])
    return np.asarray(out, dtype=float).reshape(-1, 4)


def element_ranges(owner: np.ndarray, n_elements: int) -> np.ndarray:
    """CSR pointers (M+1,) of items (springs, triangles) stored grouped by element:
    element e owns ``owner``'s items ``ptr[e]:ptr[e+1]``."""
    if len(owner) and np.any(np.diff(owner) < 0):
        raise ValueError("items are not grouped by element")
    return np.searchsorted(owner, np.arange(n_elements + 1)).astype(np.int64)


#: skin segments per chunk in the full contact query (:class:`SkinTopology`)
CHUNK = 4


class SkinTopology(NamedTuple):
    """Skin segments and chunks of all meshes, as flat arrays: segment ``k`` runs from
    skin vertex ``seg_a[k]`` to ``seg_b[k]`` of element ``seg_elem[k]``, its ring
    neighbours are ``seg_next``/``seg_prev``; a chunk is the chord over ``chunk_count``
    consecutive segments from ``chunk_first`` (``chunk_a`` to ``chunk_b``), what the full
    contact query bins into cells."""

    seg_a: np.ndarray
    seg_b: np.ndarray
    seg_elem: np.ndarray
    seg_next: np.ndarray
    seg_prev: np.ndarray
    chunk_a: np.ndarray
    chunk_b: np.ndarray
    chunk_elem: np.ndarray
    chunk_first: np.ndarray
    chunk_count: np.ndarray


class ContactTopology(NamedTuple):
    """What the contact kernels walk along and test against, derived from the skin rings
    and triangles (:func:`contact_topology`).

    Attributes
    ----------
    ring
        (S, 4) int64: each skin segment's ends, next and previous segment
        (:func:`~repulsionpak.sim.forces.ring_table`), the walks of both queries.
    seg_tri_ptr, seg_tri
        The triangles at either end of each segment, as corner vertices
        (:func:`~repulsionpak.sim.forces.segment_triangles`), the point-in-mesh tests of
        :func:`~repulsionpak.sim.contacts.follow_contacts`.
    """

    ring: np.ndarray
    seg_tri_ptr: np.ndarray
    seg_tri: np.ndarray


def contact_topology(m: Model) -> ContactTopology:
    """The :class:`ContactTopology` of ``m`` (its ``skin`` set)."""
    s = m.skin
    ptr, corners = segment_triangles(s.seg_a, s.seg_b, m.vtri_ptr, m.vtri, m.tris)
    return ContactTopology(ring_table(s.seg_a, s.seg_b, s.seg_next, s.seg_prev), ptr, corners)


def skin_topology(m: Model) -> SkinTopology:
    """The skin segments and chunks of every element (also frozen ones: they repel).
    Segment k of a mesh runs from its skin vertex k to k+1; the segments of one mesh are
    consecutive."""
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
    return SkinTopology(seg[:, 0].copy(), seg[:, 1].copy(), seg[:, 2].astype(np.int32), seg[:, 3].copy(),
                        seg[:, 4].copy(), chunk[:, 0].copy(), chunk[:, 1].copy(), chunk[:, 2].astype(np.int32),
                        chunk[:, 3].copy(), chunk[:, 4].copy())


def _csr(n: int, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    order = np.argsort(rows, kind="stable")
    counts = np.bincount(rows, minlength=n)
    ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
    return ptr, cols[order].astype(np.int32)


def build_model(templates: Sequence[Template], placement: Placement, frame: SimFrame,
                region_sim, cell_size: float, gap: float, kinds: Sequence[str] | None = None,
                frozen: Sequence[bool] | None = None, base: tuple["Model", State] | None = None
                ) -> tuple[Model, State]:
    """Concatenate the placed meshes into a :class:`Model` and an initial :class:`State`.

    ``base`` (an existing model/state) is kept as the first elements — used by the
    secondary phase to append new elements to frozen primaries.
    """
    xs, vert_elem, skin, springs, rest0, s_elem, s_edge, tris, t_elem = [], [], [], [], [], [], [], [], []
    an_tri, an_bary, ring_sign = [], [], []
    ntri = 0  # triangles before the next element's
    nominal = list(base[0].max_growth) if base is not None else []
    starts, nskin = [0], []
    m0 = 0
    if base is not None:
        bm, bs = base
        xs.append(bs.x)
        vert_elem.append(bm.vert_elem)
        skin.append(bm.is_skin)
        springs.append(bm.springs)
        rest0.append(bm.rest0)  # frozen elements never move: their springs are inert
        s_elem.append(bm.spring_elem)
        s_edge.append(bm.spring_is_edge)
        tris.append(bm.tris)
        t_elem.append(bm.tri_elem)
        an_tri.append(bm.anchor_tri)
        an_bary.append(bm.anchor_bary)
        ring_sign.append(bm.ring_sign)
        ntri = len(bm.tris)
        starts = list(bm.elem_vstart)
        nskin = list(bm.elem_nskin)
        m0 = bm.n_elements
    n = starts[-1]
    for k, ti in enumerate(placement.template_index):
        t = templates[ti]
        e = m0 + k
        pts = placed_vertices(t, placement.position[k], placement.angle[k], placement.shrink_of(k)) / frame.unit
        xs.append(pts)
        vert_elem.append(np.full(len(pts), e, np.int32))
        sk = np.zeros(len(pts), bool)
        sk[:t.n_skin] = True
        skin.append(sk)
        springs.append(t.springs + n)
        lengths = np.linalg.norm(pts[t.springs[:, 0]] - pts[t.springs[:, 1]], axis=1)
        rest0.append(lengths)
        s_elem.append(np.full(len(t.springs), e, np.int32))
        edge = np.zeros(len(t.springs), bool)
        edge[:t.n_edges] = True
        s_edge.append(edge)
        tris.append(t.tris + n)
        t_elem.append(np.full(len(t.tris), e, np.int32))
        at = np.full(len(pts), -1, np.int32)
        at[:t.n_skin] = t.anchor_tri + ntri
        ntri += len(t.tris)
        ab = np.zeros((len(pts), 3))
        ab[:t.n_skin] = t.anchor_bary
        an_tri.append(at)
        an_bary.append(ab)
        ring_sign.append([t.ring_sign])
        n += len(pts)
        starts.append(n)
        nskin.append(t.n_skin)
        nominal.append(1.0 / placement.shrink_of(k))
    x = np.ascontiguousarray(np.concatenate(xs), dtype=np.float64)
    N = len(x)
    anchors = dict(anchor_tri=np.ascontiguousarray(np.concatenate(an_tri), dtype=np.int32),
                   anchor_bary=np.ascontiguousarray(np.concatenate(an_bary), dtype=np.float64),
                   ring_sign=np.ascontiguousarray(np.concatenate(ring_sign), dtype=np.float64))
    springs_a = np.ascontiguousarray(np.concatenate(springs), dtype=np.int32)
    tris_a = np.ascontiguousarray(np.concatenate(tris), dtype=np.int32)
    vtri_ptr, vtri = _csr(N, tris_a.ravel(), np.repeat(np.arange(len(tris_a)), 3))
    a, b = springs_a[:, 0], springs_a[:, 1]
    vnbr_ptr, vnbr = _csr(N, np.concatenate([a, b]), np.concatenate([b, a]))
    M = len(nskin)
    kinds_all = (list(base[0].kind) if base else []) + list(kinds or ["primary"] * len(placement.template_index))
    frozen_all = np.zeros(M, bool)
    if base is not None:
        frozen_all[:m0] = base[0].frozen
    if frozen is not None:
        frozen_all[:len(frozen)] |= np.asarray(frozen, bool)
    tindex = np.concatenate([base[0].template_index if base else np.zeros(0, np.int32),
                             np.asarray(placement.template_index, np.int32)]).astype(np.int32)
    minx, miny, maxx, maxy = region_sim.bounds
    margin = 0.25 * max(maxx - minx, maxy - miny)
    # the container does not change between phases: reuse the base model's field
    fld = base[0].field if base is not None else container_field(region_sim, gap / 3.0, margin)
    longest = max(float(np.max(np.linalg.norm(t.verts[t.springs[:t.n_edges, 0]] - t.verts[t.springs[:t.n_edges, 1]], axis=1)))
                  for t in templates) / frame.unit
    tri_cell = min(1.3 * longest, cell_size)
    tri_rest = triangle_areas(x, tris_a)
    if base is not None:  # frozen elements: their current areas (they never move)
        tri_rest[:len(base[0].tris)] = base[0].tri_rest
    model = Model(
        vert_elem=np.ascontiguousarray(np.concatenate(vert_elem), dtype=np.int32),
        elem_vstart=np.asarray(starts, np.int32),
        elem_nskin=np.asarray(nskin, np.int32),
        is_skin=np.concatenate(skin),
        springs=springs_a,
        rest0=np.ascontiguousarray(np.concatenate(rest0), dtype=np.float64),
        spring_elem=np.ascontiguousarray(np.concatenate(s_elem), dtype=np.int32),
        spring_is_edge=np.concatenate(s_edge),
        tris=tris_a,
        tri_elem=np.ascontiguousarray(np.concatenate(t_elem), dtype=np.int32),
        tri_rest=np.ascontiguousarray(tri_rest),
        vtri_ptr=vtri_ptr, vtri=vtri, vnbr_ptr=vnbr_ptr, vnbr=vnbr,
        x_rest=x.copy(), stiffness=np.ones(M), bend_limit=np.zeros(M),
        frozen=frozen_all, template_index=tindex, max_growth=np.asarray(nominal, dtype=float), kind=kinds_all, field=fld,
        container_area=float(region_sim.area), gap=float(gap),
        corners=base[0].corners if base is not None else reflex_corners(region_sim), cell_size=float(cell_size), tri_cell_size=float(tri_cell),
        grid_origin=(float(minx - cell_size), float(miny - cell_size)),
        grid_extent=(float(maxx - minx + 2 * cell_size), float(maxy - miny + 2 * cell_size)),
        **anchors,
    )
    # the new skins' rest widths, measured on the placed meshes (frozen ones keep theirs)
    n0 = base[0].n_vertices if base is not None else 0
    model.anchor_w = np.zeros(N)
    if base is not None:
        model.anchor_w[:n0] = base[0].anchor_w
    skin_depths(x, tris_a, model.anchor_tri, model.anchor_bary, model.ring_sign, model.vert_elem,
                model.elem_vstart, model.elem_nskin, np.flatnonzero(model.is_skin[n0:]) + n0, model.anchor_w)
    if base is not None:
        model.inset_extra = base[0].inset_extra
        model.bend_limit[:m0] = base[0].bend_limit
    model.skin = skin_topology(model)
    model.contact = contact_topology(model)
    model.align_weight = align_weights(x, model.elem_vstart, model.elem_nskin)
    if base is not None:  # (the placed elements' weights: their rest shapes, not their current ones)
        model.align_weight[:m0] = base[0].align_weight
    model.spring_ptr = element_ranges(model.spring_elem, M)
    model.tri_ptr = element_ranges(model.tri_elem, M)
    if base is not None and base[0].band_scale is not None:  # the placed copies' narrowed skins
        model.ensure_bands()
        for name in ("band_scale", "band_near", "band_share"):
            getattr(model, name)[:n0] = getattr(base[0], name)
    if base is not None and base[0].skins_built is not None:  # ... and their rest arrays as built
        bx, bt, bw, bb = base[0].skins_built
        t0 = len(base[0].tris)
        model.skins_built = (np.concatenate([bx, model.x_rest[n0:]]), np.concatenate([bt, model.tri_rest[t0:]]),
                             np.concatenate([bw, model.anchor_w[n0:]]), np.concatenate([bb, model.anchor_bary[n0:]]))
    n_grow = np.zeros(M, np.int64)
    if base is not None:
        n_grow[:m0] = base[1].n_grow
    return model, State(x, np.zeros_like(x), n_grow)
