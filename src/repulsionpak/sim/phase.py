"""What every simulation phase (the primaries', the pocket fill's) derives from the templates
it moves and the parameters: the neighbour grid's cell and the meshes' bend limits.

Notes
-----
The primary phase (:mod:`repulsionpak.pack`) and the secondary one
(:mod:`repulsionpak.secondary`) build their models the same way; these functions live
below both so that neither imports the other.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..params import Params
from ..preprocess import Template
from ..render import is_convex


def typical_size(templates: Sequence[Template], assignment: np.ndarray) -> float:
    """Typical final element diameter (container units): 2·sqrt(mean skin area / π).

    Parameters
    ----------
    templates : sequence of Template
        The meshed elements.
    assignment : (n,) int array
        Template index of each copy.

    Returns
    -------
    float
        The diameter of a disc of the copies' mean skin area.
    """
    return float(2 * np.sqrt(np.mean([templates[i].skin_area for i in assignment]) / np.pi))


def neighbour_cell(templates: Sequence[Template], assignment: np.ndarray, gap: float,
                   params: Params) -> float:
    """The neighbour grid's cell width (container units) for a phase moving the copies
    ``assignment``: ``sim.cell_size`` × their typical size, and at least three mesh spacings.

    Parameters
    ----------
    templates : sequence of Template
        The meshed elements.
    assignment : (n,) int array
        Template index of each copy that moves.
    gap : float
        The packing's gap (container units).
    params : Params
        ``sim.cell_size`` and ``preprocess.mesh_spacing`` are read.

    Returns
    -------
    float
        The cell width in container units.

    Notes
    -----
    A vertex is repelled by every skin in the 3×3 cells around it, so the cell is the
    reach of the repulsion: scaled to the elements that move, small secondaries feel their
    own neighbourhood (and a query scans a few times fewer skin chunks) rather than a
    primary-sized one.
    """
    return max(params.sim.cell_size * typical_size(templates, assignment),
               3.0 * params.preprocess.mesh_spacing * gap)


def bend_limits(templates, template_index, sim) -> np.ndarray:
    """Per-copy deformation limit of the mesh (``sim/shape.py``) that keeps the art's
    distortion below ``sim.bend_limit`` (``bend_limit_convex`` for convex elements).

    Parameters
    ----------
    templates : sequence of Template
        The meshed elements.
    template_index : (n,) int array
        Template index of each copy.
    sim : SimParams
        ``bend_limit`` and ``bend_limit_convex`` are read.

    Returns
    -------
    (n,) float array
        The mesh's limit for each copy (RMS displacement over the mesh's RMS radius).

    Notes
    -----
    The art's distortion (symmetric difference over area) is about the mean normal
    displacement of its outline over its mean half-width h = area / perimeter (thin strokes
    show a bend more than a disc); the mesh limit is an RMS displacement relative to the
    mesh's RMS radius R, so it is the art limit × h / R (× 0.8 for the difference between
    an RMS and a mean).
    """
    out = {}
    for ti in set(int(t) for t in template_index):
        t = templates[ti]
        d = sim.bend_limit_convex if is_convex(t) else sim.bend_limit
        o = t.outline
        h = t.scale * o.area / max(o.perimeter, 1e-300)
        v = t.verts - t.verts.mean(axis=0)
        r = float(np.sqrt((v ** 2).sum(axis=1).mean()))
        out[ti] = 0.8 * d * h / r if r > 0 else 0.0
    return np.array([out[int(ti)] for ti in template_index])


__all__ = ["bend_limits", "neighbour_cell", "typical_size"]
