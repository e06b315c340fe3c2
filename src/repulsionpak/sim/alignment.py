"""Elongated elements turn parallel to their neighbours and to the container's edge
(beyond the paper).

Thin elements at random orientations jam like spilled matches long before they fill the
container: to pack denser they must lie side by side, which needs room they no longer
have once the jam forms. So while they still have it, every elongated element is turned,
by a torque, towards the mean direction of what surrounds it: the long axes of its
elongated neighbours and the tangent of the container's edge near it. The directions are
*nematic* (a bar turned by 180° is the same bar), so they are averaged as doubled angles.

An element's direction and elongation come from the second moments of its skin vertices
(:func:`skin_axes`): the anisotropy ``a = (λ_max − λ_min) / (λ_max + λ_min)`` is 0 for a
round element and approaches 1 for a line. Only elements whose rest anisotropy exceeds
:data:`ANISOTROPY_START` are turned, fully from :data:`ANISOTROPY_FULL` on; a neighbour
votes with its current anisotropy, so round neighbours have no say.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit.kernels import parallel_kernel
from .forces import _deep, _field_sample

#: rest anisotropy (λ_max − λ_min)/(λ_max + λ_min) of the skin below which an element is
#: not turned (0.4: the outline of a rectangle about 1.8:1)
ANISOTROPY_START = 0.4
#: rest anisotropy from which an element is turned at full strength (0.8: about 4:1)
ANISOTROPY_FULL = 0.8

__all__ = ["ANISOTROPY_FULL", "ANISOTROPY_START", "align_weights", "align_torque", "skin_axes"]


@parallel_kernel
def skin_axes(x, elem_vstart, elem_nskin, theta, aniso, cx, cy, cos2, sin2):
    """Per element: the direction (radians, in (−π/2, π/2]) of the long axis of its skin
    vertices, their anisotropy in [0, 1] and their centroid, written into ``theta``,
    ``aniso``, ``cx``, ``cy`` (M,); ``cos2``, ``sin2`` get cos 2θ and sin 2θ (each
    element's vote, computed once rather than at every vertex that sees it). The
    elements run in parallel, each one's sums in vertex order: the same values on any
    number of threads."""
    for e in prange(elem_vstart.shape[0] - 1):
        a = elem_vstart[e]
        n = elem_nskin[e]
        mx = 0.0
        my = 0.0
        for i in range(a, a + n):
            mx += x[i, 0]
            my += x[i, 1]
        mx /= max(n, 1)
        my /= max(n, 1)
        sxx = 0.0
        syy = 0.0
        sxy = 0.0
        for i in range(a, a + n):
            dx = x[i, 0] - mx
            dy = x[i, 1] - my
            sxx += dx * dx
            syy += dy * dy
            sxy += dx * dy
        tr = sxx + syy
        theta[e] = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
        aniso[e] = np.sqrt((sxx - syy) ** 2 + 4.0 * sxy * sxy) / tr if tr > 0.0 else 0.0
        cx[e] = mx
        cy[e] = my
        cos2[e] = np.cos(2.0 * theta[e])
        sin2[e] = np.sin(2.0 * theta[e])


def align_weights(x_rest: np.ndarray, elem_vstart: np.ndarray, elem_nskin: np.ndarray) -> np.ndarray:
    """How strongly each element (M,) is turned, in [0, 1], from its rest skin's
    anisotropy: 0 below :data:`ANISOTROPY_START`, 1 from :data:`ANISOTROPY_FULL` on."""
    M = len(elem_nskin)
    theta, aniso, cx, cy, cos2, sin2 = (np.zeros(M) for _ in range(6))
    skin_axes(x_rest, elem_vstart, elem_nskin, theta, aniso, cx, cy, cos2, sin2)
    return np.clip((aniso - ANISOTROPY_START) / (ANISOTROPY_FULL - ANISOTROPY_START), 0.0, 1.0)


@parallel_kernel
def align_torque(x, elem_vstart, elem_nskin, moving, weight, theta, aniso, cx, cy, cos2, sin2,
                 nb_count, nb_elem, values, ox, oy, inv_h, edge_reach, k, F):
    """Turn every moving element with ``weight`` > 0 towards the nematic mean of its
    surroundings: the axes ``theta`` of the elements its skin vertices see (``nb_elem``),
    each weighted by that element's ``aniso``, and the edge's tangent at each skin vertex
    within ``edge_reach`` of the container's boundary (signed distance field ``values``),
    weighted 1. The force on a vertex r from the centroid is k·w·c·sin(2Δ)/2 · r⊥/r_rms,
    Δ the turn to the mean direction and c ∈ [0, 1] how much the votes agree: a rotation
    about the centroid, strongest for a far vertex, nothing for a net push. ``cos2``,
    ``sin2``: cos 2θ and sin 2θ of every element (:func:`skin_axes`). The edge is sampled
    only for an element not entirely deeper inside than ``edge_reach``."""
    for e in prange(elem_vstart.shape[0] - 1):
        w = weight[e]
        if w <= 0.0 or not moving[e]:
            continue
        a = elem_vstart[e]
        n = elem_nskin[e]
        sc = 0.0
        ss = 0.0
        total = 0.0
        near_edge = not _deep(x, a, a + n, values, ox, oy, inv_h, edge_reach)
        for i in range(a, a + n):
            for j in range(nb_count[i]):
                f = nb_elem[i, j]
                if f == e:
                    continue
                v = aniso[f]
                sc += v * cos2[f]
                ss += v * sin2[f]
                total += v
            if not near_edge:
                continue
            d, gx, gy = _field_sample(values, ox, oy, inv_h, x[i, 0], x[i, 1])
            if d > -edge_reach:  # the edge's tangent: the normal's doubled angle, turned by π
                phi = np.arctan2(gy, gx)
                sc -= np.cos(2.0 * phi)
                ss -= np.sin(2.0 * phi)
                total += 1.0
        if total <= 0.0:
            continue
        agree = np.sqrt(sc * sc + ss * ss) / total
        delta = 0.5 * np.arctan2(ss, sc) - theta[e]
        s = 0.5 * np.sin(2.0 * delta) * k * w * agree
        b = elem_vstart[e + 1]
        r2 = 0.0
        for i in range(a, b):
            r2 += (x[i, 0] - cx[e]) ** 2 + (x[i, 1] - cy[e]) ** 2
        rr = np.sqrt(r2 / (b - a))
        if rr <= 0.0:
            continue
        s /= rr
        for i in range(a, b):
            F[i, 0] -= s * (x[i, 1] - cy[e])
            F[i, 1] += s * (x[i, 0] - cx[e])
