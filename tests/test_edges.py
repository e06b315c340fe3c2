"""The indexed container edge (:mod:`repulsionpak.geometry.edges`): the same exact
distances as shapely's, from points and from geometries, near and far."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, box

from repulsionpak.geometry.edges import Edges


@pytest.fixture(scope="module")
def wiggly():
    """A region with a long, detailed boundary: a wavy ring (2,000 vertices) with a
    square hole, and a second part beside it."""
    t = np.linspace(0.0, 2.0 * np.pi, 2000, endpoint=False)
    r = 100.0 + 3.0 * np.sin(60.0 * t)
    outer = shapely.Polygon(np.c_[r * np.cos(t), r * np.sin(t)], [box(-20, -20, 20, 20).exterior.coords])
    return shapely.MultiPolygon([outer, box(150, -10, 170, 10)])


def test_point_distances_are_shapelys_to_the_last_bit(wiggly):
    """Near the edge (the binned segments) and far from it (the tree), inside, outside
    and in the hole: bit for bit what ``shapely.distance`` gives, so a field built on
    them is the same field."""
    rng = np.random.default_rng(3)
    xy = rng.uniform(-130.0, 180.0, (3000, 2))
    edges = Edges(wiggly)
    got = edges.distance_xy(xy[:, 0], xy[:, 1], reach=4.0)
    want = shapely.distance(wiggly.boundary, shapely.points(xy))
    assert (want <= 4.0).sum() > 100 and (want > 4.0).sum() > 1000  # both ways are taken
    assert np.array_equal(got, want)


def test_geometry_distances_and_shortest_lines(wiggly):
    rng = np.random.default_rng(4)
    centres = rng.uniform(-110.0, 110.0, (200, 2))
    geoms = np.array([Point(c).buffer(1.0 + (k % 5), quad_segs=8) for k, c in enumerate(centres)], dtype=object)
    edges = Edges(wiggly)
    want = shapely.distance(wiggly.boundary, geoms)
    assert (want == 0).sum() > 10 and (want > 0).sum() > 100  # crossing the edge, and clear of it
    assert np.array_equal(edges.distance(geoms), want)
    assert edges.distance(geoms[0]) == want[0]  # one geometry: a float
    for g, d in zip(geoms[:40], want[:40]):
        line = edges.shortest_line(g)
        assert line.length == pytest.approx(d, abs=1e-9)
        if d > 0:  # one end on the art, the other on the edge
            a, b = shapely.get_coordinates(line)
            assert g.boundary.distance(Point(a)) < 1e-9 and wiggly.boundary.distance(Point(b)) < 1e-9


def test_a_lineal_geometry_is_indexed_as_it_is_and_empty_queries_are_nan():
    line = shapely.LineString([(0, 0), (10, 0), (10, 10)])
    edges = Edges(line)
    assert len(edges) == 2
    assert edges.distance(Point(5, 3)) == 3.0
    assert np.isnan(edges.distance(shapely.Polygon()))
    assert edges.shortest_line(shapely.Polygon()) is None
    d = Edges(box(0, 0, 1, 1)).distance_xy(np.array([0.5, 5.0]), np.array([0.5, 0.5]), reach=0.1)
    assert d.tolist() == [0.5, 4.0]


def test_too_many_cells_falls_back_to_the_tree(monkeypatch):
    """Long segments over a fine cell would bin into millions of cells: the points then
    ask the tree, with the same answers."""
    import repulsionpak.geometry.edges as E

    region = shapely.Polygon([(0, 0), (1000, 3), (997, 1000), (2, 996)])
    xy = np.random.default_rng(5).uniform(-10, 1010, (500, 2))
    want = shapely.distance(region.boundary, shapely.points(xy))
    monkeypatch.setattr(E, "MAX_ENTRIES", 100)
    edges = Edges(region)
    assert np.array_equal(edges.distance_xy(xy[:, 0], xy[:, 1], reach=1.0), want)
    assert edges._buckets[1.0] is None
