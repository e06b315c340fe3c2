"""Skins kept wide (beyond the paper): a skin vertex stays outside its art.

A skin is the art offset by about half the gap; two skins touching then leave the gap
between the arts. The mesh is sampled a gap apart, so the band between the art and the
skin is one layer of triangles, and where a neighbour presses hard — at a pointed part,
against a corner — that layer was squashed: at the end of the heart scene's simulation
the art of most animals came within 0.2–0.3 gap of its own skin somewhere (0.55 at rest),
and arts whose skins touched stood 0.4–0.8 gap apart, which the final repair then
resolved by shrinking an element. :func:`keep_skin_width` is a position constraint, like
the bend limit: after every step each skin vertex stands, along its outward normal, at
least ``fraction`` of its rest distance (grown with its element) beyond the nearest point
of its art, which moves with the mesh (its triangle and barycentric coordinates,
:func:`repulsionpak.preprocess.skin_anchors`). A violation is corrected by moving the
skin vertex out and the art's triangle in, weighted so that the element's centre does
not move: pressure on the skin reaches the element as a whole, as a thick skin's would.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._jit.kernels import parallel_kernel

#: the share of a violation corrected per step: half, so that a vertex pressed between
#: its skin constraint and a neighbour's overlap force does not jump back and forth
SKIN_RELAX = 0.5


@njit(cache=True, inline="always")
def _depth(x, i, e, tris, anchor_tri, anchor_bary, ring_sign, elem_vstart, elem_nskin, hypot):
    """How far skin vertex ``i`` (of element ``e``) stands outside its anchor along its
    ring's outward normal (from its two ring neighbours), and that normal; (0, 0, 0) when
    the neighbours coincide. ``hypot``: the tangent's length by ``np.hypot`` (the rest
    widths, as first measured with numpy) rather than the square root of its square."""
    s = elem_vstart[e]
    n = elem_nskin[e]
    j = i - s
    prv = s + (j - 1 + n) % n
    nxt = s + (j + 1) % n
    tx = x[nxt, 0] - x[prv, 0]
    ty = x[nxt, 1] - x[prv, 1]
    ln = np.hypot(tx, ty) if hypot else np.sqrt(tx * tx + ty * ty)
    if ln <= 0.0:
        return 0.0, 0.0, 0.0
    nx = ring_sign[e] * ty / ln
    ny = -ring_sign[e] * tx / ln
    t = anchor_tri[i]
    px = (anchor_bary[i, 0] * x[tris[t, 0], 0] + anchor_bary[i, 1] * x[tris[t, 1], 0]
          + anchor_bary[i, 2] * x[tris[t, 2], 0])
    py = (anchor_bary[i, 0] * x[tris[t, 0], 1] + anchor_bary[i, 1] * x[tris[t, 1], 1]
          + anchor_bary[i, 2] * x[tris[t, 2], 1])
    return (x[i, 0] - px) * nx + (x[i, 1] - py) * ny, nx, ny


@njit(cache=True)
def skin_depths(x, tris, anchor_tri, anchor_bary, ring_sign, vert_elem, elem_vstart, elem_nskin,
                verts, out):
    """:func:`_depth` of each skin vertex in ``verts`` into ``out`` (at least 0): the rest
    widths, measured on the placed meshes."""
    for k in range(verts.shape[0]):
        i = verts[k]
        d, _, _ = _depth(x, i, vert_elem[i], tris, anchor_tri, anchor_bary, ring_sign,
                         elem_vstart, elem_nskin, True)
        out[i] = max(d, 0.0)


@njit(cache=True, inline="always")
def _keep_element(x, e, tris, anchor_tri, anchor_bary, anchor_w, ring_sign, elem_vstart, elem_nskin,
                  grown, fraction, relax):
    """:func:`keep_skin_width` on the skin of element ``e`` (its growth factor ``grown``),
    vertex by vertex; returns the number of vertices corrected."""
    hits = 0
    s = elem_vstart[e]
    for i in range(s, s + elem_nskin[e]):
        t = anchor_tri[i]
        if t < 0:
            continue
        depth, nx, ny = _depth(x, i, e, tris, anchor_tri, anchor_bary, ring_sign, elem_vstart, elem_nskin,
                               False)
        if nx == 0.0 and ny == 0.0:
            continue
        target = fraction * anchor_w[i] * grown
        if depth >= target:
            continue
        a = tris[t, 0]
        b = tris[t, 1]
        c = tris[t, 2]
        # gradient of the constraint: +1 on x_i, −bary on the triangle's corners (x_i may
        # be one of them)
        ci = 1.0
        ca = -anchor_bary[i, 0]
        cb = -anchor_bary[i, 1]
        cc = -anchor_bary[i, 2]
        if a == i:
            ci += ca
            ca = 0.0
        if b == i:
            ci += cb
            cb = 0.0
        if c == i:
            ci += cc
            cc = 0.0
        norm = ci * ci + ca * ca + cb * cb + cc * cc
        if norm <= 1e-12:
            continue
        lam = relax * (target - depth) / norm
        x[i, 0] += lam * ci * nx
        x[i, 1] += lam * ci * ny
        x[a, 0] += lam * ca * nx
        x[a, 1] += lam * ca * ny
        x[b, 0] += lam * cb * nx
        x[b, 1] += lam * cb * ny
        x[c, 0] += lam * cc * nx
        x[c, 1] += lam * cc * ny
        hits += 1
    return hits


@parallel_kernel
def keep_skin_width(x, tris, anchor_tri, anchor_bary, anchor_w, ring_sign, moving,
                    elem_vstart, elem_nskin, growth, fraction, relax):
    """Project every skin vertex of the ``moving`` elements to at least ``fraction`` × its
    rest width (``anchor_w`` × its element's growth) outside its anchor, along the outward
    normal of its skin ring (:func:`_depth`; ``ring_sign`` per element, +1 for a
    counter-clockwise ring). ``relax`` of the violation is corrected per call. Returns the
    number of vertices corrected.

    Notes
    -----
    A correction moves the skin vertex and the corners of its anchor triangle, all of its
    own element, and the next vertex's depth reads them (Gauss–Seidel): the elements are
    independent of each other, the vertices of one are not. So the elements run in
    parallel and each one's skin in vertex order, the order of a serial sweep over all
    skin vertices: the same positions to the bit on any number of threads.
    """
    M = elem_nskin.shape[0]
    fixed = np.zeros(M, np.int64)
    for e in prange(M):
        if moving[e]:
            fixed[e] = _keep_element(x, e, tris, anchor_tri, anchor_bary, anchor_w, ring_sign,
                                     elem_vstart, elem_nskin, growth[e], fraction, relax)
    total = 0
    for e in range(M):  # (a loop: ``ndarray.sum`` would load numba's array maths with the kernel)
        total += fixed[e]
    return total
