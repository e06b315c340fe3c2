"""Uniform neighbour grids rebuilt at every full contact query by counting sort (numba)."""

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


@njit(cache=True)
def triangle_bounds(x, tris, bb):
    """Bounding box of every triangle, ``bb[t] = (xmin, ymin, xmax, ymax)``; returns the
    sum of their widths and heights (the caller's measure of the triangles' size)."""
    total = 0.0
    for t in range(tris.shape[0]):
        a = tris[t, 0]
        b = tris[t, 1]
        c = tris[t, 2]
        x0 = min(x[a, 0], x[b, 0], x[c, 0])
        x1 = max(x[a, 0], x[b, 0], x[c, 0])
        y0 = min(x[a, 1], x[b, 1], x[c, 1])
        y1 = max(x[a, 1], x[b, 1], x[c, 1])
        bb[t, 0] = x0
        bb[t, 1] = y0
        bb[t, 2] = x1
        bb[t, 3] = y1
        total += (x1 - x0) + (y1 - y0)
    return total


@njit(cache=True)
def cover_cells(x, tris, tri_elem, bb, margin, ox, oy, inv_c, gx, gy, cell_start, out_xy, out_elem):
    """Bin every triangle into each cell its bounding box (grown by ``margin``) overlaps.

    Parameters
    ----------
    x, tris, tri_elem
        Vertex positions, triangles (T, 3) and their elements.
    bb
        (T, 4) bounding boxes (:func:`triangle_bounds`).
    margin
        How far the boxes are grown each way before binning.
    ox, oy, inv_c, gx, gy
        The grid (as :func:`cell_of`).
    cell_start
        (gx·gy+1,) output: cell c holds the entries ``cell_start[c]:cell_start[c+1]``.
    out_xy, out_elem
        Output, one row per entry: the triangle's corners (ax, ay, bx, by, cx, cy) and
        element, in cell order and within a cell in triangle order.

    Returns
    -------
    int
        The number of entries. If it exceeds ``len(out_xy)``, only ``cell_start`` is
        filled (the counts): the caller must retry with larger outputs.
    """
    ncell = gx * gy
    for c in range(ncell + 1):
        cell_start[c] = 0
    for t in range(tris.shape[0]):
        cx0, cy0 = cell_of(bb[t, 0] - margin, bb[t, 1] - margin, ox, oy, inv_c, gx, gy)
        cx1, cy1 = cell_of(bb[t, 2] + margin, bb[t, 3] + margin, ox, oy, inv_c, gx, gy)
        for cy in range(cy0, cy1 + 1):
            for cx in range(cx0, cx1 + 1):
                cell_start[cy * gx + cx + 1] += 1
    for c in range(ncell):
        cell_start[c + 1] += cell_start[c]
    total = cell_start[ncell]
    if total > out_xy.shape[0]:
        return total
    for t in range(tris.shape[0]):  # counts become insertion cursors, shifted back below
        cx0, cy0 = cell_of(bb[t, 0] - margin, bb[t, 1] - margin, ox, oy, inv_c, gx, gy)
        cx1, cy1 = cell_of(bb[t, 2] + margin, bb[t, 3] + margin, ox, oy, inv_c, gx, gy)
        for cy in range(cy0, cy1 + 1):
            for cx in range(cx0, cx1 + 1):
                c = cy * gx + cx
                k = cell_start[c]
                for j in range(3):
                    out_xy[k, 2 * j] = x[tris[t, j], 0]
                    out_xy[k, 2 * j + 1] = x[tris[t, j], 1]
                out_elem[k] = tri_elem[t]
                cell_start[c] = k + 1
    for c in range(ncell, 0, -1):
        cell_start[c] = cell_start[c - 1]
    cell_start[0] = 0
    return total


