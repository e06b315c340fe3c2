"""Tests of repulsionpak.measure's art-only yardstick on constructed geometry with known
answers: gaps, overlaps, edge distances, outside area, distortion, promises."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import shapely
from shapely import affinity
from shapely.geometry import Point, Polygon, box

from repulsionpak import measure
from repulsionpak.errors import ParameterError
from repulsionpak.measure import evaluate
from repulsionpak.types import ArtPath, Container, PlacedArt, Style


def placed(geom, source="sq.svg") -> PlacedArt:
    """A PlacedArt painting exactly ``geom`` (holes as evenodd subpaths)."""
    subs = []
    for p in shapely.get_parts(geom):
        for ring in [p.exterior, *p.interiors]:
            subs.append(np.asarray(ring.coords)[:-1])
    return PlacedArt(source, "primary", (ArtPath(tuple(subs), (True,) * len(subs), Style(fill="#000", fill_rule="evenodd")),))


def ring(cx, cy, r_out, r_in):
    return Point(cx, cy).buffer(r_out, quad_segs=64).difference(Point(cx, cy).buffer(r_in, quad_segs=64))


# --------------------------------------------------------------------------- gaps, overlap, edges


def test_two_squares_gap_edge_and_overlap_exact():
    a, b = box(10, 10, 30, 30), box(37.5, 10, 57.5, 30)  # 7.5 apart
    cont = Container("c", box(0, 0, 100, 40))
    res = evaluate(cont, [placed(a), placed(b)], gap=7.5, grid=200)
    assert res["gap"]["values"] == [pytest.approx(7.5, abs=1e-12)] * 2
    assert res["gap"]["median"] == pytest.approx(7.5) and res["overlap_area"] == 0.0
    # edge: a is 10 from the left/top/bottom, b 10 from top/bottom, 42.5 from the right
    assert res["edge"]["values"] == [pytest.approx(10.0), pytest.approx(10.0)]
    assert res["edge"]["min"] == pytest.approx(10.0) and res["edge"]["margin"] == 3.75
    assert res["edge"]["n_below_margin"] == 0 and res["outside_area"] == 0.0
    # move b left by 10: it overlaps a by 2.5 x 20 = 50
    res = evaluate(cont, [placed(a), placed(affinity.translate(b, -10))], gap=7.5, grid=200)
    assert res["overlap_area"] == pytest.approx(50.0, rel=1e-12)
    assert res["gap"]["values"] == [0.0, 0.0]
    json.dumps(res, allow_nan=False)


def test_edge_distances_curved_container_and_outside():
    disc = Point(0, 0).buffer(100, quad_segs=256)
    inner = box(-10, -10, 10, 10)  # corners at 10·√2 from the centre
    poking = box(90, -5, 110, 5)  # crosses the boundary
    away = box(200, 0, 210, 10)  # entirely outside
    d = measure.edge_distances(disc, [inner, poking, away, Polygon()])
    assert d[0] == pytest.approx(100 - 10 * math.sqrt(2), rel=1e-4)
    assert d[1:] == [0.0, 0.0, None]
    out = measure.outside_area(disc, [inner, poking, away])
    # the part of ``poking`` inside the disc: ∫_{-5}^{5} (sqrt(100² − y²) − 90) dy
    prim = lambda y: 0.5 * (y * math.sqrt(100**2 - y**2) + 100**2 * math.asin(y / 100))  # noqa: E731
    inside = prim(5) - prim(-5) - 90 * 10
    assert out == pytest.approx(100.0 + (200.0 - inside), rel=1e-4)
    assert measure.outside_area(disc, [inner]) == 0.0


def test_holed_element_counts_its_hole():
    """A disc inside a ring's hole neither overlaps nor touches it: gap = 30 − 10."""
    res = evaluate(Container("c", box(-100, -100, 100, 100)),
                   [placed(ring(0, 0, 50, 30), "ring.svg"), placed(Point(0, 0).buffer(10, quad_segs=64), "disc.svg")],
                   gap=20.0, grid=200)
    assert res["overlap_area"] == 0.0
    assert res["gap"]["values"] == [pytest.approx(20.0, rel=1e-3)] * 2
    assert res["edge"]["values"][0] == pytest.approx(50.0, rel=1e-3)


