"""A run's inputs as the library decides them: the gap, the container's flattening, the elements.

Every entry point (``repulsionpak pack``, ``batch``, the live view, the kernel cache's build,
:func:`repulsionpak.pack.pack` called from Python) reads its inputs through
:func:`load_inputs` or :func:`run_container`, so the same files, seed and parameters give
the same packing wherever it is made.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from dataclasses import dataclass, field

import shapely

from .errors import ParameterError
from .params import Params, PlacementParams
from .placement import gap_for_count
from .types import Container, Element

#: a run flattens the container's curves to within this share of its gap
CONTAINER_TOLERANCE = 0.001


def default_gap(container: Container, placement: PlacementParams | None = None) -> float:
    """The gap of a run that names none.

    Parameters
    ----------
    container : Container
    placement : PlacementParams, optional
        With a ``count``, the gap is also at most the one at which that many elements are
        ``element_size`` gaps across (the inverse of :func:`repulsionpak.placement.estimate_count`).

    Returns
    -------
    float
        1% of the container's larger side, at most 4% of the widest circle it holds (and
        at most the count's gap), to 4 significant digits (a readable data-gap).

    Notes
    -----
    The circle cap only binds on containers much longer than wide: a 20:1 strip got a gap
    of a fifth of its height from its length, and held 3 elements. The count cap binds
    when many elements are asked for: 1,000 copies in a 1000 × 1500 poster at a gap of 15
    could be 24 units across at most, 1.6 gaps, and covered a fifth of it. The example
    containers keep 1% of their larger side.
    """
    minx, miny, maxx, maxy = container.bounds
    gap = 0.01 * max(maxx - minx, maxy - miny)
    circle = shapely.maximum_inscribed_circle(container.region, 1e-3 * gap)
    gap = min(gap, 0.04 * 2 * circle.length)
    if placement is not None and placement.count:
        gap = min(gap, gap_for_count(container.region.area, placement.count, placement))
    return float(f"{gap:.4g}")


def margin_of(params: Params, gap: float) -> float:
    """The edge margin in container units: ``params.margin``, or half the gap."""
    return 0.5 * gap if params.margin is None else float(params.margin)


def check_fineness(container: Container, gap: float, params: Params) -> None:
    """Refuse a gap too fine for the container.

    Parameters
    ----------
    container : Container
    gap : float
        The run's gap, container units.
    params : Params
        ``placement.max_vertices`` bounds the meshes.

    Raises
    ------
    ParameterError
        When the meshes would need more than ``placement.max_vertices`` vertices,
        estimated as area / gap² (skins are sampled a gap apart and the elements grow
        until they fill the container, however many there are).
    """
    need = container.area / (gap * gap)
    limit = params.placement.max_vertices
    if need > limit:
        minx, miny, maxx, maxy = container.bounds
        size = max(maxx - minx, maxy - miny)
        least = math.sqrt(container.area / limit)
        about = f"{need:,.0f}" if need < 1e12 else f"{need:.1e}"
        raise ParameterError(
            f"the gap ({gap:g}, {100 * gap / size:.2g}% of the container's {size:g} units) is too fine: its "
            f"meshes would need about {about} vertices (the container's area / gap²), more than "
            f"placement.max_vertices = {limit:,}; use a gap of at least {least:.3g} "
            f"({100 * least / size:.2g}% of the container's size; 1% is typical), or raise "
            "placement.max_vertices in a --config file to try anyway")


def _read_container(path, tolerance: float | None, params: Params) -> Container:
    """``load_container(path, tolerance)``; a gap far too fine flattens the container to
    millions of points: that error then says the gap is too fine, when that is why."""
    from .io import load_container
    from .io.files import TooManyPoints

    try:
        return load_container(path, tolerance=tolerance)
    except TooManyPoints:
        if params.gap is not None:
            check_fineness(load_container(path), params.gap, params)
        raise


def run_container(container: Container | str | os.PathLike, params: Params) -> tuple[Container, Params]:
    """The container as a run uses it, and the parameters with the run's gap.

    Parameters
    ----------
    container : Container or path
        A path is read; a :class:`Container` read from a file at the reader's default
        tolerance (``load_container(path)``) is read again at the run's.
    params : Params
        ``params.gap`` None: :func:`default_gap` of the container as read by default.

    Returns
    -------
    container : Container
        Flattened to ``CONTAINER_TOLERANCE`` × gap; a container built in memory, or read
        at a tolerance of the caller's choosing, is kept as it is.
    params : Params
        ``params`` with ``gap`` set.

    Notes
    -----
    The edge margin is checked against the flattened polygon, whose chords lie outside
    the drawn curve on concave stretches by up to the tolerance: art kept gap/2 from a
    gap/100 polygon came 0.494 gap from the drawn curve inside a letter C. The default
    gap comes from the container read at the reader's default tolerance, then it is read
    again at the gap's: the same two reads wherever the run starts.
    """
    if isinstance(container, (str, os.PathLike)):
        path = container
        if params.gap is None:  # read once for the gap: the read at the gap's tolerance below warns
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                cont = _read_container(path, None, params)
        else:
            cont = _read_container(path, CONTAINER_TOLERANCE * params.gap, params)
    elif isinstance(container, Container):
        path, cont = container.path, container
    else:
        raise ParameterError(f"pack(): the container must be a Container (load_container(path) reads one) "
                             f"or its file's path, got {type(container).__name__}")
    gap = params.gap if params.gap is not None else default_gap(cont, params.placement)
    if cont.tolerance is None and path is not None:
        cont = _read_container(path, CONTAINER_TOLERANCE * gap, params)
    if params.gap != gap:
        params = dataclasses.replace(params, gap=gap)
    return cont, params


def _is_paths(items) -> bool:
    return isinstance(items, (str, os.PathLike)) or (
        not isinstance(items, Element) and hasattr(items, "__iter__")
        and any(isinstance(i, (str, os.PathLike)) for i in items))


def _elements(items, controls) -> tuple[list[Element], list[str] | None]:
    """Elements of a list of Element or of paths (files, folders, manifests, read as the
    CLI reads them); the paths as given, or None for Element objects."""
    if not _is_paths(items):
        return list(items), None
    from .io.manifest import load_element_args

    paths = [items] if isinstance(items, (str, os.PathLike)) else list(items)
    return load_element_args(paths, controls), [str(p) for p in paths]


@dataclass(frozen=True, eq=False)
class Inputs:
    """What a run packs: the container as flattened for it, the elements and the
    parameters with the run's gap; ``sources`` names the inputs in the report."""

    container: Container
    elements: tuple[Element, ...]
    secondary: tuple[Element, ...]
    params: Params
    sources: dict = field(default_factory=dict)


