"""The four forces of sec. 5, one numba kernel each, plus the contact query they share.

Every force kernel has the same shape: ``f(<model arrays>, x, ..., k, F)`` and *adds* its
force into ``F`` (N, 2) for the vertices of non-frozen elements, so each can be switched
off or tested alone. :func:`contact_query` finds, for every skin vertex, whether it lies
inside another element's mesh and the closest point on the skin of every neighbouring
mesh in the 3×3 cell window (sec. 5, "Simulation details").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .grid import cell_of
from .._jit.kernels import parallel_kernel
from .shape import similarity_sums


@njit(cache=True, inline="always")
def _inside_triangle(px, py, ax, ay, bx, by, cx, cy):
    d1 = (px - bx) * (ay - by) - (ax - bx) * (py - by)
    d2 = (px - cx) * (by - cy) - (bx - cx) * (py - cy)
    d3 = (px - ax) * (cy - ay) - (cx - ax) * (py - ay)
    neg = (d1 < 0) or (d2 < 0) or (d3 < 0)
    pos = (d1 > 0) or (d2 > 0) or (d3 > 0)
    return not (neg and pos)


@njit(cache=True, inline="always")
def _inside_skin(x, s0, n, px, py):
    """Whether (px, py) lies inside the closed skin ring of vertices ``s0`` .. ``s0 + n - 1``
    (crossing number: a ray towards +x crosses the ring an odd number of times).

    Notes
    -----
    The count of :func:`repulsionpak.geometry.overlap._inside`, read from the ring's
    consecutive rows of ``x`` (a mesh's skin) instead of a polygon array and its
    next-vertex table, which the simulation does not keep."""
    c = False
    ax = x[s0 + n - 1, 0]
    ay = x[s0 + n - 1, 1]
    for k in range(n):
        bx = x[s0 + k, 0]
        by = x[s0 + k, 1]
        if (ay > py) != (by > py) and px < ax + (py - ay) * (bx - ax) / (by - ay):
            c = not c
        ax = bx
        ay = by
    return c


@njit(cache=True, inline="always")
def _nearest_slot(nb_count, nb_d2, i):
    """The contact slot of vertex ``i``'s nearest neighbouring skin (the first of equals),
    −1 when it has none."""
    best = -1
    for j in range(nb_count[i]):
        if best < 0 or nb_d2[i, j] < nb_d2[i, best]:
            best = j
    return best


@njit(cache=True, inline="always")
def _closest_on_coords(ax, ay, bx, by, px, py):
    """Closest point of segment (a, b) to p: (d², qx, qy, t) with t in [0, 1]."""
    abx = bx - ax
    aby = by - ay
    l2 = abx * abx + aby * aby
    t = 0.0
    if l2 > 0.0:
        t = ((px - ax) * abx + (py - ay) * aby) / l2
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
    qx = ax + t * abx
    qy = ay + t * aby
    return (px - qx) * (px - qx) + (py - qy) * (py - qy), qx, qy, t


@njit(cache=True, inline="always")
def _walk_ring(x, ring, s, px, py, max_hops):
    """From skin segment ``s``, step to the next or previous segment of the same ring while
    that one is closer to (px, py). Returns (d², qx, qy, segment) of the local minimum.
    ``ring`` (S, 4) holds a segment's ends, next and previous segment in one row
    (:func:`ring_table`).

    Once a hop was made, only the segments ahead are tried: the one behind is the one it
    came from, farther than the current one by construction (``ring[ring[s, 2], 3] ==
    s``), so testing it again, as a walk that tries both sides every hop would, cannot
    change the outcome.

    Notes
    -----
    The walk is a chain of dependent loads (segment → its ends → their positions); with
    one row instead of four arrays the full query took ~6 % less time on a jammed
    1,000-element scene, the cheap update ~5 %."""
    best, qx, qy, _ = _closest_on_coords(x[ring[s, 0], 0], x[ring[s, 0], 1], x[ring[s, 1], 0],
                                         x[ring[s, 1], 1], px, py)
    direction = 0  # +1 after a hop to the next segment, -1 after one to the previous
    for _ in range(max_hops):
        if direction >= 0:
            n = ring[s, 2]
            d2, ax, ay, _ = _closest_on_coords(x[ring[n, 0], 0], x[ring[n, 0], 1], x[ring[n, 1], 0],
                                               x[ring[n, 1], 1], px, py)
            if d2 < best:
                best, qx, qy, s = d2, ax, ay, n
                direction = 1
                continue
            if direction > 0:
                break
        n = ring[s, 3]
        d2, ax, ay, _ = _closest_on_coords(x[ring[n, 0], 0], x[ring[n, 0], 1], x[ring[n, 1], 0],
                                           x[ring[n, 1], 1], px, py)
        if d2 >= best:
            break
        best, qx, qy, s = d2, ax, ay, n
        direction = -1
    return best, qx, qy, s


def ring_table(seg_a, seg_b, seg_next, seg_prev) -> np.ndarray:
    """The skin rings as one (S, 4) int64 table: ``[seg_a, seg_b, seg_next, seg_prev]``
    per segment (:func:`_walk_ring`)."""
    return np.ascontiguousarray(np.column_stack([seg_a, seg_b, seg_next, seg_prev]), dtype=np.int64)


@njit(cache=True)
def segment_triangles(seg_a, seg_b, vtri_ptr, vtri, tris):
    """The triangles incident to either end of each skin segment, each once, as their
    corner vertices: segment s has ``corners[ptr[s]:ptr[s+1]]`` ((E, 3) int32; those at
    ``seg_a[s]`` in ``vtri`` order, then the others at ``seg_b[s]``).

    Returns
    -------
    ptr, corners
        The lists of :func:`contact_update`'s point-in-mesh test.
    """
    S = seg_a.shape[0]
    ptr = np.zeros(S + 1, np.int64)
    for s in range(S):
        a = seg_a[s]
        b = seg_b[s]
        k = vtri_ptr[a + 1] - vtri_ptr[a]
        for m in range(vtri_ptr[b], vtri_ptr[b + 1]):
            t = vtri[m]
            if tris[t, 0] != a and tris[t, 1] != a and tris[t, 2] != a:
                k += 1
        ptr[s + 1] = ptr[s] + k
    corners = np.empty((ptr[S], 3), np.int32)
    for s in range(S):
        a = seg_a[s]
        b = seg_b[s]
        k = ptr[s]
        for m in range(vtri_ptr[a], vtri_ptr[a + 1]):
            t = vtri[m]
            for j in range(3):
                corners[k, j] = tris[t, j]
            k += 1
        for m in range(vtri_ptr[b], vtri_ptr[b + 1]):
            t = vtri[m]
            if tris[t, 0] != a and tris[t, 1] != a and tris[t, 2] != a:
                for j in range(3):
                    corners[k, j] = tris[t, j]
                k += 1
    return ptr, corners


@parallel_kernel
def contact_query(x, active, vert_elem,
                  seg_xy, seg_elem, seg_start, seg_order, sox, soy, sinv, sgx, sgy,
                  tri_xy, tri_elem, tri_start, tox, toy, tinv, tgx, tgy,
                  chunk_first, chunk_count, ring,
                  inside, nb_count, nb_elem, nb_d2, nb_q, nb_seg):
    """For each vertex in ``active`` (skin vertices of moving elements):

    * ``inside[i]``: the vertex lies in a triangle of another element (those of its cell
      of the triangle cover, :class:`~repulsionpak.sim.grid.TriangleCover`: ``tri_xy``,
      ``tri_elem``, ``tri_start`` and the grid ``tox``...``tgy``);
    * ``nb_q[i, :nb_count[i]]``: the closest point on the skin of each other element
      having skin in the 3×3 window of the segment cells (``nb_elem``, ``nb_d2`` and the
      segment id ``nb_seg`` alongside). At most ``nb_q.shape[1]`` neighbours are kept
      (the closest win). :func:`contact_update` refreshes these between full queries.

    The segment cells hold *chunks*: chords over ``chunk_count`` consecutive skin
    segments starting at segment ``chunk_first``. The nearest chunk of each neighbour is
    found first, then the exact closest point by walking along that neighbour's skin
    from the matching segment (a few times fewer distance tests than all segments;
    ``ring``: :func:`ring_table`).
    """
    K = nb_q.shape[1]
    for k in prange(active.shape[0]):
        i = active[k]
        e = vert_elem[i]
        px = x[i, 0]
        py = x[i, 1]
        # a vertex already inside a mesh keeps the way out it came in by (see below)
        n_old = nb_count[i] if inside[i] else 0
        old_elem = nb_elem[i, :n_old].copy()
        old_seg = nb_seg[i, :n_old].copy()
        cx, cy = cell_of(px, py, tox, toy, tinv, tgx, tgy)
        c = cy * tgx + cx
        hit = False
        for m in range(tri_start[c], tri_start[c + 1]):
            if tri_elem[m] == e:
                continue
            if _inside_triangle(px, py, tri_xy[m, 0], tri_xy[m, 1], tri_xy[m, 2],
                                tri_xy[m, 3], tri_xy[m, 4], tri_xy[m, 5]):
                hit = True
                break
        inside[i] = hit
        cnt = 0
        cx, cy = cell_of(px, py, sox, soy, sinv, sgx, sgy)
        for yy in range(max(cy - 1, 0), min(cy + 2, sgy)):
            for xx in range(max(cx - 1, 0), min(cx + 2, sgx)):
                c = yy * sgx + xx
                last = -1
                slot = -1
                for m in range(seg_start[c], seg_start[c + 1]):
                    f = seg_elem[m]
                    if f == e:
                        continue
                    d2, qx, qy, t = _closest_on_coords(seg_xy[m, 0], seg_xy[m, 1], seg_xy[m, 2],
                                                       seg_xy[m, 3], px, py)
                    if f != last:  # items of one element are contiguous in a cell
                        last = f
                        slot = -1
                        for j in range(cnt):
                            if nb_elem[i, j] == f:
                                slot = j
                                break
                        if slot < 0:
                            if cnt < K:
                                slot = cnt
                                cnt += 1
                            else:  # full: reuse the farthest slot
                                slot = 0
                                for j in range(1, K):
                                    if nb_d2[i, j] > nb_d2[i, slot]:
                                        slot = j
                                if d2 >= nb_d2[i, slot]:
                                    slot = -2  # ignore this element in this cell
                                    continue
                            nb_elem[i, slot] = f
                            nb_d2[i, slot] = np.inf
                    if slot == -2:
                        continue
                    if d2 < nb_d2[i, slot]:
                        ch = seg_order[m]
                        nb_d2[i, slot] = d2
                        nb_seg[i, slot] = chunk_first[ch] + min(int(t * chunk_count[ch]), chunk_count[ch] - 1)
        # exact closest points: walk along each neighbour's skin from the chunk's segment —
        # or, for a vertex that was inside and still is, from the segment it followed so
        # far. Its point is then the nearest on the side it entered by (contact_update
        # follows it locally between queries), not the globally nearest: past the midline
        # of a thin part that is the far side, and pulling there would complete the
        # crossing (a thin arm across a leg, with no vertex inside once through).
        for j in range(cnt):
            start = nb_seg[i, j]
            if hit:
                for o in range(n_old):
                    if old_elem[o] == nb_elem[i, j]:
                        start = old_seg[o]
                        break
            best, qx, qy, s = _walk_ring(x, ring, start, px, py, 64)
            nb_seg[i, j] = s
            nb_d2[i, j] = best
            nb_q[i, j, 0] = qx
            nb_q[i, j, 1] = qy
        nb_count[i] = cnt


@parallel_kernel
def contact_update(x, active, ring, seg_tri_ptr, seg_tri, elem_vstart, elem_nskin,
                   near2, far2, inside, nb_count, nb_elem, nb_d2, nb_q, nb_seg):
    """Cheap refresh of :func:`contact_query`'s results between full queries.

    Every stored closest point follows its neighbour's skin by walking from the stored
    segment to the adjacent one while that is closer (vertices move at most
    velocity_cap·Δt per step, so a few hops suffice; ``ring``: :func:`ring_table`);
    neighbours farther than sqrt(far2) keep the point of the last full query (their weak
    repulsion barely changes in a few steps). The point-in-mesh test is redone
    only against neighbours whose skin is closer than sqrt(near2) (or any neighbour, for
    a vertex that was inside), and only against the triangles incident to the ends of
    the closest skin segment (``seg_tri[seg_tri_ptr[s]:seg_tri_ptr[s+1]]``, their corner
    vertices: :func:`segment_triangles`): between full queries a vertex moves far less
    than a triangle, so it can only enter a mesh there. A vertex that was inside and is
    not in those triangles may lie deeper (a thin part's triangles span its width): it is
    tested against its nearest neighbour's whole skin ring (``elem_vstart``,
    ``elem_nskin``: :func:`_inside_skin`), so that it does not count as out, and its way
    out, :func:`contact_query`'s entry side, is not lost.

    Notes
    -----
    The triangles at a segment are listed per segment, corners included, so a test reads
    the positions directly: through the vertex → triangles → corners chain of loads (and
    with the triangle on the segment, at both ends, tested twice) the call took about a
    third longer on a jammed 1,000-element scene.

    A mesh's triangles tile the inside of its skin ring, so the deep test reads the ring
    (its skin vertices, consecutive in ``x``) instead of every triangle: late in the
    1,000-element poster 3,895 vertices a step take it, 678 of them still inside, and the
    ring gave the same answer for every one at ~40 % fewer loads (the update 8.9–9.7 →
    6.2–7.0 ms an iteration on two threads). Where a mesh folds over itself the two differ
    (a point under the fold is inside two triangles and, by the crossing number, outside
    the ring); the full query every ``requery_every`` steps tests the triangles.
    """
    for k in prange(active.shape[0]):
        i = active[k]
        px = x[i, 0]
        py = x[i, 1]
        was_inside = inside[i]
        hit = False
        for j in range(nb_count[i]):
            if nb_d2[i, j] > far2:
                continue
            best, qx, qy, s = _walk_ring(x, ring, nb_seg[i, j], px, py, 16)
            nb_seg[i, j] = s
            nb_d2[i, j] = best
            nb_q[i, j, 0] = qx
            nb_q[i, j, 1] = qy
            if hit or (best >= near2 and not was_inside):
                continue
            for m in range(seg_tri_ptr[s], seg_tri_ptr[s + 1]):
                a = seg_tri[m, 0]
                b = seg_tri[m, 1]
                c = seg_tri[m, 2]
                if _inside_triangle(px, py, x[a, 0], x[a, 1], x[b, 0], x[b, 1], x[c, 0], x[c, 1]):
                    hit = True
                    break
        if was_inside and not hit and nb_count[i] > 0:
            f = nb_elem[i, _nearest_slot(nb_count, nb_d2, i)]
            hit = _inside_skin(x, elem_vstart[f], elem_nskin[f], px, py)
        inside[i] = hit


@parallel_kernel
def repulsion_force(x, active, inside, nb_count, nb_q, k_r, soft, F):
    """Eq. 2: F_r = k_r Σ_i u/|u| · 1/(ς + |u|²), u = x − x_i, over neighbouring meshes;
    zero for a vertex inside another mesh."""
    for k in prange(active.shape[0]):
        i = active[k]
        if inside[i]:
            continue
        fx = 0.0
        fy = 0.0
        for j in range(nb_count[i]):
            ux = x[i, 0] - nb_q[i, j, 0]
            uy = x[i, 1] - nb_q[i, j, 1]
            d2 = ux * ux + uy * uy
            d = np.sqrt(d2)
            if d > 1e-12:
                w = 1.0 / (d * (soft + d2))
                fx += ux * w
                fy += uy * w
        F[i, 0] += k_r * fx
        F[i, 1] += k_r * fy


@parallel_kernel
def adhesion_force(x, active, inside, nb_count, nb_d2, nb_q, k_a, reach, F):
    """Beyond the paper: each skin vertex outside every other mesh whose nearest
    neighbouring skin is closer than ``reach`` is drawn toward that skin's closest point
    with the force k_a·(1 − d/reach), d its distance; nothing for a vertex inside another
    mesh or with no neighbour within ``reach``.

    Notes
    -----
    Only the nearest neighbour pulls, so a vertex between two skins is drawn to the closer
    one and the channel between them closes from the narrow side first. The force falls
    to zero at ``reach`` so that it does not jump as a neighbour comes into range, and so
    that a closest point the cheap update leaves as the last full query found it (beyond
    ``sim.far_update``, by default the same 2 gaps) pulls with next to nothing.
    """
    for k in prange(active.shape[0]):
        i = active[k]
        if inside[i] or nb_count[i] == 0:
            continue
        j = _nearest_slot(nb_count, nb_d2, i)
        d2 = nb_d2[i, j]
        if d2 >= reach * reach or d2 <= 1e-24:
            continue
        d = np.sqrt(d2)
        w = k_a * (1.0 - d / reach) / d
        F[i, 0] += (nb_q[i, j, 0] - x[i, 0]) * w
        F[i, 1] += (nb_q[i, j, 1] - x[i, 1]) * w


@parallel_kernel
def overlap_force(x, active, inside, tris, vtri_ptr, vtri, nb_count, nb_d2, nb_q, k_o, F):
    """Eq. 4: F_o = k_o Σ (p_i − x) over the centroids p_i of the triangles incident to x,
    for vertices inside another mesh — plus, beyond the paper, k_o (q − x) towards the
    nearest point q on the neighbouring skin (the way out). Eq. 4 alone only contracts a
    mesh; when two meshes overlap over a wide lens nothing pushed them apart and
    neighbours growing around them could press them through each other."""
    for k in prange(active.shape[0]):
        i = active[k]
        if not inside[i]:
            continue
        fx = 0.0
        fy = 0.0
        for m in range(vtri_ptr[i], vtri_ptr[i + 1]):
            t = vtri[m]
            a = tris[t, 0]
            b = tris[t, 1]
            c = tris[t, 2]
            fx += (x[a, 0] + x[b, 0] + x[c, 0]) / 3.0 - x[i, 0]
            fy += (x[a, 1] + x[b, 1] + x[c, 1]) / 3.0 - x[i, 1]
        best = _nearest_slot(nb_count, nb_d2, i)
        if best >= 0:
            fx += nb_q[i, best, 0] - x[i, 0]
            fy += nb_q[i, best, 1] - x[i, 1]
        F[i, 0] += k_o * fx
        F[i, 1] += k_o * fy


@njit(cache=True, inline="always")
def _spring(x, springs, rest0, g, k_e, F, s):
    a = springs[s, 0]
    b = springs[s, 1]
    ux = x[b, 0] - x[a, 0]
    uy = x[b, 1] - x[a, 1]
    d = np.sqrt(ux * ux + uy * uy)
    if d < 1e-12:
        return
    diff = d - rest0[s] * g
    mag = k_e * diff * abs(diff) / d
    F[a, 0] += mag * ux
    F[a, 1] += mag * uy
    F[b, 0] -= mag * ux
    F[b, 1] -= mag * uy


@parallel_kernel
def edge_force(x, springs, rest0, sp_ptr, growth, moving, k_e, F):
    """Eq. 3: F_e = k_e · u/|u| · s(|u| − ℓ)², u = x_b − x_a, applied +F to x_a and −F
    to x_b; ℓ = rest0 · growth[element] (sec. 6). Element e's springs are
    ``sp_ptr[e]:sp_ptr[e+1]`` (:func:`element_ranges`); elements share no vertex, so
    they run in parallel without write conflicts, each in its serial order."""
    for e in prange(sp_ptr.shape[0] - 1):
        if not moving[e]:
            continue
        for s in range(sp_ptr[e], sp_ptr[e + 1]):
            _spring(x, springs, rest0, growth[e], k_e, F, s)


@njit(cache=True, inline="always")
def _field_sample(values, ox, oy, inv_h, px, py):
    """Bilinear value and gradient of a grid field at (px, py) (clamped to the grid;
    beyond it the value grows with the distance to the grid)."""
    ny, nx = values.shape
    fx = (px - ox) * inv_h
    fy = (py - oy) * inv_h
    extra = 0.0
    cfx = min(max(fx, 0.0), nx - 1.000001)
    cfy = min(max(fy, 0.0), ny - 1.000001)
    if cfx != fx or cfy != fy:
        extra = np.sqrt((fx - cfx) ** 2 + (fy - cfy) ** 2) / inv_h
    i = int(cfx)
    j = int(cfy)
    tx = cfx - i
    ty = cfy - j
    v00 = values[j, i]
    v10 = values[j, i + 1]
    v01 = values[j + 1, i]
    v11 = values[j + 1, i + 1]
    val = (v00 * (1 - tx) + v10 * tx) * (1 - ty) + (v01 * (1 - tx) + v11 * tx) * ty
    gx = ((v10 - v00) * (1 - ty) + (v11 - v01) * ty) * inv_h
    gy = ((v01 - v00) * (1 - tx) + (v11 - v10) * tx) * inv_h
    if extra > 0.0:  # outside the sampled grid: point back towards it
        gx = (cfx - fx) * -1.0
        gy = (cfy - fy) * -1.0
        n = np.sqrt(gx * gx + gy * gy)
        gx /= n
        gy /= n
        val += extra
    return val, gx, gy


#: grid cells added to an element's reach before it counts as deep inside the container
#: (the bilinear samples of the field err by up to ~1.5 cells plus √2 cells each way)
DEEP_CELLS = 8.0


@njit(cache=True, inline="always")
def _deep(x, a, b, values, ox, oy, inv_h, reach):
    """Whether every vertex ``a:b`` is farther inside the container than ``reach`` by the
    field: the sample at their centroid, less their radius about it and
    :data:`DEEP_CELLS` cells of sampling error."""
    cx = 0.0
    cy = 0.0
    for i in range(a, b):
        cx += x[i, 0]
        cy += x[i, 1]
    cx /= b - a
    cy /= b - a
    r2 = 0.0
    for i in range(a, b):
        dx = x[i, 0] - cx
        dy = x[i, 1] - cy
        r2 = max(r2, dx * dx + dy * dy)
    d, _, _ = _field_sample(values, ox, oy, inv_h, cx, cy)
    return d + np.sqrt(r2) + DEEP_CELLS / inv_h + reach < 0.0


@parallel_kernel
def boundary_force(x, elem_vstart, moving, values, ox, oy, inv_h, k_b, F, outside, block_depth, inset):
    """Eq. 5: F_b = k_b (p_b − x) for a vertex outside the container, p_b the closest
    boundary point, from the signed distance field: p_b − x = −sdf · ∇sdf/|∇sdf|, for
    the vertices of the ``moving`` elements (``elem_vstart[e]:elem_vstart[e+1]``).

    ``inset`` moves the boundary the force acts on that far inside the container (0 is
    the paper's rule): skins then rest just inside the boundary instead of just outside,
    so the art never crosses it. ``outside[i]`` is set for vertices more than
    ``block_depth`` outside: they block their element's growth like an overlap does.
    An element deep inside the container (:func:`_deep`, reach max(inset, −block_depth,
    0)) gets neither without sampling the field at its vertices: on a poster of a thousand
    elements that is most of them."""
    reach = max(inset, -block_depth, 0.0)
    for e in prange(elem_vstart.shape[0] - 1):
        if not moving[e]:
            continue
        a = elem_vstart[e]
        b = elem_vstart[e + 1]
        if _deep(x, a, b, values, ox, oy, inv_h, reach):
            for i in range(a, b):
                outside[i] = False
            continue
        for i in range(a, b):
            d, gx, gy = _field_sample(values, ox, oy, inv_h, x[i, 0], x[i, 1])
            outside[i] = d > block_depth
            d += inset
            if d <= 0.0:
                continue
            n = np.sqrt(gx * gx + gy * gy)
            if n < 1e-12:
                continue
            F[i, 0] -= k_b * d * gx / n
            F[i, 1] -= k_b * d * gy / n


@parallel_kernel
def inversion_force(x, tris, tri_ptr, tri_rest, growth, moving, min_fraction, k, F):
    """Beyond the paper (whose sec. 12 notes folded, unaesthetic bends): a triangle whose
    signed area falls below ``min_fraction`` of its (grown) rest area pushes its vertices
    along the gradient of its area, k·(A_min − A)/sqrt(A_rest) each, so meshes do not fold
    over and the art mapped through them stays inside the skin. Element e's triangles
    are ``tri_ptr[e]:tri_ptr[e+1]`` (parallel over elements, like :func:`edge_force`)."""
    for e in prange(tri_ptr.shape[0] - 1):
        if not moving[e]:
            continue
        for t in range(tri_ptr[e], tri_ptr[e + 1]):
            _unfold(x, tris, tri_rest, growth[e], min_fraction, k, F, t)


@njit(cache=True, inline="always")
def _unfold(x, tris, tri_rest, g, min_fraction, k, F, t):
    a = tris[t, 0]
    b = tris[t, 1]
    c = tris[t, 2]
    area = 0.5 * ((x[b, 0] - x[a, 0]) * (x[c, 1] - x[a, 1]) - (x[b, 1] - x[a, 1]) * (x[c, 0] - x[a, 0]))
    rest = tri_rest[t] * g * g
    target = min_fraction * rest
    if area >= target:
        return
    mag = k * (target - area) / np.sqrt(rest)
    # dA/dx_v = 0.5 * perp(x_next - x_prev) for v in (a, b, c) counter-clockwise
    for j in range(3):
        v = tris[t, j]
        p = tris[t, (j + 1) % 3]
        q = tris[t, (j + 2) % 3]
        gx = 0.5 * (x[p, 1] - x[q, 1])
        gy = 0.5 * (x[q, 0] - x[p, 0])
        n = np.sqrt(gx * gx + gy * gy)
        if n > 1e-12:
            F[v, 0] += mag * gx / n
            F[v, 1] += mag * gy / n


@parallel_kernel
def project_inside(x, active_all, values, ox, oy, inv_h, limit):
    """Hard constraint after the Euler step (beyond the paper): a vertex more than
    ``limit`` outside the container is moved back to that distance along the field's
    gradient. The penalty force of Eq. 5 alone lets strongly pushed vertices sit far out."""
    for k in prange(active_all.shape[0]):
        i = active_all[k]
        d, gx, gy = _field_sample(values, ox, oy, inv_h, x[i, 0], x[i, 1])
        if d <= limit:
            continue
        n = np.sqrt(gx * gx + gy * gy)
        if n < 1e-12:
            continue
        x[i, 0] -= (d - limit) * gx / n
        x[i, 1] -= (d - limit) * gy / n


@njit(cache=True)
def mark_corners_near(live_tris, tri_key, tgx, tgy, corner_start, corner_order, cell_mark, corner_mark, stamp):
    """Marks (``corner_mark[k] = stamp``) the reflex corners whose 3×3 triangle-cell
    window holds a live triangle: found from the live triangles' cells (``tri_key``: each
    triangle's cell, from the last rebuild; the corners binned into the same cells:
    ``corner_start``/``corner_order``), each cell visited once (``cell_mark``). A jagged
    container's thousands of corners away from the moving meshes are never looked at.
    Its own kernel, compiled only for containers with many corners (see
    :func:`corner_candidates`)."""
    for j in range(live_tris.shape[0]):
        c = tri_key[live_tris[j]]
        if cell_mark[c] == stamp:
            continue
        cell_mark[c] = stamp
        cy = c // tgx
        cx = c - cy * tgx
        for yy in range(max(cy - 1, 0), min(cy + 2, tgy)):
            for xx in range(max(cx - 1, 0), min(cx + 2, tgx)):
                nc = yy * tgx + xx
                for q in range(corner_start[nc], corner_start[nc + 1]):
                    corner_mark[corner_order[q]] = stamp


@njit(cache=True)
def corner_candidates(corner_key, marked, corner_mark, stamp, tri_elem, frozen, tri_order, tri_start,
                      tgx, tgy, active, cand_ptr, cand):
    """The reflex corners near a moving mesh and their candidate triangles: the
    triangles of non-frozen elements in the 3×3 triangle-cell window of the corner
    (``corner_key``: each corner's triangle cell). The ``n`` corners with any are
    ``active[:n]`` (ascending), corner ``active[j]``'s list is
    ``cand[cand_ptr[j]:cand_ptr[j+1]]``. Returns ``(n, entries needed)``; if the latter
    exceeds ``len(cand)``, the lists are incomplete and the caller must retry with a
    larger ``cand`` (and new marks).

    Gathered at each full neighbour query: a triangle containing a corner has its centroid
    within 2/3 of its longest edge (< 0.64 cell) of it, so the window keeps a third of a
    cell of margin for the few steps until the next query.

    With ``marked``, only the corners :func:`mark_corners_near` marked with ``stamp`` are
    looked at (a container with many corners); without, every corner's window is scanned
    (fewer corners than live triangles). A corner is found by either route exactly when
    its window holds a live triangle, so the lists are those of a scan of every corner
    with frozen triangles left out, in the same order; frozen elements never move, so
    :func:`corner_force` gets the same sums. (The marked corners are taken in one pass
    over the marks, not sorted: numba's sort more than doubled the compile time of this
    kernel, which every first run pays.)"""
    n = 0
    kept = 0
    for k in range(corner_key.shape[0]):
        if marked and corner_mark[k] != stamp:
            continue
        first = n
        gy = corner_key[k] // tgx
        gx = corner_key[k] - gy * tgx
        for yy in range(max(gy - 1, 0), min(gy + 2, tgy)):
            for xx in range(max(gx - 1, 0), min(gx + 2, tgx)):
                c = yy * tgx + xx
                for m in range(tri_start[c], tri_start[c + 1]):
                    t = tri_order[m]
                    if frozen[tri_elem[t]]:
                        continue
                    if n < cand.shape[0]:
                        cand[n] = t
                    n += 1
        if n > first:  # (always, for a marked corner)
            active[kept] = k
            cand_ptr[kept] = first
            kept += 1
    cand_ptr[kept] = n
    return kept, n


@njit(cache=True)
def corner_force(x, corners, active, n_active, cand_ptr, cand, tris, tri_elem, moving, k_b, F):
    """Beyond the paper: the container's reflex corners (pointing into the container, like
    the cleft of a heart) can slip between two skin vertices into a mesh, where no vertex
    is outside. A corner found inside a triangle pushes that triangle off it: its three
    vertices alike, along the corner's bisector into the container (``corners[k, 2:]``),
    by k_b × their mean distance from the corner. (Pushing each vertex away from the
    corner, k_b·(v − c), inflated the triangle around it instead: on a container edged
    with fine teeth, a small mesh holding several corners grew to 160× its area and the
    secondary phase never converged.) Only the corners near a
    moving mesh, ``active[:n_active]``, and their candidate triangles
    (:func:`corner_candidates`) are tested."""
    for j in range(n_active):
        k = active[j]
        cx = corners[k, 0]
        cy = corners[k, 1]
        for m in range(cand_ptr[j], cand_ptr[j + 1]):
            t = cand[m]
            if not moving[tri_elem[t]]:
                continue
            a = tris[t, 0]
            b = tris[t, 1]
            c = tris[t, 2]
            if _inside_triangle(cx, cy, x[a, 0], x[a, 1], x[b, 0], x[b, 1], x[c, 0], x[c, 1]):
                s = 0.0
                for i in range(3):
                    v = tris[t, i]
                    s += math.sqrt((x[v, 0] - cx) ** 2 + (x[v, 1] - cy) ** 2)
                s *= k_b / 3.0
                for i in range(3):
                    v = tris[t, i]
                    F[v, 0] += s * corners[k, 2]
                    F[v, 1] += s * corners[k, 3]


@njit(cache=True)
def outside_distance(x, values, ox, oy, inv_h, out):
    """Signed distance of every vertex to the container boundary (positive outside)."""
    for i in range(x.shape[0]):
        d, gx, gy = _field_sample(values, ox, oy, inv_h, x[i, 0], x[i, 1])
        out[i] = d


@parallel_kernel
def shape_force(x, x_rest, elem_vstart, moving, stiffness, k_s, F):
    """Beyond the paper: shape matching [Müller et al. 2005] as a force. Each moving
    element is pulled towards the best similarity transform (rotation, uniform scale,
    translation; least squares) of its rest shape ``x_rest``: F_i = k_s·stiffness[e]·
    (goal_i − x_i). A similarity costs nothing — elements still move, turn and grow
    freely — but any other deformation is resisted linearly. The quadratic edge springs
    of Eq. 3 barely resist small deformations, and their sum over a mesh lets arms kink
    and rings fold (measured); this term keeps the art recognisable (the distortion the
    evaluation reports is exactly the distance to that best similarity)."""
    for e in prange(elem_vstart.shape[0] - 1):
        if not moving[e]:
            continue
        k = k_s * stiffness[e]
        if k <= 0.0:
            continue
        s = elem_vstart[e]
        t = elem_vstart[e + 1]
        # complex least squares: z ≈ c·w with z = x − centroid, w = rest − centroid
        cx, cy, rx, ry, re, im, ww, _ = similarity_sums(x, x_rest, s, t)
        if ww <= 0.0:
            continue
        re /= ww
        im /= ww
        for i in range(s, t):
            wx = x_rest[i, 0] - rx
            wy = x_rest[i, 1] - ry
            gx = cx + re * wx - im * wy
            gy = cy + im * wx + re * wy
            F[i, 0] += k * (gx - x[i, 0])
            F[i, 1] += k * (gy - x[i, 1])
