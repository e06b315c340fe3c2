"""Every measure of a packing in one JSON-serialisable dict: :func:`evaluate`.

:func:`evaluate` takes a container and its placed art (a :class:`~repulsionpak.Packing`'s
``container`` and ``placed``) and gathers the coverage, gap, edge, distortion and SCP
measures of the other modules of :mod:`repulsionpak.measure`; :func:`evaluate_file` does
the same for a packing SVG read back through :func:`repulsionpak.io.read_packing_svg`
(the dict ``repulsionpak evaluate --json`` prints).
"""

from __future__ import annotations

import math
import numbers
import os

import numpy as np

from ..blas import with_one_blas_thread
from ..errors import ParameterError
from ..art_area import _polygonal
from ..types import Container, PlacedArt
from .contact import q_at, scp
from .coverage import area_fraction, art_geometry, edge_distances, outside, outside_area, overlap_area
from .gaps import gap_statistics
from .similarity import distortion_summary, distortions, frame_angle, source_geometries

__all__ = ["evaluate", "evaluate_file"]


@with_one_blas_thread
def evaluate(
    container: Container,
    placed: list[PlacedArt],
    gap: float,
    grid: int = 1000,
    *,
    outside_tol: float | None = None,
    with_scp: bool = True,
    sources=None,
    margin: float | None = None,
    workers: int = 1,
    primary_scp: bool | None = None,
) -> dict:
    """All measures of a packing as a JSON-serialisable dict.

    Parameters
    ----------
    container : Container
        The container the packing fills.
    placed : list of PlacedArt
        The placed art (``packing.placed``, or ``read_packing_svg(path)[1]``).
    gap : float
        The gap asked for (container units, > 0).
    grid : int
        Pixels along the longer side of the SCP raster.
    outside_tol : float, optional
        An element counts as outside when its art lies farther than this outside the
        container (default 5 % of ``gap``; see :func:`~repulsionpak.measure.outside`).
    with_scp : bool
        Compute the SCP (the raster and its distance transform are the slow part;
        ``pack`` reports do without them). Without it the SCP entries are ``None``.
    sources : mapping or iterable of Element, optional
        The source art for the distortion: ``data-source`` name → shapely geometry, or
        the library elements. Without it (or for an unknown name) the distortion values
        are ``None``.
    margin : float, optional
        The edge margin checked (default gap/2).
    workers : int
        Threads fitting several copies' distortion at once (the values do not depend on it).
    primary_scp : bool, optional
        Compute ``scp_ratio_primary`` (default: as ``with_scp``).

    Returns
    -------
    dict
        What ``repulsionpak evaluate --json`` prints: ``area_fraction``,
        ``overlap_area``, ``n_primary``, ``n_secondary``, ``n_elements``, ``n_outside`` /
        ``outside`` / ``outside_tol``, ``container_area``, ``gap`` {median, p10, p90,
        mean, min, max, requested, values}, ``deformation`` {mean, max, values},
        ``outside_area`` (art area outside the container, exact), ``edge`` {min, margin,
        n_below_margin, values} (each element's art distance to the container's
        boundary; how many are closer than 0.98 × margin), ``distortion`` {median, p95,
        max, values, by_kind} (per element, area(best similar copy of its source △ the
        placed art) / its area), ``scp`` {r, q, h, q0, pixel_size, shape} (r includes
        gap/2 exactly), ``scp_at_half_gap`` = Q_s(gap/2), ``scp_ratio`` =
        Q_s(gap/2)/Q_s(0); and what the primaries do alone: ``area_fraction_primary``,
        ``scp_ratio_primary``, ``median_primary_size`` (the square root of the median
        primary's art area) and ``smallest_secondary_rel`` (the smallest secondary
        copy's size over it; ``None`` without primaries or secondaries).

    Raises
    ------
    ParameterError
        When the container, the placed art, the gap or the margin is not valid.

    Notes
    -----
    The measures look at the art alone, never at the simulation's meshes
    (:mod:`~repulsionpak.measure.coverage`, :mod:`~repulsionpak.measure.similarity`),
    so they measure the output independently of the code that made it. The primaries
    are also measured alone because the pocket copies, counted as art everywhere else,
    hide a loose packing. A copy that carries its ``frame`` starts the distortion fit
    from that rotation.
    """
    if not isinstance(container, Container):
        raise ParameterError(f"evaluate(): the container must be a Container, got {type(container).__name__}")
    if hasattr(placed, "placed") and hasattr(placed, "gap"):  # a Packing
        raise ParameterError("evaluate(): give the packing's placed art, packing.placed, not the Packing")
    placed = list(placed) if hasattr(placed, "__iter__") and not isinstance(placed, (str, bytes)) else None
    if placed is None or not all(isinstance(p, PlacedArt) for p in placed):
        raise ParameterError("evaluate(): placed must be a list of PlacedArt (a packing's .placed, or "
                             "read_packing_svg(path)[1])")
    if isinstance(gap, bool) or not isinstance(gap, numbers.Real) or not np.isfinite(gap) or gap <= 0:
        raise ParameterError(f"gap must be a positive number, got {gap!r}")
    gap = float(gap)
    region = _polygonal(container.region)
    geoms = [art_geometry(p) for p in placed]
    af = area_fraction(region, geoms)
    tol = 0.05 * gap if outside_tol is None else float(outside_tol)
    out_idx = outside(region, geoms, tol)
    gs = gap_statistics(geoms)
    gs["requested"] = gap
    defs = [None if p.deformation is None else float(p.deformation) for p in placed]
    known = [d for d in defs if d is not None and np.isfinite(d)]
    edges = edge_distances(region, geoms)
    margin = 0.5 * gap if margin is None else float(margin)
    if not (np.isfinite(margin) and margin >= 0):
        raise ParameterError(f"margin must be a non-negative number, got {margin!r}")
    known_edges = [e for e in edges if e is not None]
    if sources is not None and not isinstance(sources, dict):
        sources = source_geometries(sources)
    dist = (distortions(geoms, [p.source for p in placed], sources,
                                 angles=[frame_angle(p.frame) for p in placed],
                                 workers=workers) if sources
            else [None] * len(placed))
    s = q_half = q0 = None
    if with_scp:
        s = scp(region, geoms, grid=grid, gap=gap)
        q_half = q_at(s, 0.5 * gap)
        q0 = s["q"][0] if s["q"] else None
    alone = _primaries_alone(region, geoms, [p.kind for p in placed], gap, grid,
                             with_scp if primary_scp is None else primary_scp)
    return {
        "area_fraction": float(af),
        "overlap_area": overlap_area(geoms),
        "n_primary": sum(1 for p in placed if p.kind == "primary"),
        "n_secondary": sum(1 for p in placed if p.kind == "secondary"),
        "n_elements": len(placed),
        "n_outside": len(out_idx),
        "outside": out_idx,
        "outside_tol": tol,
        "container_area": float(region.area),
        "gap": gs,
        "deformation": {
            "mean": float(np.mean(known)) if known else None,
            "max": float(np.max(known)) if known else None,
            "values": defs,
        },
        "outside_area": outside_area(region, geoms),
        "edge": {
            "min": min(known_edges) if known_edges else None,
            "margin": margin,
            "n_below_margin": sum(1 for e in known_edges if e < 0.98 * margin),
            "values": edges,
        },
        "distortion": distortion_summary(dist, [p.kind for p in placed]),
        "scp": s,
        "scp_at_half_gap": q_half,
        "scp_ratio": (q_half / q0) if (q_half is not None and q0) else None,
        **alone,
    }


