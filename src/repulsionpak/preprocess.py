"""Element templates (sec. 4): outline → skin → resampled boundary → mesh → springs → binding.

A :class:`Template` is built once per library element at the scale the elements are
expected to have in the final packing (``scale``: file units → container units), so that
the skin offset is gap/2 in container units. Placement then shrinks copies of it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from .errors import InputError
from .geometry.mesh import bind_points, mesh_springs, triangulate_polygon
from .art_area import art_area
from .geometry.outline import art_area_problem, resample_adaptive, ring_coords, skin_polygon
from .params import PreprocessParams
from .types import Element


@dataclass(frozen=True, eq=False)
class Outline:
    """The area an element's art covers, in its file units, and its size measures."""

    element: Element
    geometry: shapely.Geometry  # union of fills and strokes
    center: np.ndarray  # (2,) centroid of the outline
    area: float
    perimeter: float

    def skin_area(self, scale: float, offset: float) -> float:
        """Approximate skin area when the art is scaled by ``scale`` and offset by ``offset``
        (Steiner formula for the parallel body)."""
        r = offset
        return scale * scale * self.area + scale * self.perimeter * r + np.pi * r * r


def outline_of(element: Element) -> Outline:
    geom = art_area(element.paths)
    problem = art_area_problem(geom)
    if problem is not None:
        raise InputError(element.source, problem)
    c = geom.centroid
    return Outline(element, geom, np.array([c.x, c.y]), float(geom.area), float(geom.length))


@dataclass(frozen=True, eq=False)
class Template:
    """A meshed element at its nominal final scale, centred on the origin (container units).

    Vertices ``verts[:n_skin]`` are the skin boundary in order; the rest are interior
    Steiner points. ``springs[:n_edges]`` are mesh edges, the rest auxiliary springs.
    Every art vertex ``i`` (flattened over the element's paths in order) is
    ``Σ_k art_bary[i, k] · verts[tris[art_tri[i], k]]``.
    """

    outline: Outline
    scale: float
    verts: np.ndarray
    n_skin: int
    tris: np.ndarray
    springs: np.ndarray
    n_edges: int
    art_tri: np.ndarray
    art_bary: np.ndarray
    skin_area: float
    #: per skin vertex, the nearest art point (:func:`skin_anchors`); the skin ring's
    #: orientation (+1 counter-clockwise)
    anchor_tri: np.ndarray
    anchor_bary: np.ndarray
    ring_sign: float

    @property
    def element(self) -> Element:
        return self.outline.element

    @property
    def radius(self) -> float:
        return float(np.sqrt((self.verts ** 2).sum(axis=1).max()))


def build_template(outline: Outline, scale: float, gap: float,
                   params: PreprocessParams = PreprocessParams()) -> Template:
    """Mesh ``outline`` scaled by ``scale`` (file → container units) with a skin of gap/2."""
    if not (scale > 0 and gap > 0):
        raise ValueError("scale and gap must be positive")
    geom = shapely.affinity.scale(
        shapely.affinity.translate(outline.geometry, -outline.center[0], -outline.center[1]),
        scale, scale, origin=(0, 0))
    skin = skin_polygon(geom, params.skin_offset * gap, detail=0.5 * params.skin_tolerance * gap)
    spacing = params.mesh_spacing * gap
    ring = resample_adaptive(ring_coords(skin), spacing, params.skin_tolerance * gap,
                             params.min_boundary_vertices)
    ring = _untangle(ring)
    # few interior Steiner points: where the quality (minimum angle) demands them, and to
    # keep interior triangles below ~3 boundary spacings (they bound the grid cell size)
    max_area = (3.0 * spacing) ** 2 * np.sqrt(3) / 4
    verts, tris = triangulate_polygon(ring, max_area=max_area, min_angle=params.min_angle,
                                      interior=params.interior_points)
    edges, aux = mesh_springs(tris)
    springs = np.concatenate([edges, aux]).astype(np.int32)
    art = np.concatenate([p for a in outline.element.paths for p in a.subpaths])
    art = (art - outline.center) * scale
    art_tri, art_bary = bind_points(art, verts, tris)
    x, y = ring[:, 0], ring[:, 1]
    signed = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    anchor_tri, anchor_bary = skin_anchors(geom, verts[:len(ring)], verts, tris)
    return Template(outline, float(scale), verts, len(ring), tris, springs, len(edges),
                    art_tri, art_bary, abs(signed), anchor_tri, anchor_bary,
                    1.0 if signed > 0 else -1.0)


def skin_anchors(art, ring: np.ndarray, verts: np.ndarray, tris: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Where each skin vertex (``ring``) stands over its ``art`` (beyond the paper): the
    nearest point of the art's outline as (triangle of the mesh, barycentric coordinates).
    :func:`repulsionpak.sim.skinwidth.keep_skin_width` keeps each skin vertex most of its
    rest distance outside that point, so the skin cannot be pressed thin."""
    lines = shapely.shortest_line(art.boundary, shapely.points(ring))
    near = shapely.get_coordinates(shapely.get_point(lines, 0))
    tri, bary = bind_points(near, verts, tris)
    return tri.astype(np.int32), bary


def _untangle(ring: np.ndarray) -> np.ndarray:
    """Resampling can, at very sharp narrow features, produce a self-intersecting ring;
    drop samples until it is simple (rare; keeps the order)."""
    poly = shapely.Polygon(ring)
    if poly.is_valid:
        return ring
    fixed = shapely.make_valid(poly)
    parts = [g for g in getattr(fixed, "geoms", [fixed]) if isinstance(g, shapely.Polygon)]
    biggest = max(parts, key=lambda g: g.area)
    keep = shapely.contains_xy(shapely.buffer(biggest, 1e-9 * max(1.0, np.ptp(ring))), ring[:, 0], ring[:, 1])
    out = ring[keep]
    return out if shapely.Polygon(out).is_valid and len(out) >= 3 else ring_coords(biggest)
