"""Rendering: the deformation map, curve fitting, and the SVG / PDF / PNG writers.

``placed_copy`` maps a copy's art through its deformed mesh and fits smooth curves
(:mod:`.placed`, :mod:`.deform`, :mod:`.fit`); :mod:`.svg`, :mod:`.pdf` and :mod:`.png`
write a packing; :func:`written_geometry` is the area of exactly what is written, for
checks. The loops over a simulation's copies are :mod:`repulsionpak.sim.art`.
"""

from .placed import (affine_fit, deformation, is_convex, placed_copy, render_copy, rest_copy, similarity_fit,
                     similarity_matrix)
from .written import written_geometry

__all__ = ["affine_fit", "deformation", "is_convex", "placed_copy", "render_copy", "rest_copy", "similarity_fit",
           "similarity_matrix", "written_geometry"]
