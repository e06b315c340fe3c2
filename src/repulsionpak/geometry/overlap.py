"""Area of the intersection of two polygons under many similarity transforms (numba).

The distortion fit (:func:`repulsionpak.measure.distortion`) searches the rotation,
scale and shift that make a source outline cover a placed copy best: some sixty
evaluations of area(T(A) ∩ B) per copy, with B fixed. A GEOS overlay costs ~0.3 ms
each, most of it the call's set-up; this kernel computes the same area in a few
hundredths of that for the few-hundred-vertex outlines the fit uses.

Green's theorem: the boundary of A ∩ B is the part of ∂A inside B plus the part of ∂B
inside A, so with rings oriented with their region on the left (exteriors
counter-clockwise, holes clockwise)

    area(A ∩ B) = ½ ∮ x dy − y dx  over (∂A ∩ B) ∪ (∂B ∩ A).

Each edge is cut at its crossings with the other polygon's edges (found through a
uniform grid over B's edges, built once) and the pieces inside are summed; whether a
ring starts inside comes from a crossing count, and every crossing toggles it.
Crossings are taken on half-open edges, so a crossing through a shared vertex counts
once. Edges that overlap collinearly (a copy fitting its source exactly, up to
rounding) would leave the crossings to rounding noise: the moving polygon is shifted by
10⁻⁹ of the size, which turns them into parallel edges a clear distance apart and
changes the area by ~10⁻⁹ of it. The fit searches with this kernel and measures its
final value with GEOS.
"""

from __future__ import annotations

import numpy as np
import shapely
from numba import njit

__all__ = ["Rings", "rings_of", "OverlapGrid", "intersection_areas", "nelder_mead_sym",
           "is_cold"]

_NUDGE = 1e-9  #: relative shift of the moving polygon (see :func:`intersection_areas`)


class Rings:
    """A polygonal geometry as oriented rings: ``xy`` (N, 2) the vertices of every ring
    one after the other (no closing repeat), ``nxt[i]`` the index of the vertex after i
    in its ring, ``starts`` the first vertex of each ring; region on the left."""

    __slots__ = ("xy", "nxt", "starts", "area")

    def __init__(self, xy: np.ndarray, nxt: np.ndarray, starts: np.ndarray, area: float):
        self.xy, self.nxt, self.starts, self.area = xy, nxt, starts, area


def rings_of(geom) -> Rings:
    """:class:`Rings` of a Polygon or MultiPolygon (empty parts skipped)."""
    parts = [geom] if geom.geom_type == "Polygon" else list(getattr(geom, "geoms", []))
    xs, nxt, starts = [], [], []
    n = 0
    for p in parts:
        if p.is_empty:
            continue
        p = shapely.orient_polygons(p)  # exterior counter-clockwise, holes clockwise
        for ring in [p.exterior, *p.interiors]:
            c = np.asarray(ring.coords)[:-1]
            if len(c) < 3:
                continue
            k = len(c)
            xs.append(c)
            starts.append(n)
            nxt.append(np.concatenate([np.arange(n + 1, n + k), [n]]))
            n += k
    if not xs:
        return Rings(np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64), 0.0)
    return Rings(np.ascontiguousarray(np.concatenate(xs), dtype=np.float64),
                 np.concatenate(nxt).astype(np.int64), np.asarray(starts, np.int64), float(geom.area))


class OverlapGrid:
    """The fixed polygon B of :func:`intersection_areas` with its edges binned in a
    uniform grid (each edge in every cell its bounding box meets)."""

    __slots__ = ("rings", "x0", "y0", "inv", "gx", "gy", "cell_start", "cell_edges", "nudge")

    def __init__(self, rings: Rings, cells_per_edge: float = 0.5):
        self.rings = rings
        xy = rings.xy
        m = len(xy)
        if m == 0:
            lo, hi = np.zeros(2), np.ones(2)
        else:
            lo, hi = xy.min(axis=0), xy.max(axis=0)
        span = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-12))
        g = int(max(1, min(64, round(np.sqrt(max(m, 1) * cells_per_edge)))))
        self.inv = g / span * (1.0 - 1e-9)
        self.x0, self.y0 = float(lo[0]), float(lo[1])
        self.gx = int(max(1, min(g, np.floor((hi[0] - lo[0]) * self.inv) + 1)))
        self.gy = int(max(1, min(g, np.floor((hi[1] - lo[1]) * self.inv) + 1)))
        # a shift of the moving polygon far below any precision the fit needs but far
        # above rounding: edges of a copy that fits its source exactly would otherwise
        # coincide, and the crossings along coincident edges are rounding noise
        size = float(np.abs(xy).max()) if m else 1.0
        self.nudge = np.array([0.0, 0.0, np.cos(1.0), np.sin(1.0)]) * (_NUDGE * size)
        self.cell_start, self.cell_edges = _bin_edges(xy, rings.nxt, self.x0, self.y0, self.inv,
                                                      self.gx, self.gy)


