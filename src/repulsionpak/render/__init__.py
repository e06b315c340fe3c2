"""Rendering: the deformation map, curve fitting, and the SVG / PDF / PNG writers.

``placed_art`` maps every element's art through its deformed mesh and fits smooth curves
(:mod:`.placed`, :mod:`.deform`, :mod:`.fit`); :mod:`.svg`, :mod:`.pdf` and :mod:`.png`
write a packing; :func:`written_geometry` is the area of exactly what is written, for
checks.
"""

from .placed import (affine_fit, deformation, element_vertices, is_convex, placed_art, render_copy,
                     rest_art, similarity_fit, similarity_matrix, skin_polygons)
from .written import written_geometry

__all__ = ["affine_fit", "deformation", "element_vertices", "is_convex", "placed_art", "render_copy",
           "rest_art", "similarity_fit", "similarity_matrix", "skin_polygons", "written_geometry"]
