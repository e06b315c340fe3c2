"""The area a drawing covers: fills by their fill rule, strokes by their caps and joins.

Owns :func:`art_area` (the union of the visible paths' fills and stroke outlines, valid
and polygonal) and its parts: :func:`_fill_geometry` (``evenodd`` and ``nonzero`` fills
of the subpaths), :func:`_stroke_geometry` (a subpath buffered with the style's cap, join
and miter limit) and :func:`_polygonal` (the polygonal part of a shapely result).

Notes
-----
:class:`~repulsionpak.types.PlacedArt` measures its art with :func:`art_area`, so this
module sits beside ``types`` and imports nothing from the package: it reads paths by
their fields (``subpaths``, ``closed``, ``style``), whatever class holds them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import LinearRing, LineString, Point, Polygon, box

__all__ = ["art_area"]


_CAP = {"butt": "flat", "round": "round", "square": "square"}
_JOIN = {"miter": "mitre", "miter-clip": "mitre", "arcs": "round", "round": "round", "bevel": "bevel"}


def _polygonal(geom) -> shapely.Geometry:
    """The polygonal part of ``geom`` (valid), as a Polygon/MultiPolygon (maybe empty)."""
    if geom is None or geom.is_empty:
        return Polygon()
    if not geom.is_valid:
        geom = shapely.make_valid(geom)
    if geom.geom_type in ("Polygon", "MultiPolygon"):
        return geom
    parts = [p for p in shapely.get_parts(geom) if p.geom_type in ("Polygon", "MultiPolygon") and not p.is_empty]
    if not parts:
        return Polygon()
    out = shapely.union_all(parts)
    return out if out.is_valid else shapely.make_valid(out)


def _signed_area(pts: np.ndarray) -> float:
    """The shoelace area of the closed ring ``pts`` (K, 2): positive when counter-clockwise
    (y up)."""
    x, y = pts[:, 0], pts[:, 1]
    # (the next point of each, as np.roll(·, -1) gives it, without its overhead)
    return 0.5 * float(np.dot(x, np.concatenate((y[1:], y[:1]))) - np.dot(np.concatenate((x[1:], x[:1])), y))


def _ring_points(pts: np.ndarray) -> np.ndarray | None:
    """The finite points of a subpath without a repeated closing point; None when fewer
    than three are left (no area)."""
    pts = np.asarray(pts, dtype=float)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) >= 2 and np.array_equal(pts[0], pts[-1]):
        pts = pts[:-1]
    return pts if len(pts) >= 3 else None


def _repaired(poly, method: str) -> shapely.Geometry:
    """The invalid polygon ``poly`` made valid as its fill rule splits it (``method``:
    ``structure`` for nonzero, ``linework`` for evenodd), polygonal."""
    try:
        if method == "structure":
            poly = shapely.make_valid(poly, method="structure", keep_collapsed=False)
        else:
            poly = shapely.make_valid(poly)
    except TypeError:  # pragma: no cover - old shapely without the method argument
        poly = shapely.make_valid(poly)
    return _polygonal(poly)


def _subpath_polygons(subpaths: Sequence[np.ndarray], methods: Sequence[str]) -> list:
    """Each (implicitly closed) subpath of ``subpaths`` as a valid polygonal geometry
    (maybe empty; an invalid one split by :func:`_repaired` with its ``methods`` entry):
    the polygons built and checked all at once, the invalid ones repaired one by one.

    Notes
    -----
    A copy's art is a few dozen subpaths, and a packing measures thousands of copies:
    one shapely ``Polygon`` and two validity checks per subpath cost more than the union
    of the copy's fills (a 1,000-element poster: 41,000 subpaths, 1.5 s). The rings are
    the same coordinates, closed the same way, so the polygons are the same."""
    rings = [_ring_points(p) for p in subpaths]
    out = [Polygon()] * len(rings)
    full = [k for k, r in enumerate(rings) if r is not None]
    if not full:
        return out
    counts = [len(rings[k]) for k in full]
    polys = shapely.polygons(shapely.linearrings(np.concatenate([rings[k] for k in full]),
                                                 indices=np.repeat(np.arange(len(full)), counts)))
    for k, poly, valid in zip(full, polys, shapely.is_valid(polys)):
        out[k] = poly if valid else _repaired(poly, methods[k])
    return out


def _fill_geometry(path, polys: Sequence | None = None) -> shapely.Geometry:
    """Area painted by the fill of ``path`` following its fill rule; ``polys``: its
    subpaths' polygons (:func:`_subpath_polygons`), when known."""
    evenodd = path.style.fill_rule == "evenodd"
    if polys is None:
        polys = _subpath_polygons(path.subpaths, [_fill_method(path)] * len(path.subpaths))
    kept, signs, pts_list = [], [], []
    for pts, poly in zip(path.subpaths, polys):
        if poly.is_empty or poly.area <= 0:
            continue
        kept.append(poly)
        signs.append(1 if _signed_area(np.asarray(pts, dtype=float)) >= 0 else -1)
        pts_list.append(pts)
    polys = kept
    if not polys:
        return Polygon()
    if evenodd:
        out = polys[0]
        for p in polys[1:]:
            out = shapely.symmetric_difference(out, p)
        return _polygonal(out)
    if len(polys) == 1:
        return polys[0]
    # nonzero, approximated: the winding number of each subpath's region is the sum of
    # the orientations of every subpath containing a representative point of it; regions
    # are composed from the largest to the smallest (outer before inner), filled when
    # their winding is non-zero and cut out (holes) otherwise.
    areas = np.array([p.area for p in polys])
    order = np.argsort(-areas, kind="stable")
    reps = [p.representative_point() for p in polys]
    rx = np.array([q.x for q in reps])
    ry = np.array([q.y for q in reps])
    for p in polys:
        shapely.prepare(p)
    winding = np.array(signs, dtype=int)
    for j, pj in enumerate(polys):
        inside = shapely.contains_xy(pj, rx, ry)
        inside[j] = False
        # only a larger subpath can contain a smaller one's region
        inside &= areas < areas[j]
        winding[inside] += signs[j]
    return _polygonal(_compose(polys, order, winding != 0))


