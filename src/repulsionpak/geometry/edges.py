"""Distances to a container's edge at a cost that follows what is near, not the edge's length.

A container read from a detailed logo or map has tens of thousands of boundary vertices
(Simple Icons' Gutenberg mark: 45,000 at a run's flattening), and a plain
``shapely.distance(region.boundary, g)`` compares ``g`` with every one of its segments:
6 ms for one element of art, 0.4 ms for one point. The verification asks that of
every element many times, and the simulation's boundary field of every grid point
near the edge. :class:`Edges` cuts the boundary into short pieces held in an STR tree,
so a query looks at the pieces near it; the answers are the same exact distances.
"""

from __future__ import annotations

import numpy as np
import shapely
from numba import njit

#: segments per indexed piece of the boundary (the tree's leaves)
PIECE = 16


def _lines(lineal) -> list[np.ndarray]:
    """The coordinate arrays of every line (ring) of a lineal geometry."""
    return [shapely.get_coordinates(p) for p in shapely.get_parts(lineal) if not p.is_empty]


class Edges:
    """The boundary of a polygonal region (or a lineal geometry), indexed for exact
    distances and shortest lines.

    Parameters
    ----------
    geom : shapely geometry
        A (Multi)Polygon, whose boundary is indexed, or a (Multi)LineString.
    piece : int
        Segments per indexed piece.

    Notes
    -----
    The distance from a geometry to the boundary is the least of its distances to the
    pieces, so the tree's nearest piece gives it exactly (areal semantics as
    ``shapely.distance``: 0 for a polygon that the boundary crosses or lies inside).
    """

    def __init__(self, geom, piece: int = PIECE):
        pieces, segs = [], []
        #: the indexed lines themselves (the region's boundary)
        self.boundary = geom if shapely.get_dimensions(geom) == 1 else shapely.boundary(geom)
        for xy in _lines(self.boundary):
            if len(xy) < 2:
                continue
            segs.append(np.concatenate([xy[:-1], xy[1:]], axis=1))
            for k in range(0, len(xy) - 1, piece):
                pieces.append(xy[k:k + piece + 1])
        if pieces:
            sizes = np.array([len(q) for q in pieces])
            self.pieces = shapely.linestrings(np.concatenate(pieces), indices=np.repeat(np.arange(len(pieces)), sizes))
        else:
            self.pieces = np.empty(0, object)
        self.tree = shapely.STRtree(self.pieces)
        #: (S, 4) every segment of the boundary: x0, y0, x1, y1
        self.segments = np.ascontiguousarray(np.concatenate(segs) if segs else np.zeros((0, 4)))
        self._buckets: dict[float, tuple] = {}

    def __len__(self) -> int:
        return len(self.segments)

    def distance(self, geoms) -> np.ndarray | float:
        """Exact distance from each geometry to the boundary (a float for one geometry;
        NaN for an empty one or when the boundary is empty)."""
        one = isinstance(geoms, shapely.Geometry)
        arr = np.atleast_1d(np.asarray(geoms, dtype=object))
        out = np.full(len(arr), np.nan)
        if len(arr) and len(self.pieces):
            (src, _), dist = self.tree.query_nearest(arr, return_distance=True, all_matches=False)
            out[src] = dist
        return float(out[0]) if one else out

    def nearest(self, g):
        """The piece of the boundary nearest ``g`` (a LineString), or None."""
        if not len(self.pieces) or g is None or g.is_empty:
            return None
        j = np.atleast_1d(self.tree.query_nearest(g, all_matches=False))
        return self.pieces[int(j[0])] if len(j) else None

    def shortest_line(self, g):
        """``shapely.shortest_line(g, boundary)``: from ``g``'s nearest point to the
        boundary's."""
        near = self.nearest(g)
        return None if near is None else shapely.shortest_line(g, near)

    def distance_xy(self, x: np.ndarray, y: np.ndarray, reach: float) -> np.ndarray:
        """Exact distance from each point (x[i], y[i]) to the boundary, for points
        mostly within ``reach`` of it.

        The segments are binned into square cells ``reach`` wide, and each point looks
        at the 3 × 3 cells around its own, which hold every segment within ``reach`` of it;
        a point that finds none there (farther than ``reach``) asks the tree."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        y = np.ascontiguousarray(y, dtype=np.float64)
        if not len(self.segments):
            return np.full(len(x), np.nan)
        reach = float(reach)
        if reach not in self._buckets:
            self._buckets[reach] = _bin_segments(self.segments, reach)
        if self._buckets[reach] is None:  # long segments across many cells: the tree alone
            return self.distance(shapely.points(x, y))
        ox, oy, gx, gy, start, order = self._buckets[reach]
        d = _segment_distances(x, y, self.segments, ox, oy, reach, gx, gy, start, order)
        far = np.flatnonzero(~(d <= reach))
        if len(far):
            d[far] = self.distance(shapely.points(x[far], y[far]))
        return d


#: the most (segment, cell) entries :func:`_bin_segments` makes (8 bytes each, twice)
MAX_ENTRIES = 10_000_000


def _bin_segments(seg: np.ndarray, cell: float):
    """Segments into square cells of side ``cell`` (each into every cell its bounding box
    meets): the grid's origin and size and a CSR list of segment indices per cell; None
    when that would take more than :data:`MAX_ENTRIES` entries."""
    x0 = np.minimum(seg[:, 0], seg[:, 2])
    x1 = np.maximum(seg[:, 0], seg[:, 2])
    y0 = np.minimum(seg[:, 1], seg[:, 3])
    y1 = np.maximum(seg[:, 1], seg[:, 3])
    ox, oy = float(x0.min()) - cell, float(y0.min()) - cell
    gx = int((x1.max() - ox) // cell) + 2
    gy = int((y1.max() - oy) // cell) + 2
    i0 = ((x0 - ox) // cell).astype(np.int64)
    i1 = ((x1 - ox) // cell).astype(np.int64)
    j0 = ((y0 - oy) // cell).astype(np.int64)
    j1 = ((y1 - oy) // cell).astype(np.int64)
    span = (i1 - i0 + 1) * (j1 - j0 + 1)
    if float(span.sum()) + float(gx) * gy > MAX_ENTRIES:
        return None
    cells = np.empty(int(span.sum()), np.int64)
    owner = np.repeat(np.arange(len(seg)), span)
    _fill_cells(i0, i1, j0, j1, gx, cells)
    order = np.argsort(cells, kind="stable")
    start = np.searchsorted(cells[order], np.arange(gx * gy + 1))
    return ox, oy, gx, gy, start.astype(np.int64), owner[order].astype(np.int64)


@njit(cache=True)
def _fill_cells(i0, i1, j0, j1, gx, cells):
    k = 0
    for s in range(len(i0)):
        for j in range(j0[s], j1[s] + 1):
            for i in range(i0[s], i1[s] + 1):
                cells[k] = j * gx + i
                k += 1


@njit(cache=True)
def _point_to_segment(px, py, ax, ay, bx, by):
    """GEOS's ``Distance::pointToSegment``, operation for operation: the same double as
    ``shapely.distance`` gives."""
    if ax == bx and ay == by:
        return np.sqrt((px - ax) * (px - ax) + (py - ay) * (py - ay))
    len2 = (bx - ax) * (bx - ax) + (by - ay) * (by - ay)
    r = ((px - ax) * (bx - ax) + (py - ay) * (by - ay)) / len2
    if r <= 0.0:
        return np.sqrt((px - ax) * (px - ax) + (py - ay) * (py - ay))
    if r >= 1.0:
        return np.sqrt((px - bx) * (px - bx) + (py - by) * (py - by))
    s = ((ay - py) * (bx - ax) - (ax - px) * (by - ay)) / len2
    return abs(s) * np.sqrt(len2)


@njit(cache=True)
def _segment_distances(x, y, seg, ox, oy, cell, gx, gy, start, order):
    """Distance from each point to the nearest segment in the 3 × 3 cells around it
    (inf when they hold none)."""
    n = len(x)
    out = np.empty(n)
    for p in range(n):
        px = x[p]
        py = y[p]
        ci = int((px - ox) // cell)
        cj = int((py - oy) // cell)
        best = np.inf
        for j in range(max(cj - 1, 0), min(cj + 2, gy)):
            for i in range(max(ci - 1, 0), min(ci + 2, gx)):
                c = j * gx + i
                for k in range(start[c], start[c + 1]):
                    s = order[k]
                    d = _point_to_segment(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3])
                    if d < best:
                        best = d
        out[p] = best
    return out


__all__ = ["Edges", "PIECE"]