def _bin_edges(xy, nxt, x0, y0, inv, gx, gy):
    """CSR lists of the edges (i → nxt[i]) meeting each cell of a gx × gy grid: the
    cells of each edge's bounding box, edges in increasing order within a cell."""
    m = len(xy)
    if m == 0:
        return np.zeros(gx * gy + 1, np.int64), np.zeros(0, np.int64)
    a, b = xy, xy[nxt]
    i0 = np.clip(np.floor((np.minimum(a[:, 0], b[:, 0]) - x0) * inv), 0, gx - 1).astype(np.int64)
    i1 = np.clip(np.floor((np.maximum(a[:, 0], b[:, 0]) - x0) * inv), 0, gx - 1).astype(np.int64)
    j0 = np.clip(np.floor((np.minimum(a[:, 1], b[:, 1]) - y0) * inv), 0, gy - 1).astype(np.int64)
    j1 = np.clip(np.floor((np.maximum(a[:, 1], b[:, 1]) - y0) * inv), 0, gy - 1).astype(np.int64)
    wide = i1 - i0 + 1
    cnt = wide * (j1 - j0 + 1)
    first = np.cumsum(cnt) - cnt
    k = np.arange(int(cnt.sum())) - np.repeat(first, cnt)
    w = np.repeat(wide, cnt)
    cell = (np.repeat(j0, cnt) + k // w) * gx + np.repeat(i0, cnt) + k % w
    order = np.argsort(cell, kind="stable")
    start = np.zeros(gx * gy + 1, np.int64)
    start[1:] = np.cumsum(np.bincount(cell, minlength=gx * gy))
    return start, np.repeat(np.arange(m, dtype=np.int64), cnt)[order]


@njit(cache=True, nogil=True, error_model="numpy")
def _inside(px, py, xy, nxt):
    """Even–odd crossing count of the ray from (px, py) towards +x."""
    ins = False
    for e in range(xy.shape[0]):
        f = nxt[e]
        ay, by = xy[e, 1], xy[f, 1]
        if (ay > py) != (by > py):
            xc = xy[e, 0] + (py - ay) * (xy[f, 0] - xy[e, 0]) / (by - ay)
            if xc > px:
                ins = not ins
    return ins


@njit(cache=True, nogil=True, error_model="numpy")
def _inside_grid(px, py, xy, nxt, x0, y0, invx, invy, gx, gy, cstart, cedges):
    """:func:`_inside` through a grid of the edges (CSR ``cstart``/``cedges``, each edge
    in every cell of its bounding box, as :func:`_bin_edges` and :func:`_bin_rows` bin
    them): only the edges binned in the ray's row, right of the point, are tested, and a
    crossing counts once, in the cell its crossing point lies in (clamped to the cells
    its edge was binned in). The crossings are those :func:`_inside` counts, by the same
    arithmetic, so the answer is the same; the cost is one row of the grid instead of
    every edge (a point-in-polygon test per ring: a hundred rings against a hundred
    rings' edges made the fit quadratic in the subpaths of dotted art or lettering)."""
    jf = np.floor((py - y0) * invy)
    if not (jf >= 0.0 and jf < gy):  # no edge straddles the ray's line (NaN: none either)
        return False
    j = int(jf)
    i_f = np.floor((px - x0) * invx) - 1.0  # a cell of slack for rounding at xc ~ px
    if i_f >= gx:
        return False
    i_start = int(i_f) if i_f >= 0.0 else 0
    ins = False
    for i in range(i_start, gx):
        c = j * gx + i
        for mm in range(cstart[c], cstart[c + 1]):
            e = cedges[mm]
            f = nxt[e]
            ay, by = xy[e, 1], xy[f, 1]
            if (ay > py) != (by > py):
                ax, bx = xy[e, 0], xy[f, 0]
                xc = ax + (py - ay) * (bx - ax) / (by - ay)
                if xc > px:
                    lo = min(max(np.floor((min(ax, bx) - x0) * invx), 0.0), gx - 1.0)
                    hi = min(max(np.floor((max(ax, bx) - x0) * invx), 0.0), gx - 1.0)
                    k = min(max(np.floor((xc - x0) * invx), lo), hi)
                    if k == i:
                        ins = not ins
    return ins


#: a fixed polygon with more rings than this has the start of each of its rings tested
#: against the moving polygon through a grid of the moving polygon's rows, built per
#: evaluation (:func:`_bin_rows`); with fewer, every edge is tested (cheaper, same answer)
_ROWS_FROM = 8


@njit(cache=True, nogil=True, error_model="numpy")
def _bin_rows(xy, nxt):
    """The edges of ``xy`` binned in horizontal rows (each edge in every row its
    bounding box meets): (y0, inv, gy, row_start, row_edges) for :func:`_inside_grid`
    with one column (``invx`` 0)."""
    n = xy.shape[0]
    ylo, yhi = np.inf, -np.inf
    for i in range(n):
        ylo = min(ylo, xy[i, 1])
        yhi = max(yhi, xy[i, 1])
    gy = max(1, min(256, int(np.sqrt(n))))
    span = yhi - ylo
    inv = gy / span * (1.0 - 1e-9) if span > 0.0 and np.isfinite(span) else 0.0
    if inv == 0.0:
        gy = 1
    start = np.zeros(gy + 1, np.int64)
    for e in range(n):
        f = nxt[e]
        j0 = min(max(np.floor((min(xy[e, 1], xy[f, 1]) - ylo) * inv), 0.0), gy - 1.0)
        j1 = min(max(np.floor((max(xy[e, 1], xy[f, 1]) - ylo) * inv), 0.0), gy - 1.0)
        for j in range(int(j0), int(j1) + 1):
            start[j + 1] += 1
    for j in range(gy):
        start[j + 1] += start[j]
    cur = start[:-1].copy()
    items = np.empty(start[gy], np.int64)
    for e in range(n):
        f = nxt[e]
        j0 = min(max(np.floor((min(xy[e, 1], xy[f, 1]) - ylo) * inv), 0.0), gy - 1.0)
        j1 = min(max(np.floor((max(xy[e, 1], xy[f, 1]) - ylo) * inv), 0.0), gy - 1.0)
        for j in range(int(j0), int(j1) + 1):
            items[cur[j]] = e
            cur[j] += 1
    return ylo, inv, gy, start, items


@njit(cache=True, nogil=True, error_model="numpy")
def _sort(key, n):
    """Insertion sort of key[:n] in place (n is small: an edge's crossings)."""
    for i in range(1, n):
        k = key[i]
        j = i - 1
        while j >= 0 and key[j] > k:
            key[j + 1] = key[j]
            j -= 1
        key[j + 1] = k


@njit(cache=True, nogil=True, error_model="numpy")
def _inside_pieces(px, py, qx, qy, tbuf, nt, state):
    """The edge p → q cut at the parameters tbuf[:nt] (sorted here), starting inside
    when ``state``: ∑ of x dy − y dx over its pieces inside, and the state at q."""
    _sort(tbuf, nt)
    dx, dy = qx - px, qy - py
    sx, sy = px, py
    total = 0.0
    for k in range(nt):
        xx = px + tbuf[k] * dx
        yy = py + tbuf[k] * dy
        if state:
            total += sx * yy - sy * xx
        sx, sy = xx, yy
        state = not state
    if state:
        total += sx * qy - sy * qx
    return total, state


@njit(cache=True, nogil=True, error_model="numpy")
def _one_area(axy, anxt, astarts, bxy, bnxt, bstarts, x0, y0, inv, gx, gy, cstart, cedges,
              stamp, cr_a, cr_b, cr_u, tbuf):
    """area(A ∩ B) for oriented rings A (moved) and B (binned in the grid). Scratch:
    ``stamp`` (max(n, m)), the crossings' A edge, B edge and parameter along B (``cr_a``,
    ``cr_b``, ``cr_u``), one edge's crossing parameters (``tbuf``). NaN when the scratch
    is too small (many more crossings than vertices)."""
    n = axy.shape[0]
    m = bxy.shape[0]
    if n == 0 or m == 0:
        return 0.0
    for k in range(m):
        stamp[k] = -1
    ncr = 0
    total = 0.0
    # --- edges of A: cut at their crossings with B; sum the pieces inside B
    for r in range(astarts.shape[0]):
        s0 = astarts[r]
        state = _inside_grid(axy[s0, 0], axy[s0, 1], bxy, bnxt, x0, y0, inv, inv, gx, gy, cstart, cedges)
        e = s0
        while True:
            q = anxt[e]
            px, py, qx, qy = axy[e, 0], axy[e, 1], axy[q, 0], axy[q, 1]
            dx, dy = qx - px, qy - py
            i0 = int((min(px, qx) - x0) * inv)
            i1 = int((max(px, qx) - x0) * inv)
            j0 = int((min(py, qy) - y0) * inv)
            j1 = int((max(py, qy) - y0) * inv)
            nt = 0
            if i1 >= 0 and j1 >= 0 and i0 < gx and j0 < gy:
                i0 = max(i0, 0)
                j0 = max(j0, 0)
                i1 = min(i1, gx - 1)
                j1 = min(j1, gy - 1)
                for j in range(j0, j1 + 1):
                    for i in range(i0, i1 + 1):
                        c = j * gx + i
                        for mm in range(cstart[c], cstart[c + 1]):
                            f = cedges[mm]
                            if stamp[f] == e:
                                continue
                            stamp[f] = e
                            g = bnxt[f]
                            cx, cy = bxy[f, 0], bxy[f, 1]
                            ex, ey = bxy[g, 0] - cx, bxy[g, 1] - cy
                            den = dx * ey - dy * ex
                            if den == 0.0:
                                continue
                            wx, wy = cx - px, cy - py
                            t = (wx * ey - wy * ex) / den
                            if t < 0.0 or t >= 1.0:
                                continue
                            u = (wx * dy - wy * dx) / den
                            if u < 0.0 or u >= 1.0:
                                continue
                            if ncr == cr_a.shape[0]:
                                return np.nan  # more crossings than room: let GEOS measure it
                            cr_a[ncr] = e
                            cr_b[ncr] = f
                            cr_u[ncr] = u
                            ncr += 1
                            if nt < tbuf.shape[0]:
                                tbuf[nt] = t
                            nt += 1
            if nt > tbuf.shape[0]:
                return np.nan
            part, state = _inside_pieces(px, py, qx, qy, tbuf, nt, state)
            total += part
            e = q
            if e == s0:
                break
    # --- edges of B: the same crossings, grouped by B's edge; sum the pieces inside A
    for k in range(m):
        stamp[k] = 0
    for k in range(ncr):
        stamp[cr_b[k]] += 1
    # stamp[f]: number of crossings on B's edge f -> offsets (exclusive prefix sums)
    acc = 0
    for f in range(m):
        c = stamp[f]
        stamp[f] = acc
        acc += c
    # a counting sort of the crossings by B's edge
    for k in range(ncr):
        f = cr_b[k]
        cr_a[stamp[f]] = k  # reuse cr_a as the permutation (the A edges are no longer needed)
        stamp[f] += 1
    # stamp[f] is now the end of f's slice
    rows = bstarts.shape[0] > _ROWS_FROM
    if rows:
        ry0, rinv, rgy, rstart, redges = _bin_rows(axy, anxt)
    else:
        ry0, rinv, rgy, rstart, redges = 0.0, 0.0, 1, stamp[:0], stamp[:0]
    for r in range(bstarts.shape[0]):
        s0 = bstarts[r]
        if rows:
            state = _inside_grid(bxy[s0, 0], bxy[s0, 1], axy, anxt, 0.0, ry0, 0.0, rinv, 1, rgy, rstart, redges)
        else:
            state = _inside(bxy[s0, 0], bxy[s0, 1], axy, anxt)
        f = s0
        while True:
            g = bnxt[f]
            end = stamp[f]
            beg = stamp[f - 1] if f > 0 else 0
            nt = end - beg
            if nt > tbuf.shape[0]:
                return np.nan
            for k in range(nt):
                tbuf[k] = cr_u[cr_a[beg + k]]
            part, state = _inside_pieces(bxy[f, 0], bxy[f, 1], bxy[g, 0], bxy[g, 1], tbuf, nt, state)
            total += part
            f = g
            if f == s0:
                break
    return 0.5 * total


@njit(cache=True, nogil=True, error_model="numpy")
def _area_at(q, axy0, anxt, astarts, bxy, bnxt, bstarts, x0, y0, inv, gx, gy, cstart, cedges,
             axy, stamp, cr_a, cr_b, cr_u, tbuf):
    """area(T(A) ∩ B) for T = q = (angle, log scale, dx, dy) about the origin."""
    sc = np.exp(q[1])
    c = np.cos(q[0]) * sc
    s = np.sin(q[0]) * sc
    for i in range(axy0.shape[0]):
        x = axy0[i, 0]
        y = axy0[i, 1]
        axy[i, 0] = c * x - s * y + q[2]
        axy[i, 1] = s * x + c * y + q[3]
    return _one_area(axy, anxt, astarts, bxy, bnxt, bstarts, x0, y0, inv, gx, gy, cstart, cedges,
                     stamp, cr_a, cr_b, cr_u, tbuf)


@njit(cache=True, nogil=True, error_model="numpy")
def _buffers(n, m):
    """Scratch of :func:`_area_at` for n moving and m fixed vertices: the moved vertices,
    the stamps, room for 8 (n + m) + 64 crossings, 256 crossings on one edge."""
    cap = 8 * (n + m) + 64
    return (np.empty((n, 2)), np.empty(max(n, m), np.int64), np.empty(cap, np.int64),
            np.empty(cap, np.int64), np.empty(cap), np.empty(256))


@njit(cache=True, nogil=True, error_model="numpy")
def _many_areas(axy0, anxt, astarts, params, bxy, bnxt, bstarts, x0, y0, inv, gx, gy, cstart, cedges):
    """area(T_k(A) ∩ B) for T_k = params[k] = (angle, log scale, dx, dy) about the origin."""
    axy, stamp, cr_a, cr_b, cr_u, tbuf = _buffers(axy0.shape[0], bxy.shape[0])
    out = np.empty(params.shape[0])
    for k in range(params.shape[0]):
        out[k] = _area_at(params[k], axy0, anxt, astarts, bxy, bnxt, bstarts, x0, y0, inv, gx, gy,
                          cstart, cedges, axy, stamp, cr_a, cr_b, cr_u, tbuf)
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _nelder_mead(p, v, area_a, area_b, nudge, size, tol, max_evals,
                 axy0, anxt, astarts, bxy, bnxt, bstarts, x0, y0, inv, gx, gy, cstart, cedges):
    """:func:`repulsionpak.measure.similarity._nelder_mead` on area(T(A) △ B), step for step,
    without leaving compiled code (scalar loops: numba compiles every array expression
    into a kernel of its own, which took seconds). Returns (parameters, value, ok); ok
    is False when the kernel could not decide an area."""
    axy, stamp, cr_a, cr_b, cr_u, tbuf = _buffers(axy0.shape[0], bxy.shape[0])
    pts = np.empty((5, 4))
    vals = np.empty(5)
    tmp = np.empty((5, 4))
    tv = np.empty(5)
    order = np.empty(5, np.int64)
    centre = np.empty(4)
    cand = np.empty((3, 4))  # reflected, expanded, contracted
    q = np.empty(4)
    for i in range(5):
        for j in range(4):
            pts[i, j] = p[j]
        if i > 0:
            pts[i, i - 1] += size
    vals[0] = v
    evals = 0
    # every area is computed at one place, the loop below: work[:nwork] holds the
    # points to evaluate at each stage
    work = np.empty((4, 4))
    out = np.empty(4)
    ok = True
    stage = 0  # 0: the first simplex, 1: reflect, 2: expand, 3: contract, 4: shrink
    fr = 0.0
    nwork = 4
    for i in range(4):
        for j in range(4):
            work[i, j] = pts[i + 1, j]
    while True:
        for w in range(nwork):  # evaluate
            for j in range(4):
                q[j] = work[w, j] + nudge[j]
            a = _area_at(q, axy0, anxt, astarts, bxy, bnxt, bstarts, x0, y0, inv, gx, gy, cstart, cedges,
                         axy, stamp, cr_a, cr_b, cr_u, tbuf)
            if not np.isfinite(a):
                ok = False
            out[w] = max(area_a * np.exp(2.0 * work[w, 1]) + area_b - 2.0 * a, 0.0)
        evals += nwork
        if not ok:
            break
        if stage == 0 or stage == 4:
            for i in range(4):
                vals[i + 1] = out[i]
        elif stage == 1:
            fr = out[0]
            if fr < vals[0]:
                for j in range(4):
                    cand[1, j] = centre[j] + 2.0 * (centre[j] - pts[4, j])
                    work[0, j] = cand[1, j]
                stage, nwork = 2, 1
                continue
            elif fr < vals[3]:
                for j in range(4):
                    pts[4, j] = cand[0, j]
                vals[4] = fr
            else:
                for j in range(4):
                    far = cand[0, j] if fr < vals[4] else pts[4, j]
                    cand[2, j] = centre[j] + 0.5 * (far - centre[j])
                    work[0, j] = cand[2, j]
                stage, nwork = 3, 1
                continue
        elif stage == 2:
            fe = out[0]
            if fe < fr:
                for j in range(4):
                    pts[4, j] = cand[1, j]
                vals[4] = fe
            else:
                for j in range(4):
                    pts[4, j] = cand[0, j]
                vals[4] = fr
        else:  # stage 3: contracted
            fc = out[0]
            if fc < min(fr, vals[4]):
                for j in range(4):
                    pts[4, j] = cand[2, j]
                vals[4] = fc
            else:  # shrink towards the best
                for i in range(1, 5):
                    for j in range(4):
                        pts[i, j] = pts[0, j] + 0.5 * (pts[i, j] - pts[0, j])
                        work[i - 1, j] = pts[i, j]
                stage, nwork = 4, 4
                continue
        # the next step: order, stop test, reflect
        if evals >= max_evals:
            break
        for i in range(5):  # order by value (a stable insertion sort, as numpy's argsort of 5)
            order[i] = i
        for i in range(1, 5):
            o = order[i]
            j = i - 1
            while j >= 0 and vals[order[j]] > vals[o]:
                order[j + 1] = order[j]
                j -= 1
            order[j + 1] = o
        for i in range(5):
            tv[i] = vals[order[i]]
            for j in range(4):
                tmp[i, j] = pts[order[i], j]
        for i in range(5):
            vals[i] = tv[i]
            for j in range(4):
                pts[i, j] = tmp[i, j]
        spread = 0.0
        for i in range(1, 5):
            for j in range(4):
                spread = max(spread, abs(pts[i, j] - pts[0, j]))
        if spread < tol:
            break
        for j in range(4):
            centre[j] = (((pts[0, j] + pts[1, j]) + pts[2, j]) + pts[3, j]) / 4.0
            cand[0, j] = centre[j] + (centre[j] - pts[4, j])
            work[0, j] = cand[0, j]
        stage, nwork = 1, 1
    k = 0
    for i in range(1, 5):
        if vals[i] < vals[k]:
            k = i
    if vals[k] < v:
        return pts[k].copy(), vals[k], ok
    return p.copy(), v, ok


def nelder_mead_sym(a: Rings, b: "OverlapGrid", p: np.ndarray, v: float, size: float, tol: float,
                    max_evals: int):
    """Nelder–Mead on area(T(a) △ b) from ``p`` (value ``v``), all in compiled code: see
    :func:`repulsionpak.measure.similarity._nelder_mead`. Returns (parameters, value), or None when
    the kernel could not decide an area on the way (the caller then searches with GEOS)."""
    br = b.rings
    q, val, ok = _nelder_mead(np.asarray(p, np.float64), float(v), a.area, br.area, b.nudge, float(size),
                              float(tol), int(max_evals), a.xy, a.nxt, a.starts, br.xy, br.nxt, br.starts,
                              b.x0, b.y0, b.inv, b.gx, b.gy, b.cell_start, b.cell_edges)
    return (q, float(val)) if ok else None


def intersection_areas(a: Rings, b: OverlapGrid, params: np.ndarray) -> np.ndarray:
    """area(T_k(a) ∩ b) for each row ``params[k] = (angle, log_scale, dx, dy)``
    (radians; rotation and scaling about the origin, then the shift). NaN where the
    kernel could not decide (far more crossings than the outlines' vertices)."""
    p = np.atleast_2d(params) + b.nudge
    br = b.rings
    return _many_areas(a.xy, a.nxt, a.starts, p, br.xy, br.nxt, br.starts,
                       b.x0, b.y0, b.inv, b.gx, b.gy, b.cell_start, b.cell_edges)


def is_cold() -> bool:
    """True when numba's disk cache lacks the fit's kernels (the first distortion fit
    compiles them, several seconds); False when that cannot be told."""
    from .._jit.kernels import is_cached  # noqa: PLC0415

    try:
        return not all(is_cached(d) for d in (_nelder_mead, _many_areas))
    except Exception:  # noqa: BLE001  (private numba API)
        return False
