"""The contact phase's data structures against plain references: the triangle cover of
the full query (:mod:`repulsionpak.sim.contacts`, :mod:`repulsionpak.sim.grid`)."""

from __future__ import annotations

import numpy as np
import pytest

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