def test_edge_margin_counts_close_elements():
    cont = Container("c", box(0, 0, 100, 100))
    near = box(4.95, 40, 20, 60)  # 4.95 from the left edge: 0.99 × margin 5, allowed
    nearer = box(80, 40, 95.2, 60)  # 4.8 from the right edge: below 0.98 × 5
    res = evaluate(cont, [placed(near), placed(nearer)], gap=10.0, grid=100)
    assert res["edge"]["n_below_margin"] == 1 and res["edge"]["min"] == pytest.approx(4.8)
    with pytest.raises(ParameterError):
        evaluate(cont, [placed(near)], gap=10.0, margin=-1.0, with_scp=False)


# --------------------------------------------------------------------------- distortion


STAR = Polygon([(math.cos(t) * (1.0 if k % 2 == 0 else 0.4), math.sin(t) * (1.0 if k % 2 == 0 else 0.4))
                for k, t in enumerate(-math.pi / 2 + np.arange(10) * math.pi / 5)])


@pytest.mark.parametrize("shape", [STAR, ring(0, 0, 1, 0.6), box(0, 0, 5, 1),
                                   Polygon([(0, 0), (4, 0), (4, 1), (1, 1), (1, 3), (0, 3)])],
                         ids=["star", "ring", "bar", "L"])
@pytest.mark.parametrize("angle, scale, shift", [(0.0, 1.0, (0, 0)), (37.3, 2.5, (500, -200)),
                                                 (181.0, 0.01, (3, 4)), (-95.0, 100.0, (1e4, 0))])
def test_similar_copy_has_no_distortion(shape, angle, scale, shift):
    copy = affinity.translate(affinity.scale(affinity.rotate(shape, angle, origin="centroid"),
                                             scale, scale, origin="centroid"), *shift)
    d, (ang, s, dx, dy) = measure.distortion(shape, copy, return_fit=True)
    assert d < 2e-4
    assert s == pytest.approx(scale, rel=1e-3)
    if shape is not STAR and shape.geom_type == "Polygon" and not shape.interiors and shape.area != 5:
        # the L has no symmetry: the angle is unique
        assert (ang - angle + 180) % 360 - 180 == pytest.approx(0.0, abs=0.05)


def test_distortion_of_a_rectangle_from_a_square_is_analytic():
    """Best similar square in a √2 × 1/√2 rectangle: side 1/√2 inside it, △ = 1 − ½ = ½
    of the unit area; for a 3 × ⅓ rectangle: side ⅓, △ = 1 − 1/9."""
    sq = box(0, 0, 1, 1)
    assert measure.distortion(sq, box(0, 0, math.sqrt(2), 1 / math.sqrt(2))) == pytest.approx(0.5, abs=2e-3)
    assert measure.distortion(sq, box(0, 0, 3, 1 / 3)) == pytest.approx(8 / 9, abs=2e-3)
    # without the translation / scale fit: the area-matched, centroid-aligned square
    # covers 1/√2 of the rectangle's height: △ = 2·(1 − 1/√2)
    assert measure.distortion(sq, box(0, 0, math.sqrt(2), 1 / math.sqrt(2)), fit_translation=False) \
        == pytest.approx(min(0.5, 2 * (1 - 1 / math.sqrt(2))), abs=2e-3)


def test_bent_copy_is_distorted_and_more_bending_is_more():
    bar = shapely.segmentize(box(-50, -5, 50, 5), 1.0)

    def bent(k):
        def f(xy):  # bend the bar along a parabola y += k·x²
            return np.stack([xy[:, 0], xy[:, 1] + k * xy[:, 0] ** 2], axis=1)
        return shapely.transform(bar, f)

    values = [measure.distortion(bar, bent(k)) for k in (0.0, 0.002, 0.005, 0.01)]
    assert values[0] < 1e-4
    assert 0.02 < values[1] < values[2] < values[3]
    # a parabola of sagitta 25 on a bar 10 thick: far from any straight bar
    assert values[3] > 0.5