def _fill_method(path) -> str:
    """How a self-intersecting subpath of ``path`` is split (:func:`_repaired`): as its
    fill rule would (evenodd: ``linework``, alternating; nonzero: ``structure``, the
    union of the loops)."""
    return "linework" if path.style.fill_rule == "evenodd" else "structure"


def _compose(polys: list, order: np.ndarray, fill: np.ndarray) -> shapely.Geometry:
    """``polys`` united (``fill[i]``) or cut out, one after the other in ``order``, as few
    set operations: an operation needs to wait only for the earlier ones of the other
    kind whose bounding boxes meet its own (two unions, or two cuts, commute; a union
    and a cut of disjoint regions too). Each is given the first level after those; every
    level is one union of its fills then one cut of its holes. The same region as the
    operations one by one, which cost quadratic time in the number of subpaths (a line
    of text of 148 glyph contours: 0.15 s per copy, most of a pocket fill of text)."""
    n = len(order)
    box = np.asarray(shapely.bounds(np.asarray(polys, dtype=object)))[order]
    kind = np.asarray(fill, dtype=bool)[order]
    level = np.zeros(n, dtype=np.int64)
    for k in range(1, n):
        b = box[:k]
        meets = ((b[:, 0] <= box[k, 2]) & (b[:, 2] >= box[k, 0]) & (b[:, 1] <= box[k, 3])
                 & (b[:, 3] >= box[k, 1]) & (kind[:k] != kind[k]))
        level[k] = level[:k][meets].max() + 1 if meets.any() else 0
    out = Polygon()
    for lv in range(int(level.max()) + 1 if n else 0):
        adds = [polys[order[k]] for k in np.flatnonzero((level == lv) & kind)]
        cuts = [polys[order[k]] for k in np.flatnonzero((level == lv) & ~kind)]
        if adds:
            out = shapely.union(out, adds[0] if len(adds) == 1 else shapely.union_all(adds))
        if cuts:
            out = shapely.difference(out, cuts[0] if len(cuts) == 1 else shapely.union_all(cuts))
    return out


