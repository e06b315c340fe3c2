"""The force terms of Eq. 1 (sec. 5) and the ones added beyond the paper, one wrapper each.

Every term is called as ``term(model, state, forces)`` and *adds* its force into
``forces`` (N, 2) for the vertices of moving elements, so a step is the sum of a list of
terms (:func:`terms_of`) and each can be left out or tested alone. A term holds only its
constants (from :class:`~repulsionpak.params.SimParams`); the arrays come from the
:class:`~repulsionpak.sim.model.Model` and the :class:`~repulsionpak.sim.model.State`.

Notes
-----
The numba kernels doing the work are in :mod:`repulsionpak.sim.forces` (and
:mod:`repulsionpak.sim.controls` for per-element stiffness); they take flat arrays, which
numba compiles best. The wrappers pass exactly the arguments the loop passed before, so
the floating-point sums, and the packings, are the same.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..params import SimParams
from .alignment import align_torque, skin_axes
from .controls import edge_force_stiff
from .forces import (adhesion_force, boundary_force, corner_force, edge_force, inversion_force,
                     overlap_force, repulsion_force, shape_force)
from .model import Model, State

__all__ = ["Repulsion", "Edges", "ShapeMatching", "Boundary", "Overlap", "Inversion", "Corners",
           "Alignment", "Adhesion", "terms_of"]


@dataclass(frozen=True)
class Repulsion:
    """F_r, Eq. 2: each skin vertex outside every other mesh is pushed away from the
    closest points of the neighbouring skins (:func:`~repulsionpak.sim.forces.repulsion_force`)."""

    k: float
    soft: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        repulsion_force(state.x, state.active_skin, state.inside, state.nb_count, state.nb_q,
                        self.k, self.soft, forces)


@dataclass(frozen=True)
class Edges:
    """F_e, Eq. 3: the springs toward their grown rest lengths
    (:func:`~repulsionpak.sim.forces.edge_force`; with designer controls, scaled by each
    element's stiffness, :func:`~repulsionpak.sim.controls.edge_force_stiff`)."""

    k: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        if model.stiff_edges:
            edge_force_stiff(state.x, model.springs, model.rest0, model.spring_ptr, state.growth,
                             state.moving, self.k, model.stiffness, forces)
        else:
            edge_force(state.x, model.springs, model.rest0, model.spring_ptr, state.growth,
                       state.moving, self.k, forces)


@dataclass(frozen=True)
class ShapeMatching:
    """Beyond the paper: toward the best similarity of each rest shape
    (:func:`~repulsionpak.sim.forces.shape_force`)."""

    k: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        shape_force(state.x, model.x_rest, model.elem_vstart, state.moving, model.stiffness,
                    self.k, forces)


@dataclass(frozen=True)
class Boundary:
    """F_b, Eq. 5: vertices outside the container (moved ``inset`` × gap inside it) back
    toward it; marks in ``state.outside`` those more than ``block`` × gap out
    (:func:`~repulsionpak.sim.forces.boundary_force`)."""

    k: float
    block: float
    inset: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        f = model.field
        boundary_force(state.x, model.elem_vstart, state.moving, f.values, f.ox, f.oy, 1.0 / f.h, self.k,
                       forces, state.outside, self.block * model.gap, self.inset * model.gap + model.inset_extra)


@dataclass(frozen=True)
class Overlap:
    """F_o, Eq. 4: a vertex inside another mesh toward its triangles' centroids and the
    nearest point of that mesh's skin (:func:`~repulsionpak.sim.forces.overlap_force`)."""

    k: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        overlap_force(state.x, state.active_skin, state.inside, model.tris, model.vtri_ptr, model.vtri,
                      state.nb_count, state.nb_d2, state.nb_q, self.k, forces)


@dataclass(frozen=True)
class Inversion:
    """Beyond the paper: triangles folding below ``min_area`` of their grown rest area
    unfold (:func:`~repulsionpak.sim.forces.inversion_force`)."""

    min_area: float
    k: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        inversion_force(state.x, model.tris, model.tri_ptr, model.tri_rest, state.growth, state.moving,
                        self.min_area, self.k, forces)


@dataclass(frozen=True)
class Corners:
    """Beyond the paper: the container's reflex corners push off the triangles they
    entered (:func:`~repulsionpak.sim.forces.corner_force`; the candidates are gathered
    at each full contact query)."""

    k: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        if len(model.corners):
            corner_force(state.x, model.corners, state.corner_active, state.n_corner_active,
                         state.corner_ptr, state.corner_tris, model.tris, model.tri_elem, state.moving,
                         self.k, forces)


@dataclass(frozen=True)
class Alignment:
    """Beyond the paper: while the elements grow, elongated ones turn parallel to their
    elongated neighbours and to the container's edge within ``reach`` × gap
    (:func:`~repulsionpak.sim.alignment.align_torque`; each element's weight is
    ``model.align_weight``, none for an element whose rotation the designer limits)."""

    k: float
    reach: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        w = model.align_weight
        if w is None or not state.allow_growth:
            return
        if model.rot_on is not None:  # rotation windows (controls, flow) rule those elements
            w = np.where(model.rot_on, 0.0, w)
        if not w.any():
            return
        M = model.n_elements
        theta, aniso, cx, cy, cos2, sin2 = (np.empty(M) for _ in range(6))
        skin_axes(state.x, model.elem_vstart, model.elem_nskin, theta, aniso, cx, cy, cos2, sin2)
        f = model.field
        align_torque(state.x, model.elem_vstart, model.elem_nskin, state.moving, w, theta, aniso, cx, cy,
                     cos2, sin2, state.nb_count, state.nb_elem, f.values, f.ox, f.oy, 1.0 / f.h, self.reach * model.gap,
                     self.k, forces)


@dataclass(frozen=True)
class Adhesion:
    """Beyond the paper: while the packing settles, skin vertices are drawn toward the
    nearest neighbouring skin within ``reach`` × gap
    (:func:`~repulsionpak.sim.forces.adhesion_force`), so that channels wider than the
    gap close a little; nothing while the elements grow.

    Notes
    -----
    Growth stops an element at its first contact (sec. 6), so the jam ends with channels a
    gap or two wide along the parts of each element that met no neighbour. Drawn together
    while growing (k 30), the elements met earlier and the packing came out looser (the
    heart with 30 animals, no pockets, seeds 1-6: art area 0.584 -> 0.563); drawn together
    once growth has stopped, they bend into those channels within their shape limits.
    """

    k: float
    reach: float

    def __call__(self, model: Model, state: State, forces: np.ndarray) -> None:
        if state.allow_growth:
            return
        adhesion_force(state.x, state.active_skin, state.inside, state.nb_count, state.nb_d2, state.nb_q,
                       self.k, self.reach * model.gap, forces)


def terms_of(p: SimParams) -> tuple:
    """The force terms a run with parameters ``p`` sums, in the order they are added:
    F = F_r + F_e + F_b + F_o (Eq. 1), the shape-matching force after the springs when
    ``k_shape`` > 0, the unfolding force when ``min_triangle_area`` > 0, the corners'
    (for a container with reflex corners), the elongated elements' alignment when
    ``k_align`` > 0 and the settling packing's adhesion when ``k_adhesion`` > 0."""
    terms = [Repulsion(p.repulsion(), p.soft), Edges(p.k_edge)]
    if p.k_shape > 0:
        terms.append(ShapeMatching(p.k_shape))
    terms += [Boundary(p.k_boundary, p.outside_block, p.boundary_inset), Overlap(p.k_overlap)]
    if p.min_triangle_area > 0:
        terms.append(Inversion(p.min_triangle_area, p.k_overlap))
    terms.append(Corners(p.k_corner))
    if p.k_align > 0:
        terms.append(Alignment(p.k_align, p.align_reach))
    if p.k_adhesion > 0:
        terms.append(Adhesion(p.k_adhesion, p.adhesion_reach))
    return tuple(terms)
