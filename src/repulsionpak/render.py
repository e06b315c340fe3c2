"""Map every element's art through its deformed mesh (barycentric coordinates, sec. 3)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .geometry.mesh import apply_binding
from .preprocess import Template
from .sim.model import Model, SimFrame, State
from .types import ArtPath, PlacedArt


def similarity_fit(rest: np.ndarray, cur: np.ndarray) -> tuple[float, float]:
    """Best similarity transform (rotation, uniform scale, translation) from ``rest`` to
    ``cur`` (both (n, 2)), least squares. Returns (scale, rms residual)."""
    a = rest - rest.mean(axis=0)
    b = cur - cur.mean(axis=0)
    za = a[:, 0] + 1j * a[:, 1]
    zb = b[:, 0] + 1j * b[:, 1]
    denom = float(np.vdot(za, za).real)
    if denom <= 0:
        return 1.0, 0.0
    c = np.vdot(za, zb) / denom  # complex scale·rotation
    resid = zb - c * za
    return float(abs(c)), float(np.sqrt(np.mean(np.abs(resid) ** 2)))


def deformation(rest: np.ndarray, cur: np.ndarray) -> float:
    """Dimensionless deformation of a mesh: RMS distance of its vertices from the best
    similarity transform of the rest shape, divided by the RMS radius of the deformed mesh
    (0 for a rigid motion plus uniform scaling)."""
    scale, rms = similarity_fit(rest, cur)
    b = cur - cur.mean(axis=0)
    size = float(np.sqrt(np.mean((b ** 2).sum(axis=1))))
    return rms / size if size > 0 else 0.0


def element_vertices(model: Model, state: State, e: int) -> np.ndarray:
    s, t = model.elem_vstart[e], model.elem_vstart[e + 1]
    return state.x[s:t]


def placed_art(templates: Sequence[Template], model: Model, state: State, frame: SimFrame,
               elements: Sequence[int] | None = None) -> list[PlacedArt]:
    """The deformed art of elements (all by default) in container units, in model order."""
    out = []
    for e in range(model.n_elements) if elements is None else elements:
        t = templates[model.template_index[e]]
        verts = element_vertices(model, state, e) * frame.unit
        pts = apply_binding(verts, t.tris, t.art_tri, t.art_bary)
        scale, _ = similarity_fit(t.verts, verts)
        paths, k = [], 0
        for art in t.element.paths:
            subs = []
            for sp in art.subpaths:
                subs.append(pts[k:k + len(sp)])
                k += len(sp)
            paths.append(ArtPath(tuple(subs), art.closed, art.style))
        out.append(PlacedArt(t.element.source, model.kind[e], tuple(paths),
                             stroke_scale=t.scale * scale, deformation=deformation(t.verts, verts)))
    return out


def skin_polygons(model: Model, state: State, frame: SimFrame) -> list[np.ndarray]:
    """Each element's skin polygon (container units), for debug layers and checks."""
    return [state.x[model.elem_vstart[e]:model.elem_vstart[e] + model.elem_nskin[e]] * frame.unit
            for e in range(model.n_elements)]


def rest_art(templates: Sequence[Template], model: Model, elements: Sequence[int] | None = None
             ) -> list[PlacedArt]:
    """Each element's art undeformed, in its template's frame (centred, at the template's
    scale), vertex for vertex like :func:`placed_art`: the shape it should keep."""
    out = []
    for e in range(model.n_elements) if elements is None else elements:
        t = templates[model.template_index[e]]
        c, k = t.outline.center, t.scale
        paths = tuple(a.transformed(lambda p: (np.asarray(p) - c) * k) for a in t.element.paths)
        out.append(PlacedArt(t.element.source, model.kind[e], paths, stroke_scale=t.scale, deformation=0.0))
    return out


def is_convex(template: Template, solidity: float = 0.9) -> bool:
    """True when the template's art covers at least ``solidity`` of its convex hull."""
    g = template.outline.geometry
    hull = g.convex_hull.area
    return hull > 0 and g.area >= solidity * hull
