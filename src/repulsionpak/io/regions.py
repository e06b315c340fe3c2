"""Regions from closed outlines: the area a renderer fills, and container validation.

Owns :func:`rings_to_region` (the exact filled area of closed subpaths under the
``nonzero`` or ``evenodd`` fill rule, with work limits for scribbles), and the helpers the
SVG and ``.path`` container readers share: :func:`clean_points`, :func:`finalize_region`,
:func:`count_self_crossing` and :func:`warn_self_crossing`.

Notes
-----
Pure geometry on (K, 2) arrays plus the file-naming errors; ``render`` uses
:func:`rings_to_region` to fill the container as drawn, so it lives apart from the readers.
"""

from __future__ import annotations

import numpy as np
import shapely

from ..errors import InputError
from .files import warn

__all__ = [
    "MAX_REGION_FACES",
    "RegionTooComplex",
    "clean_points",
    "count_self_crossing",
    "finalize_region",
    "polygon_parts",
    "rings_to_region",
    "warn_self_crossing",
]


def _winding_numbers(points: np.ndarray, rings: list[np.ndarray]) -> np.ndarray:
    """Winding number of each point (F, 2) with respect to all closed rings (K_i, 2)."""
    a = np.concatenate(rings, axis=0)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in rings], axis=0)
    w = np.zeros(len(points), dtype=np.int64)
    chunk = max(1, 4_000_000 // max(1, len(a)))
    ax, ay, bx, by = a[None, :, 0], a[None, :, 1], b[None, :, 0], b[None, :, 1]
    for s in range(0, len(points), chunk):
        px = points[s : s + chunk, 0][:, None]
        py = points[s : s + chunk, 1][:, None]
        is_left = (bx - ax) * (py - ay) - (px - ax) * (by - ay)
        up = (ay <= py) & (by > py) & (is_left > 0)
        down = (ay > py) & (by <= py) & (is_left < 0)
        w[s : s + chunk] = up.sum(axis=1) - down.sum(axis=1)
    return w


def polygon_parts(geom) -> shapely.Geometry:
    """The polygonal part of ``geom`` as a Polygon or MultiPolygon (maybe empty)."""
    if geom is None or geom.is_empty:
        return shapely.Polygon()
    if isinstance(geom, (shapely.Polygon, shapely.MultiPolygon)):
        return geom
    parts = [
        g
        for g in shapely.get_parts(geom)
        if isinstance(g, (shapely.Polygon, shapely.MultiPolygon)) and not g.is_empty
    ]
    return shapely.union_all(parts) if parts else shapely.Polygon()


#: Work limits of :func:`rings_to_region` for pathological (heavily self-intersecting) input.
MAX_REGION_FACES = 20_000
MAX_REGION_WORK = 400_000_000


class RegionTooComplex(ValueError):
    """Raised by :func:`rings_to_region` when the outline has too many self-intersections."""


def _count_crossings(rings: list[np.ndarray], limit: int) -> int:
    """Number of intersecting pairs of non-adjacent edges of ``rings``, counted until it
    exceeds ``limit`` (then the partial count is returned). O(n log n + limit): bounds
    the time spent on scribbles before the (quadratic) noding of their linework."""
    a = np.concatenate(rings, axis=0)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in rings], axis=0)
    ring_id = np.concatenate([np.full(len(r), k) for k, r in enumerate(rings)])
    starts = np.cumsum([0] + [len(r) for r in rings])[:-1]
    first, last = starts[ring_id], starts[ring_id] + np.array([len(r) for r in rings])[ring_id] - 1
    with np.errstate(all="ignore"):
        segs = shapely.linestrings(np.stack([a, b], axis=1))
    tree = shapely.STRtree(segs)
    count, chunk = 0, 256
    for s in range(0, len(segs), chunk):
        i, j = tree.query(segs[s : s + chunk], predicate="intersects")
        i = i + s
        keep = i < j
        i, j = i[keep], j[keep]
        adjacent = (ring_id[i] == ring_id[j]) & (
            (j - i == 1) | ((i == first[i]) & (j == last[i]))
        )
        count += int(np.count_nonzero(~adjacent))
        if count > limit:
            break
    return count