def test_distortion_from_a_known_angle_finds_the_same_fit():
    """A packing knows each copy's rotation roughly (its mesh frame): the search starting
    there, a few degrees off, finds what the search over all angles finds."""
    bar = shapely.segmentize(box(-50, -5, 50, 5), 1.0)
    bent = shapely.transform(bar, lambda xy: np.stack([xy[:, 0], xy[:, 1] + 0.004 * xy[:, 0] ** 2], axis=1))
    L = Polygon([(0, 0), (4, 0), (4, 1), (1, 1), (1, 3), (0, 3)])
    for src, copy in [(bar, affinity.rotate(bent, 63.0, origin="centroid")),
                      (L, affinity.scale(affinity.rotate(L, -120.0), 3.0, 2.6))]:
        full, (ang, *_rest) = measure.distortion(src, copy, return_fit=True)
        assert full > 0.02
        for off in (-3.0, 0.0, 2.5):
            warm = measure.distortion(src, copy, angle=math.radians(ang + off))
            assert warm == pytest.approx(full, abs=1e-3)


def test_distortions_in_threads_equal_one_thread():
    src = {"a.svg": box(0, 0, 1, 1), "b.svg": STAR}
    geoms = [affinity.rotate(box(0, 0, 1, 1), 10 * k) for k in range(5)] + \
            [affinity.scale(affinity.rotate(STAR, 7 * k), 1.0 + 0.05 * k, 1.0) for k in range(5)]
    names = ["a.svg"] * 5 + ["b.svg"] * 5
    angles = [math.radians(10 * k) for k in range(5)] + [None] * 5
    one = measure.distortions(geoms, names, src, angles=angles)
    assert measure.distortions(geoms, names, src, angles=angles, workers=3) == one
    assert max(one[:5]) < 1e-4 and one[9] > one[6] > 0.01
    with pytest.raises(ParameterError):
        measure.distortions(geoms, names, src, workers=0)
    with pytest.raises(ParameterError):
        measure.distortions(geoms, names, src, angles=[0.0])


def test_frame_angle():
    t = math.radians(30.0)
    m = np.array([[2 * math.cos(t), -2 * math.sin(t), 5.0], [2 * math.sin(t), 2 * math.cos(t), 1.0], [0, 0, 1]])
    assert measure.frame_angle(m) == pytest.approx(t) and measure.frame_angle(None) is None


def test_distortion_none_for_empty_and_bad_arguments():
    assert measure.distortion(Polygon(), box(0, 0, 1, 1)) is None
    assert measure.distortion(box(0, 0, 1, 1), Polygon()) is None
    with pytest.raises(ParameterError):
        measure.distortion(box(0, 0, 1, 1), box(0, 0, 1, 1), coarse=3)
    with pytest.raises(ParameterError):
        measure.distortions([box(0, 0, 1, 1)], [], {})


def test_distortions_by_source_name_and_summary():
    src = {"a.svg": box(0, 0, 1, 1), "b.svg": STAR}
    geoms = [affinity.rotate(box(0, 0, 1, 1), 10), box(0, 0, math.sqrt(2), 1 / math.sqrt(2)), STAR]
    vals = measure.distortions(geoms, ["a.svg", "a.svg", "missing.svg"], src)
    assert vals[0] < 1e-4 and vals[1] == pytest.approx(0.5, abs=2e-3) and vals[2] is None
    s = measure.distortion_summary(vals)
    assert s["median"] == pytest.approx(np.median(vals[:2])) and s["max"] == pytest.approx(vals[1])
    assert s["p95"] == pytest.approx(np.percentile(vals[:2], 95)) and s["values"][2] is None
    assert measure.distortion_summary([None])["p95"] is None
    assert "by_kind" not in s


def test_distortion_summary_by_kind():
    vals = [0.10, 0.12, None, 0.0, 0.01, 0.02]
    kinds = ["primary", "primary", "primary", "secondary", "secondary", "secondary"]
    s = measure.distortion_summary(vals, kinds)
    prim, sec = s["by_kind"]["primary"], s["by_kind"]["secondary"]
    assert prim["n"] == 3 and prim["max"] == pytest.approx(0.12) and prim["median"] == pytest.approx(0.11)
    assert sec["n"] == 3 and sec["max"] == pytest.approx(0.02)
    # the pocket copies pull the overall statistics below the primaries' own
    assert s["median"] == pytest.approx(0.02) and s["median"] < prim["median"]
    only = measure.distortion_summary([0.1], ["primary"])["by_kind"]
    assert list(only) == ["primary"]