def load_inputs(container: Container | str | os.PathLike, elements, params: Params = Params(),
                secondary=(), controls=None) -> Inputs:
    """Read a run's inputs as every entry point does.

    Parameters
    ----------
    container : Container or path
        See :func:`run_container`.
    elements, secondary : sequence of Element, or of paths
        Paths are files, folders and element manifests (``.toml``), read in order.
    params : Params
        Validated here; the gap, when None, is the container's :func:`default_gap`.
    controls : ElementControls, optional
        Default controls of every element read from a path (the CLI's ``--rotation``,
        ``--rigid``, ``--stiffness``).

    Returns
    -------
    Inputs
        ``sources``: ``{"container": ..., "elements": [...], "secondary": [...]}``, the
        paths as given (for Element objects, the file names they were read from).
    """
    params = params.validate()
    cont, params = run_container(container, params)
    elems, e_paths = _elements(elements, controls)
    secs, s_paths = _elements(secondary or (), controls) if secondary else ([], [])
    c_name = str(container) if isinstance(container, (str, os.PathLike)) else (cont.path or cont.source)
    sources = {"container": c_name,
               "elements": e_paths if e_paths is not None else [e.source for e in elems],
               "secondary": s_paths if s_paths is not None else [e.source for e in secs]}
    return Inputs(cont, tuple(elems), tuple(secs), params, sources)


__all__ = ["CONTAINER_TOLERANCE", "Inputs", "check_fineness", "default_gap", "load_inputs", "margin_of",
           "run_container"]
