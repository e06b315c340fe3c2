"""A container from an SVG file: the region its closed shapes enclose, holes subtracted.

Owns :func:`container_from_svg` and :func:`container_from_shapes`: every closed subpath
counts (an open one whose ends meet within tolerance too) whatever its paint, each shape
filled by its fill rule, clipped by its ``clip-path``; shapes marked as holes are
subtracted; :func:`drop_unpainted` leaves out unpainted layout helpers beside a drawn
outline.

Notes
-----
A container is geometry, not appearance: its drawn shapes are kept (with their curve
source and paint servers) only for ``--container-paint as-drawn``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import shapely

from ..errors import InputError
from ..types import ArtPath, Container
from .files import PointBudget, warn
from .regions import count_self_crossing, finalize_region, polygon_parts, rings_to_region, warn_self_crossing
from .svg_clip import clip_art, polygon_rings
from .svg_flatten import flatten_shape, flattening_tolerance, shape_clipper
from .svg_shapes import SvgShape, parse_svg_shapes
from .svg_source import paint_servers, shape_source
from .svg_xml import sprite_hint

__all__ = ["CLOSE_SHARE", "container_from_shapes", "container_from_svg", "drop_unpainted"]


#: an open subpath of a container whose last point misses its first by at most this share
#: of its size counts as closed: icon sets draw outlines without ``z`` whose ends differ by
#: a rounding (Tabler's heart: 0.006 in 24 units), which a fine gap's tolerance refused
CLOSE_SHARE = 1e-3


def container_from_shapes(
    path,
    shapes: list[SvgShape],
    tol: float,
    budget: PointBudget,
    svg_root: dict,
    clip=None,
    xml=None,
) -> Container:
    """Build a Container from SVG shapes (closed subpaths only; holes subtracted).

    ``clip``: optional ``clip(shape) -> region | None`` (:func:`shape_clipper`); a
    clipped shape counts, and is drawn, as its part inside the region.
    """
    outer, holes, arts = [], [], []
    unpainted: list = []
    n_open = n_crossing = n_clipped_away = 0
    for sh in shapes:
        rings = []
        for pts, closed in flatten_shape(path, sh, tol, budget):
            if not closed:
                ends = float(np.hypot(*(pts[-1] - pts[0])))
                if len(pts) < 3 or ends > max(tol, CLOSE_SHARE * float(np.hypot(*np.ptp(pts, axis=0)))):
                    n_open += 1
                    continue
                if ends <= tol:
                    pts = pts[:-1]
            if len(pts) >= 3:
                rings.append(pts)
        if not rings:
            continue
        geom = rings_to_region(rings, sh.style.fill_rule, path)
        n_crossing += count_self_crossing(rings)
        drawn = [ArtPath(tuple(rings), tuple(True for _ in rings), sh.style, source=shape_source(path, sh))]
        region_clip = clip(sh) if clip is not None else None
        if region_clip is not None:
            geom = polygon_parts(shapely.intersection(geom, region_clip))
            if not polygon_rings(geom):
                n_clipped_away += 1
                continue
            # drawn as browsers draw it: the clipped fill, and the clipped stroke as a filled
            # area (the clipped outline, stroked, drew a line along the cut)
            drawn = clip_art(drawn[0], region_clip)
        (holes if sh.hole else outer).append(geom)
        if not sh.style.visible and not sh.hole:
            unpainted.append(geom)
        arts.extend(drawn)
    if n_open:
        warn(
            path,
            f"ignored {n_open} open subpath(s) of the container (first point != last point); close them with Z to use them",
        )
    if not outer and not holes:  # (the drawn paths may be none: a clip can hide what paints)
        if n_clipped_away:
            raise InputError(
                path,
                "has no closed path left: every closed shape is clipped away by its clip-path",
            )
        raise InputError(
            path, "has no closed path; a container needs at least one closed outline" + sprite_hint(xml)
        )
    outer = drop_unpainted(path, unpainted, outer)
    region = shapely.union_all(outer) if outer else shapely.Polygon()
    if holes:
        hole_region = shapely.union_all(holes)
        if region.is_empty:
            raise InputError(
                path,
                "has only hole shapes and no outer outline; mark at least one shape as the container",
            )
        if not hole_region.difference(region).area <= 1e-9 * max(
            hole_region.area, 1e-300
        ):
            warn(
                path,
                "a hole shape is not entirely inside the container outline; only its overlap is removed",
            )
        region = region.difference(hole_region)
    region = finalize_region(path, region)
    warn_self_crossing(path, n_crossing, region)
    return Container(
        source=Path(str(path)).name,
        region=region,
        paths=tuple(arts),
        svg_root=dict(svg_root),
        paint_servers=paint_servers(path, xml, arts),
    )


def drop_unpainted(path, unpainted: list, outer: list) -> list:
    """The container's outer shapes without those painted with neither fill nor stroke,
    when some shape is painted.

    Parameters
    ----------
    path : Path
        The container file (for the warning).
    unpainted : list
        The outer shapes' regions that have neither fill nor stroke (identity matters).
    outer : list
        Every outer shape's region.

    Returns
    -------
    list
        ``outer`` less the unpainted regions; all of ``outer`` when nothing is painted (a file
        of bare geometry) or everything is.

    Notes
    -----
    A container is geometry, whatever its paint, but an icon's invisible bounding square
    next to its drawn outline (every Tabler icon has one) is a layout helper browsers do not
    draw: counted, it turned the container into a square. Such helpers are left out, with a
    warning that says how to keep them.
    """
    if not unpainted or len(unpainted) == len(outer):
        return outer
    kept = [g for g in outer if not any(g is u for u in unpainted)]
    warn(
        path,
        f"left out {len(unpainted)} shape(s) with neither fill nor stroke beside the drawn outline "
        "(layout helpers such as an icon's bounding square); give them a fill or stroke to make "
        "them part of the container",
    )
    return kept


def container_from_svg(path: Path, data: bytes, tolerance: float | None) -> Container:
    doc = parse_svg_shapes(path, data)
    if doc.stretch is not None:
        warn(path, f"the root's transform or preserveAspectRatio stretches the drawing "
                   f"({doc.stretch[0] / doc.stretch[1]:.3g}:1); the packing is made in its user units, so the "
                   "output, drawn the same way, shows the copies stretched too: give the root a uniform "
                   "mapping (or apply the stretch to the shapes themselves)")
    # a container is geometry, not appearance: fill, stroke and opacity do not matter;
    # display:none (never parsed) and visibility:hidden shapes are left out
    shapes = [s for s in doc.shapes if not s.hidden]
    tol = flattening_tolerance(shapes, tolerance)
    budget = PointBudget(path)
    clip = shape_clipper(path, doc, tol, budget)
    return container_from_shapes(path, shapes, tol, budget, doc.svg_root, clip, doc.xml)