def test_evaluate_reports_distortion_with_sources():
    cont = Container("c", box(-100, -100, 100, 100))
    arts = [placed(affinity.translate(affinity.rotate(STAR, 20), 40, 0), "star.svg"),
            placed(affinity.scale(box(-60, -60, -40, -30), 1, 1), "square.svg")]
    res = evaluate(cont, arts, gap=10.0, grid=100, sources={"star.svg": STAR, "square.svg": box(0, 0, 1, 1)})
    d = res["distortion"]["values"]
    assert d[0] < 1e-3
    # 20 x 30 rectangle from a square: best square of side 20 inside, △ = 1 − 400/600
    assert d[1] == pytest.approx(1 / 3, abs=2e-3)
    assert evaluate(cont, arts, gap=10.0, grid=100)["distortion"]["values"] == [None, None]


# --------------------------------------------------------------------------- promises


def grid_packing(side=40.0, gap=5.0, n=5, jitter=None):
    """n × n squares ``side`` apart by ``gap``, gap/2 from the container's edges."""
    p = side + gap
    cont = box(0, 0, n * p, n * p)
    arts = [box(gap / 2 + i * p, gap / 2 + j * p, gap / 2 + i * p + side, gap / 2 + j * p + side)
            for j in range(n) for i in range(n)]
    if jitter:
        arts = [affinity.translate(a, *jitter(k)) for k, a in enumerate(arts)]
    return Container("c", cont), [placed(a, "square.svg") for a in arts]


def test_a_perfect_grid_keeps_every_promise():
    cont, arts = grid_packing()
    res = evaluate(cont, arts, gap=5.0, grid=900, sources={"square.svg": box(0, 0, 1, 1)})
    pr = measure.check_promises(res, {"square.svg": "convex"}, sources=[a.source for a in arts])
    assert pr["gap_median"]["value"] == pytest.approx(1.0) and pr["gap_p10"]["value"] == pytest.approx(1.0)
    assert pr["edge_margin"]["value"] == pytest.approx(1.0)
    assert pr["distortion_convex"]["value"] < 1e-4
    # channels of width gap: only the crossings hold a disc of radius gap/2
    assert pr["scp_ratio"]["value"] < 0.05
    assert all(v["ok"] for k, v in pr.items() if k != "all") and pr["all"] is True


def test_broken_promises_are_reported():
    # one square pushed 3 units towards its neighbour: gap 2 there (p10 < 0.8 gap)
    def jitter(k):
        return (3.0, 0.0) if k in (0, 6, 12, 18) else (0.0, 0.0)

    cont, arts = grid_packing(jitter=jitter)
    res = evaluate(cont, arts, gap=5.0, grid=900, sources={"square.svg": box(0, 0, 2, 1)})
    pr = measure.check_promises(res, {"square.svg": "convex"}, sources=[a.source for a in arts])
    assert pr["gap_p10"]["ok"] is False and pr["gap_p10"]["value"] == pytest.approx(0.4)
    assert pr["gap_median"]["ok"] is True
    assert pr["distortion_convex"]["ok"] is False  # squares from a 2:1 source
    assert pr["all"] is False
    # an overlap, art outside and an element at the edge
    # square 1 moved 6 left overlaps square 0 by 1 × 40; square 4 moved 3.5 right pokes
    # 1 out of the container's right edge (1 × 40 outside)
    cont, arts = grid_packing(jitter=lambda k: (-6.0, 0.0) if k == 1 else ((3.5, 0.0) if k == 4 else (0, 0)))
    res = evaluate(cont, arts, gap=5.0, grid=300)
    pr = measure.check_promises(res)
    assert pr["overlap"]["ok"] is False and pr["outside"]["ok"] is False and pr["edge_margin"]["ok"] is False
    assert res["overlap_area"] == pytest.approx(40.0) and res["outside_area"] == pytest.approx(40.0)
    assert pr["outside"]["value"] == pytest.approx(40.0 / res["container_area"])
    assert pr["edge_margin"]["value"] == 0.0
    assert "distortion_other" not in pr  # no sources: no distortion to check


def test_promises_unknown_without_measurements():
    cont, arts = grid_packing(n=1)
    res = evaluate(cont, arts, gap=5.0, with_scp=False)
    pr = measure.check_promises(res)
    assert pr["gap_median"]["ok"] is None and pr["scp_ratio"]["ok"] is None
    assert pr["overlap"]["ok"] is True and pr["all"] is True
    assert measure.limits_dict()["scp_ratio"] == 0.45
