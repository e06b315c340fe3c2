"""Shapes kept (beyond the paper): a limit on how far a mesh may bend.

The shape-matching force (``forces.shape_force``) resists bending everywhere; this
constraint lets a mesh bend freely up to a limit and never further. After every step,
each moving element whose vertices stray from the best similarity transform of its rest
shape by more than ``limit[e]`` (RMS distance over RMS radius) is pulled back onto that
limit — the deviation from the similarity is scaled down, the similarity itself (where
the element is, how it is turned, how big it is) is untouched. The art mapped through
such a mesh is a recognisable copy of its source: the distortion the evaluation reports
(symmetric difference with the best similar copy, over the area) measured ≈ 1.6× this
mesh measure.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._jit.kernels import parallel_kernel


@njit(cache=True, inline="always")
def similarity_sums(x, x_rest, s, t):
    """Sums of the least-squares similarity from ``x_rest[s:t]`` to ``x[s:t]`` (complex
    least squares z ≈ c·w, z = x − centroid, w = rest − centroid): the centroids (cx, cy),
    (rx, ry), Re and Im of Σ conj(w)·z, Σ|w|² and Σ|z|². c = (re + i·im) / ww; shared by
    the shape force, the bend limit and the designer controls."""
    n = t - s
    cx = 0.0
    cy = 0.0
    rx = 0.0
    ry = 0.0
    for i in range(s, t):
        cx += x[i, 0]
        cy += x[i, 1]
        rx += x_rest[i, 0]
        ry += x_rest[i, 1]
    cx /= n
    cy /= n
    rx /= n
    ry /= n
    re = 0.0
    im = 0.0
    ww = 0.0
    zz = 0.0
    for i in range(s, t):
        wx = x_rest[i, 0] - rx
        wy = x_rest[i, 1] - ry
        zx = x[i, 0] - cx
        zy = x[i, 1] - cy
        re += wx * zx + wy * zy
        im += wx * zy - wy * zx
        ww += wx * wx + wy * wy
        zz += zx * zx + zy * zy
    return cx, cy, rx, ry, re, im, ww, zz


#: the share of an element's deviation budget (limit² × its squared RMS radius) that its
#: kept vertices (see :func:`limit_deformation`) may hold; beyond it they are scaled back too
KEEP_SHARE = 0.9


@parallel_kernel
def limit_deformation(x, x_rest, elem_vstart, moving, limit, keep):
    """Project every moving element e onto RMS deviation ≤ ``limit[e]`` × its RMS radius
    from the least-squares similarity of ``x_rest``. Returns the number of elements
    projected.

    Vertices flagged in ``keep`` (the skin vertices inside another mesh) keep their
    deviation, and the others are scaled down by as much more as the limit needs, while
    the kept deviation is at most ``KEEP_SHARE`` of the budget (or what the others cannot
    make up). A larger kept deviation is scaled down to that cap, but never further than
    scaling every vertex alike would, and the others to the rest of the budget: every
    projected element ends exactly on its limit.

    Notes
    -----
    Scaling every deviation alike pulled a dented vertex back into the neighbour that
    dented it after every step, and a pointed part pressed into a neighbour stayed there,
    up to 0.86 gap deep (the heart's animals: deepest vertex p90 0.53 gap with the uniform
    projection, 0.09 with the kept vertices; no limit at all: 0.01) — gap violations the
    final repair then resolved by shrinking.

    The cap is continuous. Scaling every vertex alike once the kept deviation passes its
    share pushes the kept ones back into their neighbours a little every step, and in a
    jam, where contacts hold much of the budget, that ratchet slowly drove the arm of one
    bent S shape across another's (their skins overlapping by 22 % of the smaller after
    2,400 iterations); the repair then dropped one of them.
    """
    M = elem_vstart.shape[0] - 1
    hit = np.zeros(M, np.int64)
    for e in prange(M):
        lim = limit[e]
        if not moving[e] or lim <= 0.0:
            continue
        s = elem_vstart[e]
        t = elem_vstart[e + 1]
        cx, cy, rx, ry, re, im, ww, zz = similarity_sums(x, x_rest, s, t)
        if ww <= 0.0 or zz <= 0.0:
            continue
        re /= ww
        im /= ww
        dev = 0.0
        kept = 0.0  # the share of it the kept vertices hold
        for i in range(s, t):
            wx = x_rest[i, 0] - rx
            wy = x_rest[i, 1] - ry
            dx = x[i, 0] - (cx + re * wx - im * wy)
            dy = x[i, 1] - (cy + im * wx + re * wy)
            dev += dx * dx + dy * dy
            if keep[i]:
                kept += dx * dx + dy * dy
        ratio = np.sqrt(dev / zz)
        if ratio <= lim:
            continue
        target = lim * lim * zz
        f = lim / ratio
        fk = f
        if kept > 0.0:
            free = dev - kept
            # the kept vertices hold up to their share of the budget (more when the others
            # hold too little to make up the rest, and never less than the uniform scaling
            # leaves them); the others give up what the limit needs
            cap = max(KEEP_SHARE * target, target - free, kept * (lim / ratio) ** 2)
            if kept <= cap:
                fk = 1.0
                f = np.sqrt((target - kept) / free)
            else:
                fk = np.sqrt(cap / kept)
                f = np.sqrt((target - cap) / free) if free > 0.0 else 0.0
        for i in range(s, t):
            wx = x_rest[i, 0] - rx
            wy = x_rest[i, 1] - ry
            gx = cx + re * wx - im * wy
            gy = cy + im * wx + re * wy
            g = fk if keep[i] else f
            x[i, 0] = gx + g * (x[i, 0] - gx)
            x[i, 1] = gy + g * (x[i, 1] - gy)
        hit[e] = 1
    total = 0  # a loop, not hit.sum(): loading a kernel that calls it imports scipy (0.2 s)
    for e in range(M):
        total += hit[e]
    return total
