"""Thin and degenerate art, the skin around art, and resampled outlines (sec. 4).

The area art covers is :func:`repulsionpak.art_area.art_area`.
"""

from __future__ import annotations

import numpy as np
from numba import njit
import shapely
from shapely.geometry import LinearRing, LineString, MultiPolygon, Point, Polygon, box  # noqa: F401

#: Art whose mean thickness (:func:`relative_thickness`) is below this is degenerate:
#: it encloses (numerically) nothing, e.g. a path whose two arcs retrace each other has
#: a flattened area of float noise (~1e-17). Rejected by :func:`art_area_problem`.
MIN_RELATIVE_THICKNESS = 1e-6
#: Art thinner than this (a 0.1-unit hairline on a 1000-unit drawing) is nearly
#: invisible once packed, and such elements' packings are slow to settle (measured: a
#: 1e-5 hairline ran to max_iterations; a 0.027 line converged). The readers warn.
THIN_RELATIVE_THICKNESS = 1e-4
#: Line art thinner than this (strokes under ~0.6 % of the drawing) packs poorly: copies
#: interlock while they grow, and the verification drops those it cannot separate (an X
#: of two strokes, 10 copies in a circle: none dropped at 2 % and 1 %, 5 of 10 at 0.5 %;
#: docs/algorithm.md "Very thin elements"). The readers say so. The thinnest art of the
#: suites and examples is 0.05 (a lizard, a thin ring).
THIN_LINE_RELATIVE_THICKNESS = 6e-3


def relative_thickness(geom) -> float:
    """Mean thickness ``2·area/perimeter`` of an art area over its bounding-box diagonal
    (dimensionless, scale-invariant): ~1/4 for a disc, w/L for a w × L stroke, 0 when
    empty."""
    if geom is None or geom.is_empty:
        return 0.0
    area, perimeter = float(geom.area), float(geom.length)
    x0, y0, x1, y1 = (float(b) for b in geom.bounds)
    diag = float(np.hypot(x1 - x0, y1 - y0))
    if not (area > 0 and perimeter > 0 and diag > 0):
        return 0.0
    return 2.0 * area / perimeter / diag


def art_area_problem(geom) -> str | None:
    """Why the art area ``geom`` (from :func:`art_area`) cannot be packed, or None.

    Empty or zero area, non-finite, or a :func:`relative_thickness` below
    :data:`MIN_RELATIVE_THICKNESS` (degenerate shapes whose area is rounding noise).
    The message completes "FILE: ...".
    """
    if geom is None or geom.is_empty or not geom.area > 0:
        return ("has no visible area (every shape is unfilled and unstroked, or degenerate); "
                "an element needs a filled or stroked area")
    x0, y0, x1, y1 = (float(b) for b in geom.bounds)
    if not all(np.isfinite([geom.area, geom.length, x0, y0, x1, y1])):
        return "has non-finite coordinates (NaN or infinity)"
    if relative_thickness(geom) < MIN_RELATIVE_THICKNESS:
        return (f"has (almost) zero area: its shapes enclose {float(geom.area):.3g} square units "
                f"in a {x1 - x0:.3g} × {y1 - y0:.3g} bounding box (e.g. a path that retraces "
                "itself, or a zero-width shape); an element needs a filled or stroked area")
    return None


def polygons_of(geom) -> list[Polygon]:
    """The polygons of any geometry (collections flattened, lower dimensions dropped)."""
    if geom is None or geom.is_empty:
        return []
    if isinstance(geom, Polygon):
        return [geom]
    out = []
    for g in getattr(geom, "geoms", []):
        out.extend(polygons_of(g))
    return out


