"""The overlap kernel behind the distortion fit: areas against GEOS, exact copies, and its
compiled Nelder–Mead against the Python one."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
import shapely.affinity as aff

from repulsionpak.measure import similarity as metrics
from repulsionpak.geometry.overlap import OverlapGrid, intersection_areas, nelder_mead_sym, rings_of


def _blob(rng, n=120, holes=False, shift=(0.0, 0.0)):
    t = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = 1 + 0.3 * np.sin(3 * t + rng.uniform(0, 6)) + 0.08 * rng.standard_normal(n)
    p = shapely.make_valid(shapely.Polygon(np.c_[r * np.cos(t) + shift[0], r * np.sin(t) + shift[1]]))
    p = shapely.union_all([g for g in getattr(p, "geoms", [p]) if g.geom_type == "Polygon"])
    if holes:
        p = p.difference(shapely.Point(0.1, 0.05).buffer(0.3, 8)).difference(shapely.Point(-0.4, 0.2).buffer(0.12, 6))
    return p


def _geos_intersections(a, b, params):
    out = []
    for ang, ls, dx, dy in params:
        m = aff.rotate(a, ang, origin=(0, 0), use_radians=True)
        m = aff.scale(m, math.exp(ls), math.exp(ls), origin=(0, 0))
        out.append(shapely.intersection(aff.translate(m, dx, dy), b).area)
    return np.array(out)


@pytest.mark.parametrize("case", range(12))
def test_intersection_areas_match_geos(case):
    rng = np.random.default_rng(100 + case)
    a = _blob(rng, holes=case % 3 == 0)
    b = _blob(rng, holes=case % 2 == 0)
    if case % 4 == 1:  # two parts, one of them far off
        b = shapely.union(b, shapely.Point(2.6, 0.3).buffer(0.4, 12))
    if case % 4 == 2:
        a = shapely.union(a, shapely.box(1.8, -0.2, 2.4, 0.5))
    params = np.c_[rng.uniform(0, 2 * np.pi, 40), rng.normal(0, 0.25, 40), rng.normal(0, 0.5, (40, 2))]
    got = intersection_areas(rings_of(a), OverlapGrid(rings_of(b)), params)
    want = _geos_intersections(a, b, params)
    assert want.max() > 0.5 and (want == 0).sum() < 40  # the cases overlap, partly
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-7 * (a.area + b.area))


def test_exact_copies_overlap_fully():
    """A copy that fits its source exactly: edges coincide; the kernel must still count
    the whole shape once (the tiny nudge), also for a square's collinear edges."""
    rng = np.random.default_rng(7)
    a = _blob(rng, holes=True)
    ra = rings_of(a)
    for deg in (0.0, 0.3, 90.0, 211.0):
        b = aff.rotate(a, deg, origin=(0, 0))
        got = intersection_areas(ra, OverlapGrid(rings_of(b)), np.array([[math.radians(deg), 0, 0, 0]]))
        assert got[0] == pytest.approx(a.area, rel=1e-7)
    sq = rings_of(shapely.box(-1, -1, 1, 1))
    got = intersection_areas(sq, OverlapGrid(sq), np.array([[0, 0, 0, 0], [np.pi / 2, 0, 0, 0], [0, 0, 0.5, 0],
                                                            [0, math.log(0.5), 0, 0]]))
    np.testing.assert_allclose(got, [4.0, 4.0, 3.0, 1.0], atol=1e-7)


def test_compiled_nelder_mead_follows_the_python_one():
    """The compiled search takes the same steps as metrics._nelder_mead on the same
    objective: same parameters and value (up to the last bits of exp)."""
    rng = np.random.default_rng(3)
    for holes in (False, True):
        src = _blob(rng, holes=holes)
        copy = aff.scale(aff.rotate(src, 25, origin=(0, 0)), 1.1, 0.95, origin=(0, 0))
        search = metrics._Search(src, copy)
        p = np.array([math.radians(20), 0.02, 0.01, -0.02])
        v = float(search(p[None, :])[0])
        q_py, v_py = metrics._nelder_mead(search, p, v)
        q_nb, v_nb = nelder_mead_sym(search.ra, search.gb, p, v, metrics._NM_SIZE, metrics._NM_TOL,
                                     metrics._NM_EVALS)
        assert v_nb < v  # it improved on the start
        np.testing.assert_allclose(q_nb, q_py, atol=1e-9)
        assert v_nb == pytest.approx(v_py, abs=1e-12)


