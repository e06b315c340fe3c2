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

A skin grows with its mesh, so a copy grown past its planned size ends with a skin wider
than half the gap; :func:`narrow_grown_skins` narrows it back in the rest shape when growth
stops, and :func:`as_built` widens it again for the art's map.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._jit.kernels import parallel_kernel
from ..geometry.mesh import apply_binding, triangle_areas

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


#: a narrowed skin may not take a triangle of its mesh below this share of its rest area
#: (where it would, the triangle's skin vertices narrow half as much, :data:`NARROW_ROUNDS`
#: times at most): the offset of a concave stretch of outline cannot shrink pointwise
NARROW_MIN_AREA = 0.25
NARROW_ROUNDS = 8


def _barycentric(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of ``p`` (n, 2) in the triangles (a, b, c), by the cross
    products of :func:`~repulsionpak.geometry.mesh.triangle_areas` rather than
    :func:`~repulsionpak.geometry.mesh.barycentric`'s dot products: the same coordinates to
    rounding, but the narrowed anchors are what the packings and their recorded numbers
    were measured with, to the last bit."""
    v0, v1, v2 = b - a, c - a, p - a
    d = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / d
    l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / d
    return np.column_stack([1.0 - l1 - l2, l1, l2])


def narrow_grown_skins(model, state) -> int:
    """Narrow the skin of every moving copy grown past its planned size back to the width
    it was built with at that size (half the gap), in its rest shape: the call that ends
    growth (:meth:`~repulsionpak.sim.runner.Simulator.begin_settle`). Returns the number of
    copies whose rest shape it set (narrowed, or back as built).

    Parameters
    ----------
    model : Model
        Changed in place: ``x_rest``, ``rest0``, ``tri_rest``, ``anchor_w`` and
        ``anchor_bary`` of the copies narrowed; ``band_scale`` (N,), each skin vertex's
        band width over its width as built (1: as built), and for each inner vertex in a
        band ``band_near`` (N,), the skin vertex whose band it lies in (-1: none), and
        ``band_share`` (N,), its share of that band's width (:func:`as_built` reads them to
        map the art).
    state : State
        Each copy's growth factor (``growth``) and whether it moves (``moving``).

    Notes
    -----
    A copy's mesh grows as a whole, so its skin, built half a gap wide at the copy's planned
    size (growth ``model.max_growth``), ends wider by the copy's growth past that size: on
    the heart with 30 animals, up to 0.77 gap for an animal grown 1.5×, which keeps its
    neighbours that much farther off than the gap. For a copy at growth g past its planned
    G, each skin vertex's rest offset from its anchor (the nearest art point) is scaled by
    G/g, and an inner vertex lying in the band as built moves with it by its share of the
    band's width there. Where that would fold a triangle (its rest area below
    :data:`NARROW_MIN_AREA` of what it was: the offset of a concave stretch of outline
    cannot shrink pointwise), the triangle's skin vertices narrow half as much, up to
    :data:`NARROW_ROUNDS` times. The springs' rest lengths, the triangles' rest areas, the
    widths :func:`keep_skin_width` keeps and the anchors' barycentric coordinates (the art
    point each skin vertex stands over does not move) follow the new rest shape; the
    settling iterations then pull the skins in. Copies that stopped short of their planned
    size keep their narrower skins: widening them pushed the jam apart (docs/algorithm.md).
    Computed from the rest shape as built (kept on the model at the first call), so a
    second call with the same growth changes nothing. Copies whose rest shape a flow field
    bends (``model.flow``) are left as built.
    """
    m = model
    if m.anchor_tri is None or m.flow is not None:
        return 0
    if m.skins_built is None:
        m.skins_built = (m.x_rest.copy(), m.tri_rest.copy(), m.anchor_w.copy(), m.anchor_bary.copy())
    x0, tri_rest, anchor_w, anchor_bary = m.skins_built
    m.ensure_bands()
    narrowed = 0
    for e in np.flatnonzero(state.moving):
        k_e = min(float(m.max_growth[e]) / float(state.growth[e]), 1.0)
        s, t, ns = int(m.elem_vstart[e]), int(m.elem_vstart[e + 1]), int(m.elem_nskin[e])
        if k_e >= 1.0 - 1e-9 and (m.band_scale[s:s + ns] == 1.0).all():
            continue  # not grown past its planned size, and as built
        skin = np.arange(s, s + ns)
        at = m.anchor_tri[skin]
        if (at < 0).any():
            continue
        corners = m.tris[at] - s  # (the element's own triangles: local indices)
        rest = x0[s:t]
        anchor = apply_binding(rest, corners, np.arange(ns), anchor_bary[skin])
        offset = rest[:ns] - anchor
        width = np.hypot(offset[:, 0], offset[:, 1])
        inner = rest[ns:]
        # each inner vertex's nearest skin vertex and its depth in the band there (0: deeper)
        if len(inner):
            d2 = ((inner[:, None, :] - rest[None, :ns, :]) ** 2).sum(axis=2)
            near = np.argmin(d2, axis=1)
            depth = np.sqrt(d2[np.arange(len(inner)), near])
            share = np.clip(1.0 - depth / np.maximum(width[near], 1e-300), 0.0, 1.0)
        t0, t1 = int(m.tri_ptr[e]), int(m.tri_ptr[e + 1])
        tris = m.tris[t0:t1] - s
        k = np.full(ns, k_e)
        for _ in range(NARROW_ROUNDS):
            new = rest.copy()
            new[:ns] = anchor + k[:, None] * offset
            if len(inner):
                new[ns:] = inner + ((k[near] - 1.0) * share)[:, None] * offset[near]
            areas = triangle_areas(new, tris)
            folded = areas <= NARROW_MIN_AREA * tri_rest[t0:t1]
            if not folded.any():
                break
            v = np.unique(tris[folded].ravel())
            v = v[v < ns]
            k[v] = 1.0 - 0.5 * (1.0 - k[v])
        else:  # no narrowing that keeps every triangle: as built
            k[:] = 1.0
            new = rest.copy()
            areas = tri_rest[t0:t1].copy()
        m.x_rest[s:t] = new
        s0, s1 = int(m.spring_ptr[e]), int(m.spring_ptr[e + 1])
        sp = m.springs[s0:s1] - s
        m.rest0[s0:s1] = np.hypot(*(new[sp[:, 0]] - new[sp[:, 1]]).T)
        m.tri_rest[t0:t1] = areas
        m.anchor_w[skin] = anchor_w[skin] * k
        c = new[corners]
        m.anchor_bary[skin] = _barycentric(anchor, c[:, 0], c[:, 1], c[:, 2])
        m.band_scale[skin] = k
        if len(inner):
            m.band_near[s + ns:t] = np.where(share > 0.0, s + near, -1)
            m.band_share[s + ns:t] = share
        narrowed += 1
    return narrowed


def as_built(model, x: np.ndarray, e: int) -> np.ndarray:
    """Copy ``e``'s vertices ``x`` (its block of the state's positions, sim units) with its
    narrowed band (:func:`narrow_grown_skins`) widened back as it was built: each skin
    vertex at its width as built from its anchor point, each inner vertex in the band back
    by its share of that. The art is bound to the mesh as built, so it is mapped through
    these positions. Returns ``x`` itself when the copy was not narrowed."""
    m = model
    if m.band_scale is None:
        return x
    s, t, ns = int(m.elem_vstart[e]), int(m.elem_vstart[e + 1]), int(m.elem_nskin[e])
    k = m.band_scale[s:s + ns]
    if (k == 1.0).all():
        return x
    skin = np.arange(s, s + ns)
    anchor = apply_binding(x, m.tris[m.anchor_tri[skin]] - s, np.arange(ns), m.anchor_bary[skin])
    band = x[:ns] - anchor  # each skin vertex's band, as narrowed
    out = x.copy()
    out[:ns] = anchor + band / k[:, None]
    near = m.band_near[s + ns:t]
    moved = np.flatnonzero(near >= 0)
    if len(moved):
        i = near[moved] - s
        out[ns + moved] -= ((k[i] - 1.0) / k[i] * m.band_share[s + ns + moved])[:, None] * band[i]
    return out
