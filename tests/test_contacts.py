"""The contact phase's data structures against plain references: the triangle cover of
the full query, the packed skin rings and per-segment triangle lists of the cheap walk
(:mod:`repulsionpak.sim.contacts`, :mod:`repulsionpak.sim.grid`); and, on the same
jammed scene, the self-intersection relaxation against its first version."""

from __future__ import annotations

import numpy as np
import pytest

from repulsionpak.sim.forces import _walk_ring, contact_update, ring_table, segment_triangles
from repulsionpak.sim.grid import TriangleCover, cell_of

pytestmark = pytest.mark.usefixtures("one_numba_thread")


def _inside_all(p, corners):
    """_inside_triangle of point ``p`` against (T, 3, 2) triangles, vectorised (the same
    arithmetic, so the same answers)."""
    (ax, ay), (bx, by), (cx, cy) = corners[:, 0].T, corners[:, 1].T, corners[:, 2].T
    px, py = p
    d1 = (px - bx) * (ay - by) - (ax - bx) * (py - by)
    d2 = (px - cx) * (by - cy) - (bx - cx) * (py - cy)
    d3 = (px - ax) * (cy - ay) - (cx - ax) * (py - ay)
    neg = (d1 < 0) | (d2 < 0) | (d3 < 0)
    pos = (d1 > 0) | (d2 > 0) | (d3 > 0)
    return ~(neg & pos)


def _jammed(count=9, steps=400):
    """A square of ``count`` library elements grown until they touch, some overlapping."""
    from bench import _square_scene

    sim, model, state, _ = _square_scene(count)
    for _ in range(steps):
        sim.step()
    for _ in range(steps):  # (how soon a vertex ends inside depends on the dynamics)
        if state.inside[state.active_skin].any():
            break
        sim.step()
    assert state.inside[state.active_skin].any()
    return sim, model, state


@pytest.fixture(scope="module")
def jammed():
    return _jammed()


def test_triangle_cover_lists_every_triangle_in_the_cell_of_every_point_it_holds():
    """Points inside, on the edges and at the corners of triangles of all sizes (one
    long sliver among them): the point's cell of the cover holds every triangle the
    orientation test counts it in."""
    rng = np.random.default_rng(7)
    n = 300
    centre = rng.uniform(5, 95, (n, 1, 2))
    corners = centre + rng.normal(0, 2.0, (n, 3, 2))
    corners[0] = [[3.0, 3.0], [96.0, 60.0], [4.0, 3.5]]  # a sliver across the grid
    x = corners.reshape(-1, 2).copy()
    tris = np.arange(3 * n, dtype=np.int32).reshape(n, 3)
    elem = np.arange(n, dtype=np.int32)  # one element per triangle: elem names the triangle
    cover = TriangleCover((0.0, 0.0), (100.0, 100.0), n)
    cover.rebuild(x, tris, elem)
    assert 0 < cover.cell < 100.0
    w = rng.dirichlet(np.ones(3), (n, 4))  # 4 points inside each triangle
    pts = [np.einsum("tkc,tcd->tkd", w, corners).reshape(-1, 2), x,
           0.5 * (corners[:, 0] + corners[:, 1]), rng.uniform(0, 100, (2000, 2))]
    pts = np.concatenate(pts)
    tested = 0
    for p in pts:
        holders = set(np.flatnonzero(_inside_all(p, corners)).tolist())
        cx, cy = cell_of(p[0], p[1], *cover.params)
        c = cy * cover.gx + cx
        listed = cover.elem[cover.start[c]:cover.start[c + 1]]
        assert holders <= set(listed.tolist())
        for m in range(cover.start[c], cover.start[c + 1]):  # the rows carry their corners
            np.testing.assert_array_equal(cover.xy[m].reshape(3, 2), corners[cover.elem[m]])
        tested += len(holders)
    assert tested > 4 * n