def _primaries_alone(region, geoms: list, kinds: list[str], gap: float, grid: int, with_scp: bool) -> dict:
    """The keys of :func:`evaluate` that measure the primaries without the pocket copies:
    ``area_fraction_primary``, ``scp_ratio_primary`` (None unless ``with_scp``),
    ``median_primary_size`` and ``smallest_secondary_rel`` (sizes: the square root of
    the art's area)."""
    prim = [g for g, k in zip(geoms, kinds) if k == "primary"]
    sizes = [float(np.sqrt(g.area)) for g in prim]
    sec = [float(np.sqrt(g.area)) for g, k in zip(geoms, kinds) if k != "primary"]
    median = float(np.median(sizes)) if sizes else None
    ratio = None
    if with_scp and prim:
        sp = scp(region, prim, grid=grid, gap=gap)
        q0 = sp["q"][0] if sp["q"] else None
        ratio = q_at(sp, 0.5 * gap) / q0 if q0 else None
    return {
        "area_fraction_primary": float(area_fraction(region, prim)) if prim else 0.0,
        "scp_ratio_primary": ratio,
        "median_primary_size": median,
        "smallest_secondary_rel": (min(sec) / median) if (sec and median) else None,
    }


def _recorded_margin(info: dict | None) -> float | None:
    """The edge margin a packing was verified with, from its metadata (None if absent)."""
    meta = (info or {}).get("metadata")
    inv = meta.get("invariants") if isinstance(meta, dict) else None
    m = inv.get("margin") if isinstance(inv, dict) else None
    try:
        m = float(m)
    except (TypeError, ValueError):
        return None
    return m if math.isfinite(m) and m >= 0 else None


def evaluate_file(path: str | os.PathLike, gap: float | None = None, grid: int = 1000,
                  sources=None, workers: int = 1, margin: float | None = None) -> dict:
    """:func:`evaluate` of a packing SVG written by repulsionpak.

    Parameters
    ----------
    path : str or os.PathLike
        The packing SVG.
    gap : float, optional
        The gap; default: the root's ``data-gap``.
    grid, sources, workers
        As for :func:`evaluate` (``sources`` e.g. ``load_elements([...])``).
    margin : float, optional
        The edge margin; default: the one the packing was made with (its metadata's
        verification, when the file's own gap is used), else half the gap.

    Returns
    -------
    dict
        The :func:`evaluate` dict, plus ``file`` (``str(path)``).

    Raises
    ------
    ParameterError
        When neither ``gap`` nor the file's ``data-gap`` is known, or ``data-gap`` is
        not a number.
    """
    from ..io import read_packing_svg  # at call time: tests stand in for the reader

    container, placed, meta = read_packing_svg(path)
    own_gap = gap is None
    if gap is None:
        meta = meta or {}
        for key in ("gap", "data-gap", "data_gap"):
            if meta.get(key) not in (None, ""):
                try:
                    gap = float(meta[key])
                except (TypeError, ValueError) as exc:
                    raise ParameterError(f"{path}: data-gap is not a number: {meta[key]!r}") from exc
                break
    if gap is None:
        raise ParameterError(f"{path}: the file has no data-gap; give the gap explicitly (--gap)")
    if margin is None and own_gap:
        margin = _recorded_margin(meta)
    result = evaluate(container, placed, gap, grid=grid, sources=sources, workers=workers, margin=margin)
    result["file"] = str(path)
    return result
