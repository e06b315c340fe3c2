"""Designer controls in the simulation: per-element spring stiffness, rotation
limits and rigid bodies, as constraints projected after every Euler step.

Each element's motion is split, by the least-squares similarity (rotation θ, uniform
scale s, translation) from its placed rest shape ``x_rest`` to its current vertices, into
a similarity and a deformation:

* **rotation limits**: θ (relative to the rest shape, which was placed at its start
  angle) is clamped to ``[lo[e], hi[e]]``; an element past a limit is turned back about
  its centroid, and the rotational part of its velocity is removed, so it still slides
  and grows but does not turn any further;
* **rigid**: the vertices are replaced by the similarity of the rest shape (shape
  matching [Müller et al. 2005] with stiffness 1): translation, rotation and growth stay,
  every deformation goes. Collisions still act: they move and turn the whole body.

Elements share no vertex, so the kernel runs element-parallel.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit.kernels import parallel_kernel
from .forces import _spring
from .shape import similarity_sums

TWO_PI = 2.0 * np.pi


@parallel_kernel
def edge_force_stiff(x, springs, rest0, sp_ptr, growth, moving, k_e, stiffness, F):
    """:func:`forces.edge_force` with the constant scaled per element: k_e·stiffness[e]."""
    for e in prange(sp_ptr.shape[0] - 1):
        if not moving[e]:
            continue
        for s in range(sp_ptr[e], sp_ptr[e + 1]):
            _spring(x, springs, rest0, growth[e], k_e * stiffness[e], F, s)


@parallel_kernel
def apply_controls(x, v, x_rest, elem_vstart, moving, rot_on, rot_lo, rot_hi, rigid):
    """Project every moving element with a rotation limit (``rot_on``, range
    [rot_lo, rot_hi] radians relative to its rest shape) or ``rigid`` onto its
    constraint. Returns the number of elements changed."""
    M = elem_vstart.shape[0] - 1
    hit = np.zeros(M, np.int64)
    for e in prange(M):
        if not moving[e] or not (rot_on[e] or rigid[e]):
            continue
        s = elem_vstart[e]
        t = elem_vstart[e + 1]
        n = t - s
        cx, cy, rx, ry, re, im, ww, _ = similarity_sums(x, x_rest, s, t)
        if ww <= 0.0:
            continue
        theta = np.arctan2(im, re)
        scale = np.sqrt(re * re + im * im) / ww
        target = theta
        clamped = False
        if rot_on[e]:
            lo = rot_lo[e]
            hi = rot_hi[e]
            a = theta
            while a < lo:
                a += TWO_PI
            while a >= lo + TWO_PI:
                a -= TWO_PI
            if a > hi:  # outside: to the nearer limit
                clamped = True
                if a - hi < lo + TWO_PI - a:
                    target = theta - (a - hi)
                else:
                    target = theta + (lo + TWO_PI - a)
        if rigid[e]:
            c = scale * np.cos(target)
            sn = scale * np.sin(target)
            for i in range(s, t):
                wx = x_rest[i, 0] - rx
                wy = x_rest[i, 1] - ry
                x[i, 0] = cx + c * wx - sn * wy
                x[i, 1] = cy + sn * wx + c * wy
            hit[e] = 1
        elif clamped:
            d = target - theta
            c = np.cos(d)
            sn = np.sin(d)
            for i in range(s, t):
                zx = x[i, 0] - cx
                zy = x[i, 1] - cy
                x[i, 0] = cx + c * zx - sn * zy
                x[i, 1] = cy + sn * zx + c * zy
            hit[e] = 1
        if clamped or rigid[e]:
            # remove the rotational part of the velocity (about the centroid) at a limit;
            # a rigid body keeps only its similarity motion
            mvx = 0.0
            mvy = 0.0
            for i in range(s, t):
                mvx += v[i, 0]
                mvy += v[i, 1]
            mvx /= n
            mvy /= n
            ang = 0.0
            rr = 0.0
            for i in range(s, t):
                zx = x[i, 0] - cx
                zy = x[i, 1] - cy
                ang += zx * (v[i, 1] - mvy) - zy * (v[i, 0] - mvx)
                rr += zx * zx + zy * zy
            w = ang / rr if rr > 0.0 else 0.0
            if not rigid[e]:
                for i in range(s, t):
                    v[i, 0] += w * (x[i, 1] - cy)
                    v[i, 1] -= w * (x[i, 0] - cx)
            else:  # rigid: translation + rotation (none at a limit) + radial growth only
                if clamped:
                    w = 0.0
                rad = 0.0
                for i in range(s, t):
                    zx = x[i, 0] - cx
                    zy = x[i, 1] - cy
                    rad += zx * (v[i, 0] - mvx) + zy * (v[i, 1] - mvy)
                g = rad / rr if rr > 0.0 else 0.0
                for i in range(s, t):
                    zx = x[i, 0] - cx
                    zy = x[i, 1] - cy
                    v[i, 0] = mvx + g * zx - w * zy
                    v[i, 1] = mvy + g * zy + w * zx
    return hit.sum()