def test_triangle_cover_survives_diverged_positions():
    x = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [np.nan, 0.0], [1.0, np.inf], [2.0, 2.0]])
    cover = TriangleCover((0.0, 0.0), (10.0, 10.0), 2)
    cover.rebuild(x, np.array([[0, 1, 2], [3, 4, 5]], np.int32), np.array([0, 1], np.int32))
    assert cover.start[-1] >= 2


def test_full_query_inside_is_the_point_in_mesh_test_over_all_triangles(jammed):
    """On a jammed state with a stretched triangle, ``inside`` after a full query is
    exactly: the vertex lies in a triangle of another element (by the same orientation
    test, over every triangle)."""
    sim, model, state = jammed
    x = state.x
    keep = x.copy()
    t0 = model.tris[0]  # stretch one triangle: its corner pulled far across the scene
    x[t0[0]] += 0.25 * np.asarray(model.grid_extent)
    try:
        sim.update_contacts(True)
        corners = x[model.tris]
        n_in = 0
        for i in state.active_skin:
            other = model.tri_elem != model.vert_elem[i]
            expect = bool(_inside_all(x[i], corners[other]).any())
            assert state.inside[i] == expect, i
            n_in += expect
        assert n_in > 0
    finally:  # (the module's other tests start from the jammed state)
        x[:] = keep
        sim.update_contacts(True)


def test_segment_triangles_are_those_at_either_end_once(jammed):
    _, model, _ = jammed
    s = model.skin
    ptr, corners = segment_triangles(s.seg_a, s.seg_b, model.vtri_ptr, model.vtri, model.tris)
    vt = [set(model.vtri[model.vtri_ptr[v]:model.vtri_ptr[v + 1]].tolist()) for v in range(model.n_vertices)]
    for k in range(len(s.seg_a)):
        want = sorted(tuple(model.tris[t]) for t in vt[s.seg_a[k]] | vt[s.seg_b[k]])
        got = sorted(tuple(c) for c in corners[ptr[k]:ptr[k + 1]])
        assert got == want


def _reference_update(x, active, seg_a, seg_b, seg_next, seg_prev, tris, vtri_ptr, vtri, tri_ptr, near2, far2,
                      inside, nb_count, nb_elem, nb_d2, nb_q, nb_seg):
    """The cheap contact update as first written: the triangles at each end of the
    closest segment through the vertex → triangle lists, and a vertex that was inside
    and is not there tested against every triangle of its nearest neighbour (the walk
    itself is checked against one trying both sides every hop in test_forces). Returns
    how many vertices took that last test and how many it found inside."""
    ring = ring_table(seg_a, seg_b, seg_next, seg_prev)
    deep = deep_hits = 0
    for i in active:
        px, py = x[i]
        was_inside = inside[i]
        hit = False
        for j in range(nb_count[i]):
            if nb_d2[i, j] > far2:
                continue
            best, qx, qy, s = _walk_ring(x, ring, nb_seg[i, j], px, py, 16)
            nb_seg[i, j], nb_d2[i, j], nb_q[i, j] = s, best, (qx, qy)
            if hit or (best >= near2 and not was_inside):
                continue
            for v in (seg_a[s], seg_b[s]):
                ts = vtri[vtri_ptr[v]:vtri_ptr[v + 1]]
                if _inside_all((px, py), x[tris[ts]]).any():
                    hit = True
                    break
        if was_inside and not hit and nb_count[i] > 0:
            f = nb_elem[i, int(np.argmin(nb_d2[i, :nb_count[i]]))]
            hit = bool(_inside_all((px, py), x[tris[tri_ptr[f]:tri_ptr[f + 1]]]).any())
            deep += 1
            deep_hits += hit
        inside[i] = hit
    return deep, deep_hits