def test_distortion_values_unchanged_by_the_kernel():
    """The fit's value is measured with GEOS at the transform the kernel search found;
    the same as a search with GEOS overlays throughout (here: a bent, rotated copy)."""
    rng = np.random.default_rng(11)
    src = _blob(rng)
    copy = aff.rotate(aff.skew(src, 8, 0, origin=(0, 0)), 40, origin=(0, 0))

    class Geos(metrics._Search):  # the search through GEOS overlays only
        def __call__(self, params):
            return metrics._sym_areas(self.a, self.b, np.atleast_2d(params))

        def nelder_mead(self, p, v):
            return metrics._nelder_mead(self, p, v)

    fast = metrics.distortion(src, copy)
    orig = metrics._Search
    metrics._Search = Geos
    try:
        slow = metrics.distortion(src, copy)
    finally:
        metrics._Search = orig
    assert 0.02 < fast < 0.5
    assert fast == pytest.approx(slow, abs=1e-6)


def _dots(rng, n, r=0.12):
    pts = rng.uniform(-1.5, 1.5, (n, 2))
    pts[: n // 2] = np.round(pts[: n // 2] * 4) / 4  # on a lattice: shared rows, horizontal edges
    return shapely.union_all([shapely.Point(p).buffer(float(r * rng.uniform(0.5, 1.5)), int(rng.integers(1, 5)))
                              for p in pts])


def test_ring_start_tests_through_a_grid_count_the_same_crossings():
    """Whether a ring's first vertex lies in the other polygon is tested through a grid of
    that polygon's edges (only the ray's row); the answer is the full test's, also on
    vertices, lattice points and horizontal edges."""
    from repulsionpak.geometry.overlap import _bin_rows, _inside, _inside_grid

    rng = np.random.default_rng(5)
    for case in range(20):
        g = _dots(rng, int(rng.integers(1, 60)))
        if case % 4 == 1:
            g = shapely.union_all([shapely.box(x, y, x + 0.5, y + 0.25) for x, y in np.round(rng.uniform(-2, 2, (20, 2)) * 4) / 4])
        r = rings_of(g)
        grid = OverlapGrid(r)
        y0, inv, gy, start, edges = _bin_rows(r.xy, r.nxt)
        pts = np.concatenate([rng.uniform(-2.5, 2.5, (200, 2)), r.xy, np.round(rng.uniform(-2.5, 2.5, (100, 2)) * 4) / 4])
        for px, py in pts:
            want = _inside(px, py, r.xy, r.nxt)
            assert _inside_grid(px, py, r.xy, r.nxt, grid.x0, grid.y0, grid.inv, grid.inv, grid.gx, grid.gy,
                                grid.cell_start, grid.cell_edges) == want
            assert _inside_grid(px, py, r.xy, r.nxt, 0.0, y0, 0.0, inv, 1, gy, start, edges) == want


@pytest.mark.parametrize("case", range(4))
def test_intersection_areas_of_many_rings_match_geos(case):
    """Dotted art (a hundred rings on each side: the ring-start tests go through grids)."""
    rng = np.random.default_rng(300 + case)
    a, b = _dots(rng, 100), _dots(rng, 100)
    assert len(a.geoms) > 20 and len(b.geoms) > 20
    params = np.c_[rng.uniform(0, 2 * np.pi, 12), rng.normal(0, 0.1, 12), rng.normal(0, 0.1, (12, 2))]
    params[0] = 0.0
    got = intersection_areas(rings_of(a), OverlapGrid(rings_of(b)), params)
    np.testing.assert_allclose(got, _geos_intersections(a, b, params), rtol=0, atol=1e-7 * (a.area + b.area))