def connect_parts(geom, width: float):
    """Join disjoint polygons into one connected polygon by adding bridges.

    Bridges follow the shortest line between a component and the rest (Kruskal-like:
    repeatedly connect the nearest pair of components); each is at least ``width``
    wide, and as wide as the smaller of the two parts' mean thickness and its own length.
    """
    polys = polygons_of(geom)
    if not polys:
        return Polygon()
    while len(polys) > 1:
        best = None
        for i in range(len(polys)):
            for j in range(i + 1, len(polys)):
                d = polys[i].distance(polys[j])
                if best is None or d < best[0]:
                    best = (d, i, j)
        _, i, j = best
        line = shapely.shortest_line(polys[i], polys[j])
        # at least ``width``; a long bridge as thick as the thinner part it joins (its
        # mean thickness 2·area/perimeter), a short one as thick as it is long: a
        # bridge thinner than a mesh spacing has no vertex inside, and neighbours
        # pressed against it went straight through (two dots two diameters apart:
        # 10 of 20 copies dropped with a half-gap bridge, 1 with this one)
        w = max(width, min(2 * polys[i].area / polys[i].length, 2 * polys[j].area / polys[j].length,
                           line.length))
        bridge = shapely.buffer(line, w / 2, cap_style="round")
        merged = polygons_of(shapely.union_all([polys[i], polys[j], bridge]))
        merged = max(merged, key=lambda g: g.area)
        polys = [p for k, p in enumerate(polys) if k not in (i, j)] + [merged]
    return polys[0]


#: outlines with more vertices than this are simplified before their skin is offset
#: (see :func:`skin_polygon`); the art of the suites and the examples has at most ~550
MAX_SKIN_INPUT_VERTICES = 2000


def skin_polygon(outline, offset: float, detail: float = 0.0) -> Polygon:
    """The skin: ``outline`` offset outward by ``offset`` (round joins), one simple polygon.

    Parts that stay disjoint after the offset are bridged; holes are filled.

    An outline of more than :data:`MAX_SKIN_INPUT_VERTICES` vertices (a traced or noisy
    drawing) is first simplified within ``detail`` and offset by ``offset + detail``, so
    the skin still holds the exact outline ``offset`` away: GEOS's offset of a jagged
    outline grows much faster than its vertex count (20,000 vertices: over a minute and
    7 GB; the skin needs ~1,300)."""
    if offset <= 0:
        raise ValueError("offset must be > 0")
    if detail > 0 and len(shapely.get_coordinates(outline)) > MAX_SKIN_INPUT_VERTICES:
        outline = shapely.simplify(outline, detail)
        offset = offset + detail
    if len(shapely.get_coordinates(outline)) > MAX_SKIN_INPUT_VERTICES:
        grown = _outer_offset(outline, offset)
    else:
        grown = shapely.buffer(outline, offset, join_style="round", quad_segs=8)
    grown = connect_parts(grown, width=offset)
    return Polygon(grown.exterior.coords)


#: consecutive outline vertices offset together by :func:`_outer_offset`
_OFFSET_CHUNK = 8


def _outer_offset(outline, offset: float) -> shapely.Geometry:
    """The outline offset outward by ``offset``, holes filled, in bounded time and memory.

    GEOS offsets a ring as one curve and nodes it against itself: when the offset spans
    hundreds of vertices (a jagged outline whose teeth are deeper than the skin tolerance,
    so simplifying keeps them all), every offset segment crosses hundreds of others and
    the noding grows with their product (a 27,000-vertex sawtooth: 20 s and 3.8 GB; a
    40,000-vertex one was killed at 24 GB). The offset of a ring's region, holes filled,
    is bounded by the offset of the ring itself, which is the union of the offsets of its
    pieces: short runs of consecutive vertices are offset one by one (each crosses only
    itself) and merged by a cascaded union (the 40,000-vertex sawtooth: ~2 CPU s, 150 MB).
    Holes are filled because only the exteriors are offset; the result is the same region
    as ``buffer(...)`` with its holes filled."""
    pieces = []
    for poly in polygons_of(outline):
        ring = np.asarray(poly.exterior.coords)
        n = len(ring) - 1
        starts = range(0, n, _OFFSET_CHUNK)
        pieces.extend(shapely.LineString(ring[i:min(i + _OFFSET_CHUNK, n) + 1]) for i in starts)
    band = shapely.union_all(shapely.buffer(np.array(pieces, dtype=object), offset,
                                            join_style="round", quad_segs=8))
    # the band around each ring is an annulus: its outer boundary is the offset outline
    return shapely.union_all([Polygon(p.exterior) for p in polygons_of(band)])