def _stroke_geometry(path, width: float) -> shapely.Geometry:
    """Area painted by the stroke of ``path`` with total stroke width ``width``."""
    half = 0.5 * width
    cap = _CAP.get(path.style.stroke_linecap, "flat")
    join = _JOIN.get(path.style.stroke_linejoin, "mitre")
    limit = max(1.0, float(path.style.stroke_miterlimit))  # SVG's miter length / width = shapely's
    parts = []
    for pts, closed in zip(path.subpaths, path.closed):
        pts = np.asarray(pts, dtype=float)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if len(pts) == 0:
            continue
        # drop consecutive duplicates (zero-length segments upset joins)
        keep = np.ones(len(pts), dtype=bool)
        keep[1:] = np.any(np.diff(pts, axis=0) != 0, axis=1)
        pts = pts[keep]
        if closed and len(pts) >= 2 and np.array_equal(pts[0], pts[-1]):
            pts = pts[:-1]
        if len(pts) == 1:
            # zero-length subpath: SVG paints a dot for round / square caps only
            if cap == "round":
                parts.append(Point(pts[0]).buffer(half, quad_segs=16))
            elif cap == "square":
                x, y = pts[0]
                parts.append(box(x - half, y - half, x + half, y + half))
            continue
        if closed and len(pts) >= 3:
            line = LinearRing(pts)
            g = shapely.buffer(line, half, quad_segs=16, join_style=join, mitre_limit=limit)
        else:
            line = LineString(pts)
            g = shapely.buffer(
                line, half, quad_segs=16, cap_style=cap, join_style=join, mitre_limit=limit
            )
        parts.append(_polygonal(g))
    parts = [p for p in parts if not p.is_empty]
    if not parts:
        return Polygon()
    return _polygonal(shapely.union_all(parts))


def _filled(path) -> bool:
    """Whether ``path``'s fill shows (not fully transparent, with a fill of non-zero
    opacity)."""
    st = path.style
    return not st.opacity <= 0 and st.fill is not None and st.fill_opacity > 0


def art_area(paths: Sequence, stroke_scale: float = 1.0) -> shapely.Geometry:
    """The area covered by ``paths`` (valid, polygonal, maybe empty).

    Union over the visible paths of

    * the fill (fill not ``None``, non-zero opacity): every subpath implicitly closed,
      combined with the fill rule — ``evenodd``: symmetric difference of the subpaths;
      ``nonzero``: approximated by nesting (a subpath inside a larger one is a hole
      when the summed orientations of the subpaths containing it, its own included,
      cancel out, e.g. an opposite-orientation inner ring);
    * the stroke (stroke not ``None``, width > 0): each subpath buffered by
      ``stroke_width * stroke_scale / 2`` with the style's line cap / join
      (and miter limit); closed subpaths have no caps; dashes are ignored (the
      stroke counts as solid: its gaps are not space for other art).
    """
    filled = [p for p in paths if _filled(p)]
    polys = iter(_subpath_polygons([q for p in filled for q in p.subpaths],
                                   [_fill_method(p) for p in filled for _ in p.subpaths]))
    parts = []
    for path in paths:
        st = path.style
        if st.opacity <= 0:
            continue
        if _filled(path):
            g = _fill_geometry(path, [next(polys) for _ in path.subpaths])
            if not g.is_empty:
                parts.append(g)
        width = float(st.stroke_width) * float(stroke_scale)
        if st.stroke is not None and st.stroke_opacity > 0 and width > 0:
            g = _stroke_geometry(path, width)
            if not g.is_empty:
                parts.append(g)
    if not parts:
        return Polygon()
    out = shapely.union_all(parts)
    if not out.is_valid:
        out = shapely.make_valid(out)
    out = _polygonal(out)
    if not out.is_valid:  # pragma: no cover - belt and braces
        out = _polygonal(out.buffer(0))
    return out
