"""The contact state of a step, over ``(model, state)``: which skin vertices lie inside
another mesh and the closest points of the neighbouring skins (sec. 5, "Simulation
details").

:func:`find_contacts` is the full query over the cell lists of a freshly built
:class:`~repulsionpak.sim.grid.Grid`; :func:`follow_contacts` the cheap walk that follows
its results between full queries. Both fill the contact arrays of the
:class:`~repulsionpak.sim.model.State` (``inside``, ``nb_*``) for its ``active_skin``
vertices.

Notes
-----
The numba kernels (:func:`~repulsionpak.sim.forces.contact_query`,
:func:`~repulsionpak.sim.forces.contact_update`) take flat arrays, which is what numba
compiles best; these wrappers only name where each comes from.
"""

from __future__ import annotations

from .forces import contact_query, contact_update
from .grid import Grid
from .model import Model, State

__all__ = ["find_contacts", "follow_contacts"]


def find_contacts(model: Model, state: State, grid: Grid) -> None:
    """Full contact query of every active skin vertex (:func:`~repulsionpak.sim.forces.contact_query`).

    Parameters
    ----------
    model, state
        The meshes; the contact arrays of ``state`` are overwritten for its
        ``active_skin`` vertices (a vertex inside a mesh keeps the side it entered by).
    grid
        Cell lists rebuilt on ``state.x``: skin chunks (``grid.segs``) and the triangle
        cover (``grid.cover``).
    """
    s, st, segs, tris = model.skin, state, grid.segs, grid.cover
    contact_query(st.x, st.active_skin, model.vert_elem,
                  segs.xy, segs.elem, segs.start, segs.order, *segs.params,
                  tris.xy, tris.elem, tris.start, *tris.params,
                  s.chunk_first, s.chunk_count, model.contact.ring,
                  st.inside, st.nb_count, st.nb_elem, st.nb_d2, st.nb_q, st.nb_seg)


def follow_contacts(model: Model, state: State, near2: float, far2: float) -> None:
    """Refresh the last full query's contacts by walking along the neighbouring skins
    (:func:`~repulsionpak.sim.forces.contact_update`).

    Parameters
    ----------
    model, state
        As for :func:`find_contacts`.
    near2
        Squared distance below which a neighbour's triangles are tested for containment.
    far2
        Squared distance beyond which a neighbour keeps its point of the last full query.
    """
    st, topo = state, model.contact
    contact_update(st.x, st.active_skin, topo.ring, topo.seg_tri_ptr, topo.seg_tri, model.elem_vstart,
                   model.elem_nskin, near2, far2, st.inside, st.nb_count, st.nb_elem, st.nb_d2, st.nb_q, st.nb_seg)
