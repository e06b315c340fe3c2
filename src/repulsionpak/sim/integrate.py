"""Explicit Euler with the velocity cap (sec. 5), growth (sec. 6), area fraction (sec. 8)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .._jit.kernels import parallel_kernel
from .forces import _field_sample


@parallel_kernel
def euler_step(x, v, F, active_all, dt, vmax, vert_elem):
    """v += F·Δt; |v| capped at ``vmax`` of the vertex's element (``vert_elem``);
    x += v·Δt — for the vertices in ``active_all``. Returns nothing; NaN shows up in the
    area fraction."""
    for k in prange(active_all.shape[0]):
        i = active_all[k]
        cap = vmax[vert_elem[i]]
        vx = v[i, 0] + F[i, 0] * dt
        vy = v[i, 1] + F[i, 1] * dt
        s = np.sqrt(vx * vx + vy * vy)
        if s > cap:
            vx *= cap / s
            vy *= cap / s
        v[i, 0] = vx
        v[i, 1] = vy
        x[i, 0] += vx * dt
        x[i, 1] += vy * dt


def growth_speed_caps(x_rest, elem_vstart, elem_nskin, velocity_cap, dt, k_growth, headroom):
    """Velocity cap of each element (M,): the paper's ``velocity_cap·Δt``, raised for a
    large element to ``headroom`` times the speed its farthest skin vertex needs to follow
    its growth. Rest lengths grow by k_g·Δt of their placed length per step, so a vertex
    r from the centre of the placed mesh must move k_g·r per unit time; with the paper's
    cap alone, meshes wider than 2·velocity_cap·Δt/k_g (100 units of the 1000-unit frame at
    the defaults: few elements, or a fine gap) lag behind their growing rest lengths,
    ripple under the compression and end up bent and crossed."""
    M = len(elem_nskin)
    out = np.full(M, velocity_cap * dt)
    for e in range(M):
        s, n = int(elem_vstart[e]), int(elem_nskin[e])
        if n == 0:
            continue
        p = x_rest[s:s + n]
        r = float(np.sqrt(((p - p.mean(axis=0)) ** 2).sum(axis=1).max()))
        out[e] = max(out[e], headroom * k_growth * r)
    return out


@njit(cache=True)
def confined_contacts(x, inside, elem_vstart, elem_nskin, moving, one_sided, out):
    """``out`` = ``inside`` (N,), except that the skin vertices of an element pressed from
    one side only are cleared (so :func:`grow` lets it grow): the unit directions from the
    element's skin centroid to its vertices inside other meshes sum to at least
    ``one_sided`` × their number (1: all in one direction; 0.7: within about ±45°).

    Notes
    -----
    The paper stops an element's growth while any of its vertices is inside another mesh.
    In a jam every element touches a neighbour, and an element whose neighbours all press
    from one side (the last row along an empty stretch of the edge) stops growing for
    good although the repulsion would let it step back into the room behind it; the room
    stays empty. Growth blocked only by contacts that surround the element lets it take
    it. Vertices outside the container still stop the growth (``SimParams.outside_block``):
    counting the edge as a one-sided contact too was measured worse on the heart.
    """
    out[:] = inside
    if one_sided <= 0.0:
        return
    for e in range(elem_nskin.shape[0]):
        if not moving[e]:
            continue
        s, n = elem_vstart[e], elem_nskin[e]
        cx = 0.0
        cy = 0.0
        for i in range(s, s + n):
            cx += x[i, 0]
            cy += x[i, 1]
        cx /= n
        cy /= n
        sx = 0.0
        sy = 0.0
        k = 0
        for i in range(s, s + n):
            if inside[i]:
                dx = x[i, 0] - cx
                dy = x[i, 1] - cy
                d = np.sqrt(dx * dx + dy * dy)
                if d > 0.0:
                    sx += dx / d
                    sy += dy / d
                k += 1
        if k > 0 and np.sqrt(sx * sx + sy * sy) >= one_sided * k:
            for i in range(s, s + n):
                out[i] = False


@njit(cache=True)
def deep_contacts(inside, nb_count, nb_d2, depth2, out):
    """``out`` = the vertices of ``inside`` (N,) lying deeper than sqrt(``depth2``) in
    another mesh: farther than that from the nearest point of its skin (``nb_d2``, the way
    out each inside vertex keeps).

    Notes
    -----
    The paper stops an element's growth while any of its vertices is inside another mesh.
    In the jam a grown element's skin touches its neighbours' at a few points most of the
    time, so it stops growing although the rest of it faces room: the heart's 30 animals
    stopped with their meshes covering ~0.75 of it. Let grow the elements whose skins
    only overlap shallowly, and the verification bends the few contacts that end closer
    than the gap floor apart (:mod:`repulsionpak.verify.dents`).
    """
    for i in range(inside.shape[0]):
        if not inside[i]:
            out[i] = False
            continue
        best = np.inf
        for j in range(nb_count[i]):
            best = min(best, nb_d2[i, j])
        out[i] = best > depth2


@njit(cache=True)
def grow(inside, outside, elem_vstart, elem_nskin, moving, n_grow, growth, k_g_dt, allow, max_growth,
         steps=None):
    """Sec. 6: every moving element with no skin vertex inside another mesh grows by
    ``steps[e]`` steps (the paper, and ``steps=None``: 1); growth factor = 1 + n_M·k_g·Δt. Returns the number
    of elements that grew.

    Beyond the paper, a skin vertex outside the container (``outside``) also makes its
    element wait: growth pressure would push border elements through the penalty
    boundary force; and no element grows past ``max_growth`` (its nominal size times a
    margin), so elements that found room early do not dwarf their twins that got stuck
    (relative sizes are kept, sec. 6) and skins keep the width they were built with. An
    element given several steps takes as many as fit under ``max_growth``.
    """
    grew = 0
    if not allow:
        return 0
    for e in range(n_grow.shape[0]):
        if not moving[e]:
            continue
        blocked = False
        for i in range(elem_vstart[e], elem_vstart[e] + elem_nskin[e]):
            if inside[i] or outside[i]:
                blocked = True
                break
        if blocked:
            continue
        k = 1 if steps is None else steps[e]
        while k > 0 and 1.0 + (n_grow[e] + k) * k_g_dt > max_growth[e]:
            k -= 1
        if k == 0:
            continue
        n_grow[e] += k
        grew += 1
        growth[e] = 1.0 + n_grow[e] * k_g_dt
    return grew


@njit(cache=True)
def growth_steps(x, elem_vstart, elem_nskin, moving, nb_count, nb_d2, values, ox, oy, inv_h, clear,
                 fast, growth, until, steps):
    """The growth steps of each element this iteration into ``steps`` (M,): ``fast`` for
    a moving element with room — no neighbouring skin (``nb_d2``, the contacts' squared
    distances) closer than ``clear`` to any of its skin vertices, and every one of them at
    least ``clear`` inside the container (``values``, its signed distance field) — else 1
    (the paper's rate). Returns the number of elements with room.

    Notes
    -----
    The paper grows every element by the same small step until it touches a neighbour,
    so a packing spends its first few thousand iterations growing elements that touch
    nothing. An element with room takes several steps at once; within ``clear`` of a
    neighbour or of the edge it is back at the paper's rate, so contacts form as slowly
    as in the paper and the jam is the same kind of jam. Between full queries the contacts
    refresh every neighbour within ``sim.far_update`` (2 gaps) each step, so a clearance
    below that is judged on current distances, and an element is back at the paper's
    rate and caps before it can reach a neighbour; the every-step point-in-mesh radius
    (``Simulator.near2``) follows the fast growers' caps.
    """
    n_fast = 0
    clear2 = clear * clear
    for e in range(steps.shape[0]):
        steps[e] = 1
        if not moving[e] or fast <= 1 or growth[e] >= until[e]:
            continue
        room = True
        for i in range(elem_vstart[e], elem_vstart[e] + elem_nskin[e]):
            for j in range(nb_count[i]):
                if nb_d2[i, j] < clear2:
                    room = False
                    break
            if not room:
                break
            d, _, _ = _field_sample(values, ox, oy, inv_h, x[i, 0], x[i, 1])
            if d > -clear:
                room = False
                break
        if room:
            steps[e] = fast
            n_fast += 1
    return n_fast


@parallel_kernel
def skin_areas(x, elem_vstart, elem_nskin, moving, out):
    """Area enclosed by each element's skin polygon (shoelace) into ``out`` (M,); returns
    (sum of all areas, sum over the ``moving`` elements).

    Notes
    -----
    The elements' areas are computed in parallel, their sums serially in element order:
    the same totals to the bit on any number of threads (the stopping rule reads them).
    """
    for e in prange(elem_nskin.shape[0]):
        s = elem_vstart[e]
        n = elem_nskin[e]
        acc = 0.0
        for k in range(n):
            a = s + k
            b = s + (k + 1) % n
            acc += x[a, 0] * x[b, 1] - x[b, 0] * x[a, 1]
        out[e] = 0.5 * abs(acc)
    total = 0.0
    total_moving = 0.0
    for e in range(elem_nskin.shape[0]):
        total += out[e]
        if moving[e]:
            total_moving += out[e]
    return total, total_moving


@njit(cache=True)
def window_change(h, n, w):
    """Stopping-rule statistics over the last ``w`` steps of the history ``h[:n]`` (n > w):
    (RMS of the per-step changes, |net change| / w)."""
    acc = 0.0
    for k in range(n - w, n):
        d = h[k] - h[k - 1]
        acc += d * d
    return np.sqrt(acc / w), abs(h[n - 1] - h[n - 1 - w]) / w


@njit(cache=True)
def count_inside(inside, idx):
    c = 0
    for k in range(idx.shape[0]):
        if inside[idx[k]]:
            c += 1
    return c
