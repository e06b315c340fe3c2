"""Uniform neighbour grid rebuilt every step by counting sort (numba)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def cell_of(px, py, ox, oy, inv_c, gx, gy):
    """Cell coordinates of a point, clamped to the grid."""
    cx = int((px - ox) * inv_c)
    cy = int((py - oy) * inv_c)
    if cx < 0:
        cx = 0
    elif cx >= gx:
        cx = gx - 1
    if cy < 0:
        cy = 0
    elif cy >= gy:
        cy = gy - 1
    return cx, cy


@njit(cache=True)
def bin_points(px, py, ox, oy, inv_c, gx, gy, cell_start, order, keys):
    """Counting sort of points into cells.

    Parameters: px, py (K,) coordinates; output ``cell_start`` (gx*gy+1,) and ``order`` (K,):
    the items of cell c are ``order[cell_start[c]:cell_start[c+1]]``. ``keys`` (K,) scratch.
    """
    ncell = gx * gy
    for c in range(ncell + 1):
        cell_start[c] = 0
    for k in range(px.shape[0]):
        cx, cy = cell_of(px[k], py[k], ox, oy, inv_c, gx, gy)
        key = cy * gx + cx
        keys[k] = key
        cell_start[key + 1] += 1
    for c in range(ncell):
        cell_start[c + 1] += cell_start[c]
    # reuse counts as insertion cursors
    for k in range(px.shape[0]):
        key = keys[k]
        order[cell_start[key]] = k
        cell_start[key] += 1
    for c in range(ncell, 0, -1):
        cell_start[c] = cell_start[c - 1]
    cell_start[0] = 0


@njit(cache=True)
def segment_midpoints(x, seg_a, seg_b, mx, my):
    for s in range(seg_a.shape[0]):
        mx[s] = 0.5 * (x[seg_a[s], 0] + x[seg_b[s], 0])
        my[s] = 0.5 * (x[seg_a[s], 1] + x[seg_b[s], 1])


@njit(cache=True)
def triangle_centroids(x, tris, mx, my):
    for t in range(tris.shape[0]):
        mx[t] = (x[tris[t, 0], 0] + x[tris[t, 1], 0] + x[tris[t, 2], 0]) / 3.0
        my[t] = (x[tris[t, 0], 1] + x[tris[t, 1], 1] + x[tris[t, 2], 1]) / 3.0


@njit(cache=True)
def gather_segments(x, seg_a, seg_b, seg_elem, order, out_xy, out_elem):
    """Endpoint coordinates of the segments in cell order: out_xy[k] = (ax, ay, bx, by)."""
    for k in range(order.shape[0]):
        s = order[k]
        out_xy[k, 0] = x[seg_a[s], 0]
        out_xy[k, 1] = x[seg_a[s], 1]
        out_xy[k, 2] = x[seg_b[s], 0]
        out_xy[k, 3] = x[seg_b[s], 1]
        out_elem[k] = seg_elem[s]


@njit(cache=True)
def gather_triangles(x, tris, tri_elem, order, out_xy, out_elem):
    """Corner coordinates of the triangles in cell order: out_xy[k] = (ax, ay, bx, by, cx, cy)."""
    for k in range(order.shape[0]):
        t = order[k]
        for j in range(3):
            out_xy[k, 2 * j] = x[tris[t, j], 0]
            out_xy[k, 2 * j + 1] = x[tris[t, j], 1]
        out_elem[k] = tri_elem[t]


@njit(cache=True)
def longest_edge(x, tris):
    """Length of the longest triangle edge (the triangle grid's cells must not be smaller)."""
    best = 0.0
    for t in range(tris.shape[0]):
        for j in range(3):
            a = tris[t, j]
            b = tris[t, (j + 1) % 3]
            d = (x[a, 0] - x[b, 0]) ** 2 + (x[a, 1] - x[b, 1]) ** 2
            if d > best:
                best = d
    return np.sqrt(best)


class CellList:
    """Items (segments or triangles) binned into a uniform grid by counting sort, with their
    coordinates gathered in cell order so the queries stream through memory. Rebuilt in
    place every step (no per-step allocation).

    Cell c holds the items ``xy[start[c]:start[c+1]]`` (owner element ``elem[...]``); the
    sort is stable, so within a cell the items of one element are contiguous.
    """

    def __init__(self, origin, extent, cell_size, n_items, width):
        self.ox, self.oy = origin
        self.inv_c = 1.0 / cell_size
        self.gx = max(1, int(np.ceil(extent[0] / cell_size)))
        self.gy = max(1, int(np.ceil(extent[1] / cell_size)))
        ncell = self.gx * self.gy
        self.start = np.zeros(ncell + 1, np.int64)
        self.order = np.zeros(n_items, np.int64)
        self.xy = np.zeros((n_items, width))
        self.elem = np.zeros(n_items, np.int32)
        self._mx = np.zeros(n_items)
        self._my = np.zeros(n_items)
        self._keys = np.zeros(n_items, np.int64)  # after a rebuild: each item's cell (read by the corner gather)

    @property
    def params(self):
        return self.ox, self.oy, self.inv_c, self.gx, self.gy


class Grid:
    """The two cell lists of a step: skin segments (repulsion range, the paper's 3×3
    window) and triangles (small cells: only point-in-mesh tests)."""

    def __init__(self, origin, extent, seg_cell, tri_cell, n_segments, n_triangles):
        self.origin, self.extent = origin, extent
        self.segs = CellList(origin, extent, seg_cell, n_segments, 4)
        self.tris = CellList(origin, extent, tri_cell, n_triangles, 6)
        self.base_tri_cell = self.tri_cell = tri_cell

    def fit_triangles(self, x, tris) -> None:
        """Size the triangle cells to the current longest edge (meshes can grow past their
        nominal size; a point-in-triangle test only looks one cell around): base·1.3^k
        with the smallest k >= 0 that fits. A function of the current positions only, so
        a resumed run uses the same cells as the uninterrupted one."""
        need = 1.05 * longest_edge(x, tris)
        k = max(0, int(np.ceil(np.log(max(need, 1e-300) / self.base_tri_cell) / np.log(1.3))))
        cell = self.base_tri_cell * 1.3 ** k
        if cell != self.tri_cell:
            self.tri_cell = cell
            self.tris = CellList(self.origin, self.extent, cell, len(tris), 6)

    def rebuild(self, x, seg_a, seg_b, seg_elem, tris, tri_elem):
        self.rebuild_segments(x, seg_a, seg_b, seg_elem)
        self.rebuild_triangles(x, tris, tri_elem)

    def rebuild_segments(self, x, seg_a, seg_b, seg_elem):
        s = self.segs
        segment_midpoints(x, seg_a, seg_b, s._mx, s._my)
        bin_points(s._mx, s._my, s.ox, s.oy, s.inv_c, s.gx, s.gy, s.start, s.order, s._keys)
        gather_segments(x, seg_a, seg_b, seg_elem, s.order, s.xy, s.elem)

    def rebuild_triangles(self, x, tris, tri_elem):
        t = self.tris
        triangle_centroids(x, tris, t._mx, t._my)
        bin_points(t._mx, t._my, t.ox, t.oy, t.inv_c, t.gx, t.gy, t.start, t.order, t._keys)
        gather_triangles(x, tris, tri_elem, t.order, t.xy, t.elem)