def rings_to_region(
    rings: list[np.ndarray], fill_rule: str = "nonzero", path=None
) -> shapely.Geometry:
    """The area an SVG renderer fills for the closed subpaths ``rings`` under ``fill_rule``.

    ``rings``: list of (K_i, 2) arrays, each implicitly closed (no repeated closing
    point); rings with fewer than 3 points are ignored. Exact for nested, overlapping
    and self-intersecting rings: the linework is noded and every face of the
    arrangement is classified by the winding number of an interior point
    (``"nonzero"``: w != 0, ``"evenodd"``: w odd). Returns a valid Polygon or
    MultiPolygon (empty if nothing is filled). Outlines whose arrangement has more
    than :data:`MAX_REGION_FACES` faces raise InputError naming ``path`` (or
    :class:`RegionTooComplex` when ``path`` is None).
    """
    rings = [np.asarray(r, dtype=float) for r in rings if len(r) >= 3]
    if not rings:
        return shapely.Polygon()
    if len(rings) == 1:
        poly = shapely.Polygon(rings[0])
        if poly.is_valid:
            return poly if poly.area > 0 else shapely.Polygon()
    n_edges = sum(len(r) for r in rings)
    if n_edges > 500:  # below, even a scribble nodes in well under a second
        crossings = _count_crossings(rings, MAX_REGION_FACES)
        if crossings > MAX_REGION_FACES:
            msg = f"an outline intersects itself too often (more than {MAX_REGION_FACES} crossings); simplify it"
            if path is not None:
                raise InputError(path, msg)
            raise RegionTooComplex(msg)
    lines = [shapely.LineString(np.vstack([r, r[:1]])) for r in rings]
    noded = shapely.union_all(lines)
    faces = [
        f
        for f in shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
        if f.area > 0
    ]
    if len(faces) > MAX_REGION_FACES or len(faces) * n_edges > MAX_REGION_WORK:
        msg = (
            f"an outline intersects itself too often ({len(faces)} faces); simplify it"
        )
        if path is not None:
            raise InputError(path, msg)
        raise RegionTooComplex(msg)
    if not faces:
        return shapely.Polygon()
    faces_arr = np.empty(len(faces), dtype=object)
    faces_arr[:] = faces
    reps = shapely.get_coordinates(shapely.point_on_surface(faces_arr))
    w = _winding_numbers(reps, rings)
    keep = (w != 0) if fill_rule != "evenodd" else (np.abs(w) % 2 == 1)
    if not keep.any():
        return shapely.Polygon()
    region = shapely.union_all(faces_arr[keep])
    if not region.is_valid:
        region = shapely.make_valid(region)
    return polygon_parts(region)


def clean_points(pts: np.ndarray, closed: bool, eps: float) -> np.ndarray:
    """Remove consecutive duplicate points (and, if ``closed``, a repeated closing point)."""
    if len(pts) > 1:
        d = np.abs(np.diff(pts, axis=0)).max(axis=1)
        keep = np.concatenate([[True], d > eps])
        pts = pts[keep]
    if closed and len(pts) > 1 and np.abs(pts[-1] - pts[0]).max() <= eps:
        pts = pts[:-1]
    return pts


def finalize_region(path, region, what: str = "container") -> shapely.Geometry:
    """Validate a container region: polygonal, valid (make_valid + warning), area > 0."""
    region = polygon_parts(region)
    if not region.is_valid:
        warn(
            path,
            f"the {what} outline is not a valid polygon (self-intersections?); repaired with make_valid",
        )
        region = polygon_parts(shapely.make_valid(region))
    if region.is_empty or not region.area > 0:
        raise InputError(
            path,
            f"the {what} has zero area; it needs at least one closed shape enclosing an area",
        )
    if not np.all(np.isfinite(region.bounds)):
        raise InputError(
            path, f"the {what} has non-finite coordinates (NaN or infinity)"
        )
    return region


def count_self_crossing(rings) -> int:
    """Number of closed rings (K_i, 2) that cross or touch themselves."""
    n = 0
    for r in rings:
        if len(r) >= 4 and not shapely.LinearRing(r).is_simple:
            n += 1
    return n


def warn_self_crossing(path, n: int, region, what: str = "container") -> None:
    if n:
        parts = len(shapely.get_parts(region)) if not region.is_empty else 0
        warn(
            path,
            f"{n} {what} outline(s) cross themselves (bow-tie); used the area the fill "
            f"rule fills ({parts} region(s)); redraw the outline without crossings if that is not intended",
        )
