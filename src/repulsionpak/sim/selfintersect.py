"""Sec. 7: keep non-neighbouring vertices of one mesh at least ℓ̄/2 apart (relaxation [17])."""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit.kernels import parallel_kernel


@parallel_kernel
def relax_self_intersections(x, elem_vstart, elem_nskin, moving, edge_rest, growth,
                             vnbr_ptr, vnbr, passes, fraction, order):
    """For each moving element: ℓ̄ = the mean rest length of its edge springs at its current
    growth (``edge_rest[e] · growth[e]``, the length its springs pull towards); every pair of
    skin vertices not joined by a spring and closer than fraction·ℓ̄ is pushed apart
    symmetrically to that distance. ``passes`` Gauss–Seidel cycles; pairs are visited in
    the order of a sweep along x (sorted once per cycle), which skips the pairs that are
    too far apart in x to violate the constraint (O(n log n) instead of O(n²) per mesh).

    ℓ̄ is not the mean *current* length: with that, a mesh whose rest shape has skin
    vertices closer than fraction·ℓ̄ across a narrow slit (the turns of a stroked spiral)
    was pushed apart, which stretched its springs, which raised ℓ̄, which pushed it further:
    the mesh grew without bound (a 3-turn spiral 30× its size after 6,000 iterations, the
    run stopped as diverged). Against a fixed ℓ̄ the pushes end where the springs balance them.

    ``order`` (N,) holds, at the skin slots of each element, its skin vertex ids in the
    sweep order of the previous call (``np.arange(N)`` to start); it is re-sorted in place
    by insertion sort, which is linear on the nearly sorted orders of consecutive steps.
    The key is (x, vertex id), so the order never depends on the previous one.
    Returns the number of corrections made.
    """
    M = elem_nskin.shape[0]
    fixes = np.zeros(M, np.int64)
    for e in prange(M):
        if not moving[e] or edge_rest[e] <= 0.0:
            continue
        lim = fraction * edge_rest[e] * growth[e]
        lim2 = lim * lim
        s0 = elem_vstart[e]
        n = elem_nskin[e]
        for _ in range(passes):
            before = fixes[e]
            # sweep along x: only pairs closer than ``lim`` in x can violate the constraint
            for a in range(s0 + 1, s0 + n):
                v = order[a]
                xv = x[v, 0]
                b = a - 1
                while b >= s0 and (x[order[b], 0] > xv or (x[order[b], 0] == xv and order[b] > v)):
                    order[b + 1] = order[b]
                    b -= 1
                order[b + 1] = v
            for a in range(s0, s0 + n):
                p = order[a]
                for b in range(a + 1, s0 + n):
                    q = order[b]
                    dx = x[q, 0] - x[p, 0]
                    if dx > lim:
                        break
                    dy = x[q, 1] - x[p, 1]
                    d2 = dx * dx + dy * dy
                    if d2 >= lim2:
                        continue
                    joined = False
                    for m in range(vnbr_ptr[p], vnbr_ptr[p + 1]):
                        if vnbr[m] == q:
                            joined = True
                            break
                    if joined:
                        continue
                    d = np.sqrt(d2)
                    if d < 1e-12:
                        dx = 1e-6
                        dy = 0.0
                        d = 1e-6
                    push = 0.5 * (lim - d) / d
                    x[p, 0] -= dx * push
                    x[p, 1] -= dy * push
                    x[q, 0] += dx * push
                    x[q, 1] += dy * push
                    fixes[e] += 1
            if fixes[e] == before:  # nothing moved: a further pass would find nothing
                break
    total = 0  # a loop, not fixes.sum(): loading a kernel that calls it imports scipy (0.2 s)
    for e in range(M):
        total += fixes[e]
    return total