class TriangleCover:
    """Triangles binned by bounding box for point-in-mesh tests: every cell a triangle's
    box overlaps holds a copy of its corners, so a point needs only the triangles of its
    own cell (``xy[start[c]:start[c+1]]``, owner element ``elem[...]``).

    Which cells there are does not change which triangles contain a point, so the cell
    size is free: at each rebuild it is twice the triangles' mean box side, rounded up to
    a power of √2 (so the buffers are reallocated only when the meshes' size changes that
    much): about two entries per triangle and thirty triangles per cell.

    Notes
    -----
    The centroid-binned :class:`CellList` must look in a 3×3 window of cells at least as
    wide as the *longest* edge: on a jammed 1,000-element scene one stretched triangle
    (an edge of 29 units, the median 6) made every point test ~950 triangles. Here a long
    triangle only occupies more cells. Between one and four times the mean side, building
    and querying cost about the same in all (~12 ms there); finer cells cost more to build.
    The boxes are grown by a millionth of a cell, so that a point the rounded orientation
    test of :func:`~repulsionpak.sim.forces.contact_query` counts as inside a triangle (on
    an edge, or off it by rounding) is always in one of that triangle's cells.
    """

    #: the most entries per triangle before the cells are made coarser
    MAX_FILL = 16

    def __init__(self, origin, extent, n_triangles):
        self.ox, self.oy = origin
        self.extent = extent
        self.n = n_triangles
        self.cell = 0.0
        self.gx = self.gy = 1
        self.inv_c = 1.0
        self.bb = np.zeros((n_triangles, 4))
        self.start = np.zeros(2, np.int64)
        self.xy = np.zeros((0, 6))
        self.elem = np.zeros(0, np.int32)

    @property
    def params(self):
        return self.ox, self.oy, self.inv_c, self.gx, self.gy

    def _set_cell(self, cell: float) -> None:
        if cell == self.cell:
            return
        self.cell = cell
        self.inv_c = 1.0 / cell
        self.gx = max(1, int(np.ceil(self.extent[0] / cell)))
        self.gy = max(1, int(np.ceil(self.extent[1] / cell)))
        self.start = np.zeros(self.gx * self.gy + 1, np.int64)

    def rebuild(self, x, tris, tri_elem) -> None:
        """Bin the triangles ``tris`` (elements ``tri_elem``) at positions ``x``."""
        n = len(tris)
        total = triangle_bounds(x, tris, self.bb)
        size = total / n if n else 0.0  # twice the mean side
        span = max(self.extent[0], self.extent[1])
        if not (size > 0.0 and np.isfinite(size)):  # none, degenerate or diverged: one cell
            size = span
        # powers of √2; no more cells than ~4 per triangle (tiny triangles in a large container)
        floor = span / np.sqrt(4.0 * max(n, 256))
        k = int(np.ceil(2.0 * np.log2(max(size, floor))))
        while True:
            cell = 2.0 ** (0.5 * k)
            self._set_cell(cell)
            need = cover_cells(x, tris, tri_elem, self.bb, 1e-6 * cell, *self.params, self.start,
                               self.xy, self.elem)
            if need <= len(self.xy):
                return
            if need > self.MAX_FILL * max(n, 1) and cell < span:
                k += 2  # stretched or diverged meshes: coarser cells rather than huge buffers
                continue
            cap = int(need * 1.25) + 64
            self.xy = np.zeros((cap, 6))
            self.elem = np.zeros(cap, np.int32)


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
    """The cell lists of a full contact query: skin segments (repulsion range, the
    paper's 3×3 window), triangles by bounding box (``cover``: the point-in-mesh tests)
    and triangles by centroid (``tris``: the container corners' candidates)."""

    def __init__(self, origin, extent, seg_cell, tri_cell, n_segments, n_triangles):
        self.origin, self.extent = origin, extent
        self.segs = CellList(origin, extent, seg_cell, n_segments, 4)
        self.tris = CellList(origin, extent, tri_cell, n_triangles, 6)
        self.cover = TriangleCover(origin, extent, n_triangles)
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
        self.cover.rebuild(x, tris, tri_elem)

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
