"""Measures of a finished packing (paper sec. 11), on the art alone.

Every function here is a pure function of geometry: numpy arrays and shapely geometries
in, plain ``dict``/``list``/``float`` out (JSON-serialisable). None looks at the
simulation's meshes or skins, so they are a yardstick independent of the simulation.
Only :func:`evaluate_file` reads a file (through a reader of :mod:`repulsionpak.io`);
nothing here writes one (the plots return PNG bytes).

Modules
-------
* :mod:`.coverage` – area fraction, overlap, art outside the container, edge distances.
* :mod:`.gaps` – each element's distance to its nearest neighbour, and its statistics.
* :mod:`.raster` – the exact pixel-centre rasteriser (also used by the secondary stage).
* :mod:`.contact` – the spherical contact probability Q_s(r).
* :mod:`.similarity` – the distance of a placed copy from a similar copy of its source.
* :mod:`.evaluation` – :func:`evaluate` / :func:`evaluate_file`: all of the above in one dict.
* :mod:`.promises` – the promises a packing keeps, checked on that dict.
* :mod:`.table` – the dict as a human-readable table.
* :mod:`.plots` – SCP plots (matplotlib, imported when a plot is made).
* :mod:`.references` – stripes and square grids with a known SCP (Fig. 9).
"""

from .contact import default_r_grid, ideal_stripes_q, q_at, scp, scp_vector
from .coverage import area_fraction, art_geometry, edge_distances, outside, outside_area, overlap_area
from .evaluation import evaluate, evaluate_file
from .gaps import gap_statistics
from .plots import scp_bands_png, scp_plot_png
from .promises import ContractLimits, check_promises, limits_dict
from .raster import rasterize
from .references import (equivalent_stripe_width, perturbed_squares_reference, square_grid_reference,
                         stripes_reference)
from .similarity import distortion, distortion_summary, distortions, frame_angle, source_geometries
from .table import format_table

__all__ = [
    "ContractLimits",
    "area_fraction",
    "art_geometry",
    "check_promises",
    "default_r_grid",
    "distortion",
    "distortion_summary",
    "distortions",
    "edge_distances",
    "equivalent_stripe_width",
    "evaluate",
    "evaluate_file",
    "format_table",
    "frame_angle",
    "gap_statistics",
    "ideal_stripes_q",
    "limits_dict",
    "outside",
    "outside_area",
    "overlap_area",
    "perturbed_squares_reference",
    "q_at",
    "rasterize",
    "scp",
    "scp_bands_png",
    "scp_plot_png",
    "scp_vector",
    "source_geometries",
    "square_grid_reference",
    "stripes_reference",
]