def resample_closed(ring: np.ndarray, spacing: float, min_points: int = 8) -> np.ndarray:
    """Uniformly resample a closed polyline by arc length.

    Parameters
    ----------
    ring : (K, 2) vertices, without repeated closing point.
    spacing : desired distance between consecutive samples (> 0).

    Returns
    -------
    (M, 2) samples, M = max(min_points, round(perimeter / spacing)), equally spaced along
    the perimeter starting at ``ring[0]``.
    """
    ring = np.asarray(ring, dtype=float)
    if ring.ndim != 2 or ring.shape[1] != 2 or len(ring) < 3:
        raise ValueError("ring must be a (K>=3, 2) array")
    if not spacing > 0:
        raise ValueError("spacing must be > 0")
    closed = np.vstack([ring, ring[:1]])
    seg = np.hypot(*np.diff(closed, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    perimeter = cum[-1]
    m = max(min_points, int(round(perimeter / spacing)))
    t = np.linspace(0.0, perimeter, m, endpoint=False)
    x = np.interp(t, cum, closed[:, 0])
    y = np.interp(t, cum, closed[:, 1])
    return np.column_stack([x, y])


@njit(cache=True)
def _greedy_chords(pts, arc, spacing, tolerance):
    """Indices of the samples kept by :func:`resample_adaptive`: from each kept sample, go
    as far along the dense closed polyline ``pts`` (last = first) as the arc length
    allows while every skipped point stays within ``tolerance`` of the chord segment."""
    n = pts.shape[0] - 1
    keep = [0]
    i = 0
    while True:
        best = i + 1
        j = i + 1
        while j <= n and arc[j] - arc[i] <= spacing:
            ax, ay = pts[i, 0], pts[i, 1]
            abx, aby = pts[j, 0] - ax, pts[j, 1] - ay
            l2 = abx * abx + aby * aby
            ok = True
            if l2 > 0.0:
                for m in range(i + 1, j):
                    t = ((pts[m, 0] - ax) * abx + (pts[m, 1] - ay) * aby) / l2
                    t = min(max(t, 0.0), 1.0)
                    dx = pts[m, 0] - (ax + t * abx)
                    dy = pts[m, 1] - (ay + t * aby)
                    if dx * dx + dy * dy > tolerance * tolerance:
                        ok = False
                        break
            if not ok:
                break
            best = j
            j += 1
        if best >= n:
            break
        keep.append(best)
        i = best
    return np.array(keep, dtype=np.int64)


def resample_adaptive(ring: np.ndarray, spacing: float, tolerance: float, min_points: int = 8) -> np.ndarray:
    """Resample a closed polyline with samples at most ``spacing`` apart (by arc length)
    whose chords stay within ``tolerance`` of the original curve.

    Straight stretches get samples ``spacing`` apart; tight bends (the rounded tips of
    a skin around ears, paws, whiskers) get more, so the resampled skin keeps its offset.
    The first sample is ``ring[0]``. Returns (M, 2), M >= min_points.
    """
    ring = np.asarray(ring, dtype=float)
    if ring.ndim != 2 or ring.shape[1] != 2 or len(ring) < 3:
        raise ValueError("ring must be a (K>=3, 2) array")
    if not (spacing > 0 and tolerance > 0):
        raise ValueError("spacing and tolerance must be > 0")
    closed = np.vstack([ring, ring[:1]])
    seg = np.hypot(*np.diff(closed, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    perimeter = cum[-1]
    step = min(spacing / 4, tolerance)
    m = max(int(np.ceil(perimeter / step)), 4 * min_points)
    t = np.linspace(0.0, perimeter, m, endpoint=False)
    # the ring's corners are candidates too: sampled only around, a corner became two
    # samples a fraction of a step apart on either side of it (an edge 0.05 spacings long
    # beside one a whole spacing long: a triangle on it kept an angle below the mesh's bound)
    corner = _corners(ring, CORNER_TURN)
    if len(corner):
        t = np.union1d(t, cum[corner])
        t = t[t < perimeter]
    dense = np.column_stack([np.interp(t, cum, closed[:, 0]), np.interp(t, cum, closed[:, 1])])
    arc = np.concatenate([t, [perimeter]])
    closed_dense = np.vstack([dense, dense[:1]])
    keep = _greedy_chords(closed_dense, arc, spacing * (1 + 1e-9), tolerance)
    keep = _balance_seam(closed_dense, arc, keep, tolerance, spacing * (1 + 1e-9))
    out = dense[keep]
    if len(out) < min_points:
        return resample_closed(ring, perimeter / min_points, min_points)
    return out


#: a ring vertex turning by more than this (radians) is a corner :func:`resample_adaptive` may sample
CORNER_TURN = np.radians(30.0)


def _corners(ring: np.ndarray, turn: float) -> np.ndarray:
    """Indices of the vertices of the closed ``ring`` where it turns by more than ``turn``."""
    a = ring - np.roll(ring, 1, axis=0)
    b = np.roll(ring, -1, axis=0) - ring
    ang = np.abs(np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(axis=1)))
    return np.flatnonzero(ang > turn)


def _balance_seam(pts: np.ndarray, arc: np.ndarray, keep: np.ndarray, tolerance: float,
                  spacing: float) -> np.ndarray:
    """The greedy pass ends wherever the perimeter runs out, often a sliver of a chord
    before the first sample (a 0.25 edge between 5-unit edges: the mesh's smallest angles
    sat there). Re-place the last sample so the last two chords are as even as the
    tolerance allows, or drop it when one chord can close the ring."""
    if len(keep) < 3:
        return keep
    n = len(pts) - 1
    a, b = int(keep[-2]), int(keep[-1])
    if arc[n] - arc[b] >= 0.5 * (arc[b] - arc[a]):
        return keep
    if len(keep) > 3 and arc[n] - arc[a] <= spacing and _chord_deviation(pts, a, n) <= tolerance:
        return keep[:-1]
    best, best_short = b, arc[n] - arc[b]
    for m in range(a + 1, n):
        short = min(arc[m] - arc[a], arc[n] - arc[m])
        if (short > best_short and _chord_deviation(pts, a, m) <= tolerance
                and _chord_deviation(pts, m, n) <= tolerance):
            best, best_short = m, short
    out = keep.copy()
    out[-1] = best
    return out


def _chord_deviation(pts: np.ndarray, i: int, j: int) -> float:
    """Largest distance of pts[i+1:j] from the segment pts[i]–pts[j]."""
    if j - i < 2:
        return 0.0
    a, ab = pts[i], pts[j] - pts[i]
    p = pts[i + 1:j] - a
    t = np.clip(p @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0)
    return float(np.sqrt(((p - t[:, None] * ab) ** 2).sum(axis=1).max()))


def ring_coords(poly: Polygon) -> np.ndarray:
    """Exterior of ``poly`` as (K, 2) without the repeated closing vertex, counter-clockwise
    in a y-up frame (i.e. positive shoelace area)."""
    ring = np.asarray(poly.exterior.coords)[:-1]
    if signed_area(ring) < 0:
        ring = ring[::-1]
    return np.ascontiguousarray(ring)


def signed_area(ring: np.ndarray) -> float:
    """Shoelace area of a closed polyline (positive when counter-clockwise, y up)."""
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