@pytest.mark.parametrize("noise", [0.05, 0.4])
def test_contact_update_gives_the_arrays_of_the_first_version(jammed, noise):
    """From a full query on a jammed state, a few steps' motion later: the same contact
    arrays, bit for bit, as the update through the separate ring and triangle lists, whose
    test of a vertex that left the triangles at its entry against every triangle of the
    neighbour the update makes on the neighbour's skin ring (unfolded meshes: the same).
    ``noise``: the motion, × gap (at 0.4 some vertices are found deeper in a neighbour)."""
    sim, model, state = jammed
    sim.update_contacts(True)
    rng = np.random.default_rng(2)
    x = state.x + rng.normal(0.0, noise * model.gap, state.x.shape)
    names = ["inside", "nb_count", "nb_elem", "nb_d2", "nb_q", "nb_seg"]
    ref = [getattr(state, n).copy() for n in names]
    s = model.skin
    deep, deep_hits = _reference_update(x, state.active_skin, s.seg_a, s.seg_b, s.seg_next, s.seg_prev,
                                        model.tris, model.vtri_ptr, model.vtri, model.tri_ptr, sim.near2, np.inf,
                                        *ref)
    topo = model.contact
    out = [getattr(state, n).copy() for n in names]
    contact_update(x, state.active_skin, topo.ring, topo.seg_tri_ptr, topo.seg_tri, model.elem_vstart,
                   model.elem_nskin, sim.near2, np.inf, *out)
    for name, a, b in zip(names, ref, out):
        np.testing.assert_array_equal(a, b, err_msg=name)
    assert ref[0][state.active_skin].any()
    assert deep > 0 and (deep_hits > 0 or noise < 0.1)  # the neighbour-wide test was taken, and found some


def _reference_relax(x, elem_vstart, elem_nskin, moving, edge_rest, growth, vnbr_ptr, vnbr, passes, fraction,
                     order):
    """The self-intersection relaxation as first written: positions looked up through
    ``order`` at every comparison."""
    fixes = 0
    for e in range(len(elem_nskin)):
        if not moving[e] or edge_rest[e] <= 0.0:
            continue
        lim = fraction * edge_rest[e] * growth[e]
        s0, n = elem_vstart[e], elem_nskin[e]
        for _ in range(passes):
            before = fixes
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
                    if d2 >= lim * lim or q in vnbr[vnbr_ptr[p]:vnbr_ptr[p + 1]]:
                        continue
                    d = np.sqrt(d2)
                    if d < 1e-12:
                        dx, dy, d = 1e-6, 0.0, 1e-6
                    push = 0.5 * (lim - d) / d
                    x[p, 0] -= dx * push
                    x[p, 1] -= dy * push
                    x[q, 0] += dx * push
                    x[q, 1] += dy * push
                    fixes += 1
            if fixes == before:
                break
    return fixes


def test_relaxation_gives_the_positions_of_the_first_version(jammed):
    """Skins squeezed on a jammed scene (and two vertices on one spot): the same
    corrections, positions and sweep orders, bit for bit."""
    from repulsionpak.sim.selfintersect import relax_self_intersections

    sim, model, state = jammed
    rng = np.random.default_rng(4)
    x0 = state.x + rng.normal(0.0, 0.05 * sim.edge_rest.mean(), state.x.shape)
    for e in range(0, model.n_elements, 2):  # every other element flattened: its skin's sides meet
        a, b = model.elem_vstart[e], model.elem_vstart[e + 1]
        x0[a:b, 1] = x0[a:b, 1].mean() + 0.1 * (x0[a:b, 1] - x0[a:b, 1].mean())
    s0 = model.elem_vstart[1]
    x0[s0 + 5] = x0[s0 + 9]  # coincident: the tiny-distance branch
    order0 = np.arange(model.n_vertices, dtype=np.int64)
    args = (model.elem_vstart, model.elem_nskin, sim.relaxed, sim.edge_rest, state.growth, model.vnbr_ptr,
            model.vnbr, 3, 0.5)
    x_ref, order_ref = x0.copy(), order0.copy()
    n_ref = _reference_relax(x_ref, *args, order_ref)
    x_new, order_new = x0.copy(), order0.copy()
    n_new = relax_self_intersections(x_new, *args, order_new)
    assert n_ref > 200
    assert n_new == n_ref
    np.testing.assert_array_equal(x_new, x_ref)
    np.testing.assert_array_equal(order_new, order_ref)
