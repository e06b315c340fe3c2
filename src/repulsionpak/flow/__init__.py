"""Elements that flow (after FLOWPAK, Saputra et al. GI 2017): guide strokes, the direction
field interpolated from them, and the alignment of each element's axis with it.

* :mod:`.guides` – the guide strokes of a ``--flow GUIDES.svg`` file (polylines, in the
  direction they are drawn);
* :mod:`.field` – :class:`~.field.FlowField`, a smooth unit direction field over the
  container (harmonic interpolation of the strokes' tangents on a grid);
* :mod:`.align` – each element's axis, each copy's target orientation, and the measure:
  the angle between each output copy's axis and the field at its centroid;
* :mod:`.bend` – ``flow_bend``: rest shapes bent along the streamlines, within the shape
  promise, and the measure: each output copy's midline curvature against the streamline's.
"""

from .align import AlignStats, alignment_angles, element_axis, flow_targets
from .bend import curvature_match
from .field import FlowField, field_from_guides
from .guides import load_guides

__all__ = ["AlignStats", "FlowField", "alignment_angles", "curvature_match", "element_axis",
           "field_from_guides", "flow_targets", "load_guides"]
