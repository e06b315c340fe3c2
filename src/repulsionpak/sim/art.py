"""The simulation's copies as art: each copy's mesh vertices read from the state and handed
to :mod:`repulsionpak.render` (which works on one template and its vertices).

Notes
-----
Rendering is a layer below the stages: it knows templates and vertex arrays, not the
simulation's model and state, so the loops over a model's copies live here.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..params import RenderParams
from ..preprocess import Template
from ..render.deform import map_plan
from ..render.placed import placed_copy, rest_copy
from ..threads import thread_map
from ..types import PlacedArt
from .model import Model, SimFrame, State
from .skinwidth import as_built


def element_vertices(model: Model, state: State, e: int) -> np.ndarray:
    """Copy ``e``'s mesh vertices (sim units), a view into ``state.x``."""
    s, t = model.elem_vstart[e], model.elem_vstart[e + 1]
    return state.x[s:t]


def placed_art(templates: Sequence[Template], model: Model, state: State, frame: SimFrame,
               elements: Sequence[int] | None = None,
               params: RenderParams | None = None) -> list[PlacedArt]:
    """The deformed art of copies (all by default) in container units, in model order, as
    smooth curves (:func:`repulsionpak.render.placed_copy` of each).

    Parameters
    ----------
    templates : sequence of Template
        The model's templates.
    model, state : Model, State
        The simulation whose copies are drawn.
    frame : SimFrame
        Sim units -> container units.
    elements : sequence of int, optional
        The copies to draw (default: every one).
    params : RenderParams, optional
        Curve fitting and the deformation map.

    Returns
    -------
    list of PlacedArt
        One per copy drawn, in the order of ``elements``.

    Notes
    -----
    The copies are mapped on :func:`~repulsionpak.threads.thread_map`'s threads: the
    thin-plate maps (numpy's products) and the curve fits (a ``nogil`` kernel) run side by
    side; the art is the same on any number of threads.
    """
    params = params or RenderParams()
    gap = float(model.gap) * frame.unit
    drawn = range(model.n_elements) if elements is None else elements
    # each template's map plan first, in this thread: the copies then only read them
    for ti in sorted({int(model.template_index[e]) for e in drawn}):
        map_plan(templates[ti], params.smooth_map, params.samples, params.smoothing)

    def one(e: int) -> PlacedArt:  # (the art is bound to the mesh as built: a narrowed skin widened back)
        verts = as_built(model, element_vertices(model, state, e), e) * frame.unit
        return placed_copy(templates[model.template_index[e]], verts, model.kind[e], gap, params)
    return thread_map(one, drawn)


def rest_art(templates: Sequence[Template], model: Model, elements: Sequence[int] | None = None
             ) -> list[PlacedArt]:
    """Each copy's art undeformed, in its template's frame (:func:`repulsionpak.render.rest_copy`):
    the shape it should keep.

    Parameters
    ----------
    templates : sequence of Template
        The model's templates.
    model : Model
        Which template and kind each copy has.
    elements : sequence of int, optional
        The copies (default: every one).

    Returns
    -------
    list of PlacedArt
        One per copy, in the order of ``elements``; copies of one template and kind share
        one object (a PlacedArt is never changed in place).
    """
    made: dict[tuple[int, str], PlacedArt] = {}
    out = []
    for e in range(model.n_elements) if elements is None else elements:
        key = (int(model.template_index[e]), str(model.kind[e]))
        if key not in made:
            made[key] = rest_copy(templates[key[0]], model.kind[e])
        out.append(made[key])
    return out


def skin_polygons(model: Model, state: State, frame: SimFrame) -> list[np.ndarray]:
    """Each copy's skin polygon (container units), for debug layers and checks."""
    return [ring * frame.unit for ring in model.skin_rings(state.x)]


__all__ = ["element_vertices", "placed_art", "rest_art", "skin_polygons"]
