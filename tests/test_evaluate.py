"""Tests of repulsionpak.measure: coverage, gaps, raster, SCP against analytic references,
evaluate, the table and the plots."""

from __future__ import annotations

import importlib
import json
import math
import subprocess
import sys

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import Point, Polygon, box

import repulsionpak
import repulsionpak.measure as ev
from repulsionpak.errors import ParameterError
from repulsionpak.art_area import _polygonal
from repulsionpak.measure import coverage
from repulsionpak.types import ArtPath, Container, PlacedArt, Style


def sq(x0, y0, x1, y1, ccw=True):
    pts = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
    return pts if ccw else pts[::-1].copy()


def placed_from(geoms, kinds=None, deformation=None):
    out = []
    for k, g in enumerate(geoms):
        pts = np.asarray(g.exterior.coords)[:-1]
        out.append(
            PlacedArt(
                source="sq.svg",
                kind=(kinds[k] if kinds else "primary"),
                paths=(ArtPath((pts,), (True,), Style(fill="#000")),),
                deformation=None if deformation is None else deformation[k],
            )
        )
    return out


def arrays(res):
    return np.asarray(res["r"], dtype=float), np.asarray(res["q"], dtype=float)


# --------------------------------------------------------------------------- SCP: stripes

STRIPE_W, GAP = 30.0, 20.0


@pytest.fixture(scope="module")
def stripes_scp():
    # 2000 x 200 container, grid 2000 -> 1 unit pixels, gap = 20 px, whole periods.
    c, arts = ev.stripes_reference(STRIPE_W, GAP, (2000.0, 200.0))
    assert c.bounds == (0.0, 0.0, 2000.0, 200.0)
    return c, arts, ev.scp(c, arts, grid=2000, gap=GAP)


def test_stripes_q0(stripes_scp):
    _, _, res = stripes_scp
    q0 = GAP / (GAP + STRIPE_W)
    assert res["pixel_size"] == pytest.approx(1.0)
    assert abs(res["q"][0] - q0) <= 0.005 * q0
    assert res["q0"] == res["q"][0]


def test_stripes_match_ideal_line(stripes_scp):
    _, _, res = stripes_scp
    r, q = arrays(res)
    q0 = GAP / (GAP + STRIPE_W)
    inside = r <= GAP / 2
    assert inside.sum() >= 20
    err = np.abs(q[inside] - ev.ideal_stripes_q(r[inside], q0, GAP))
    assert err.max() <= 0.01 * q0
    assert np.all(q[r > GAP / 2 + 1e-9] <= 1e-3)
    # the curve is really sloped (not a constant within tolerance)
    assert np.interp(GAP / 4, r, q) == pytest.approx(q0 / 2, rel=0.02)


def test_stripes_match_exact_formula_with_container_edges(stripes_scp):
    # The vertical container edges add the factor (1 - 2r/W) exactly.
    _, _, res = stripes_scp
    r, q = arrays(res)
    q0 = GAP / (GAP + STRIPE_W)
    exact = q0 * np.clip(1 - 2 * r / GAP, 0, None) * (1 - 2 * r / 2000.0)
    assert np.abs(q - exact).max() <= 0.002 * q0


def test_naive_estimator_is_biased_by_half_a_pixel(stripes_scp):
    # The paper's plain "distance >= r" is off by half a pixel: 1/gap_px of Q_s(0).
    c, arts, _ = stripes_scp
    res = ev.scp(c, arts, grid=2000, gap=GAP, estimator="raw")
    r, q = arrays(res)
    q0 = GAP / (GAP + STRIPE_W)
    inside = r <= GAP / 2
    assert np.abs(q[inside] - ev.ideal_stripes_q(r[inside], q0, GAP)).max() > 0.05 * q0


def test_stripes_unaligned_with_pixels():
    # Stripe edges not on pixel edges: error bounded by the pixel resolution.
    w, g = 33.0, 21.7
    c, arts = ev.stripes_reference(w, g, (1500.0, 300.0))
    res = ev.scp(c, arts, grid=1000, gap=g)
    r, q = arrays(res)
    q0 = g / (g + w)
    gap_px = g / res["pixel_size"]
    assert abs(q[0] - q0) <= 0.01 * q0
    assert np.abs(q - ev.ideal_stripes_q(r, q0, g)).max() <= 0.5 / gap_px * q0 + 0.01 * q0


def test_r_grid_contains_half_gap_and_extends():
    r = ev.default_r_grid(3.0, gap=7.3)
    assert 7.3 / 2 in r.tolist()
    assert r[-1] >= 1.5 * 7.3 and r[0] == 0.0
    assert np.all(np.diff(r) > 0)
    r = ev.default_r_grid(500.0, gap=7.3)
    assert 7.3 / 2 in r.tolist() and r[-1] >= 100
    assert len(ev.default_r_grid(10.0)) == 101
    with pytest.raises(ParameterError):
        ev.default_r_grid(1.0, gap=0.0)


# --------------------------------------------------------------------------- SCP: squares

SIDE = 40.0


@pytest.fixture(scope="module")
def squares_scp():
    c, arts = ev.square_grid_reference(SIDE, GAP, 600.0)
    return c, arts, ev.scp(c, arts, grid=600, gap=GAP)


def test_square_grid_same_q0_as_stripes(squares_scp):
    c, arts, res = squares_scp
    ds = ev.equivalent_stripe_width(SIDE, GAP)
    assert ds == pytest.approx(16.0)
    c2, stripes = ev.stripes_reference(ds, GAP, (600.0, 600.0))
    res2 = ev.scp(c2, stripes, grid=600, gap=GAP)
    assert ev.area_fraction(c, arts) == pytest.approx(ev.area_fraction(c2, stripes), abs=1e-12)
    assert res["q"][0] == pytest.approx(res2["q"][0], rel=0.005)
    assert res["q"][0] == pytest.approx(1 - (SIDE / (SIDE + GAP)) ** 2, rel=0.005)


def test_square_grid_pockets_and_cutoff(squares_scp):
    _, _, res = squares_scp
    r, q = arrays(res)
    q_half = q[np.flatnonzero(r == GAP / 2)[0]]
    # pocket area g²(1 − π/4) per interior crossing (9² of them in 10 x 10 periods),
    # half of it at the 2 x 9 crossings with the border channels, a quarter in the corner
    expected = (81 + 18 / 2 + 1 / 4) * GAP**2 * (1 - math.pi / 4) / 600.0**2
    assert q_half > 0.01
    assert q_half == pytest.approx(expected, abs=0.005 * res["q"][0])
    assert np.all(q[r > GAP * math.sqrt(2) / 2 + res["pixel_size"]] == 0)
    assert np.any(q[r > GAP / 2 + 1] > 0)


def test_square_grid_raster_matches_exact_offsets(squares_scp):
    c, arts, res = squares_scp
    r, q = arrays(res)
    exact = ev.scp_vector(c, arts, r[::4])
    assert np.abs(q[::4] - np.asarray(exact["q"])).max() <= 0.01 * exact["q0"]


@pytest.mark.parametrize(
    "kw",
    [
        dict(rotate=True, translate=False),
        dict(rotate=False, translate=True),
        dict(rotate=True, translate=True),
        dict(rotate=True, translate=False, max_angle=20.0),
        dict(rotate=False, translate=True, max_shift=0.4 * GAP),
    ],
)
def test_perturbed_squares_longer_tail(squares_scp, kw):
    c, grid_arts, res_grid = squares_scp
    c2, arts = ev.perturbed_squares_reference(SIDE, GAP, 600.0, np.random.default_rng(7), **kw)
    assert c2.equals(c) and len(arts) == len(grid_arts)
    assert ev.overlap_area(arts) == 0.0
    assert min(ev.gap_statistics(arts)["values"]) > 0
    res = ev.scp(c2, arts, grid=600, gap=GAP)
    q_at = lambda res, r: float(np.interp(r, res["r"], res["q"]))  # noqa: E731
    # same area fraction (up to squares poking out of the container on its border) ...
    assert res["q"][0] == pytest.approx(res_grid["q"][0], abs=0.01)
    # ... but a shallower curve: more room left at gap/2 ...
    assert q_at(res, GAP / 2) > 1.3 * q_at(res_grid, GAP / 2)
    # ... and a tail beyond the grid's largest pocket (gap·√2/2 ≈ 0.707 gap)
    assert q_at(res_grid, 0.75 * GAP) == 0.0
    assert q_at(res, 0.75 * GAP) > 0.0
    if "max_angle" in kw or "max_shift" in kw:  # stronger perturbations: a clear tail
        assert q_at(res, 0.75 * GAP) > 2e-4


def test_perturbed_squares_is_reproducible_and_shrinks_only_if_needed():
    _, a = ev.perturbed_squares_reference(10, 5, 100, 3)
    _, b = ev.perturbed_squares_reference(10, 5, 100, 3)
    assert all(x.equals(y) for x, y in zip(a, b))
    assert all(x.area == pytest.approx(100.0) for x in a)
    # gap tiny against side: rotated squares must shrink to stay non-overlapping
    _, c = ev.perturbed_squares_reference(10, 0.1, 100, 4, translate=False, max_angle=10)
    assert ev.overlap_area(c) == pytest.approx(0.0, abs=1e-9)
    assert min(x.area for x in c) < 100.0


def test_random_circles_raster_vs_exact():
    rng = np.random.default_rng(3)
    c = Point(500, 500).buffer(500, quad_segs=64)
    arts = [Point(*p).buffer(rr, quad_segs=32) for p, rr in zip(rng.uniform(100, 900, (150, 2)), rng.uniform(5, 30, 150))]
    res = ev.scp(c, arts, grid=1000, gap=20.0)
    r, q = arrays(res)
    exact = ev.scp_vector(c, arts, r[::6])
    assert np.abs(q[::6] - np.asarray(exact["q"])).max() <= 0.01 * exact["q0"]
    assert res["r"][-1] >= 30.0
    assert q[-1] == pytest.approx(0.0, abs=1e-6)  # default r_max reaches the largest hole


# --------------------------------------------------------------------------- raster


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.tuples(st.floats(0, 100), st.floats(0, 100)), min_size=3, max_size=12),
)
def test_rasterize_area_matches(points):
    poly = shapely.make_valid(Polygon(points))
    poly = _polygonal(poly)
    if poly.area < 50:
        return
    mask, info = ev.rasterize(poly, (0, 0, 100, 100), grid=400)
    h = info["pixel_size"]
    # pixel-centre sampling error is bounded by the boundary length times a pixel
    assert abs(mask.sum() * h * h - poly.area) <= poly.length * h


def test_rasterize_is_exact_pixel_centre_sampling():
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(0, 2 * np.pi, 40))
    star = Polygon(np.c_[50 + rng.uniform(10, 45, 40) * np.cos(t), 50 + rng.uniform(10, 45, 40) * np.sin(t)])
    geom = shapely.make_valid(star).difference(Point(50.3, 49.7).buffer(7)).union(box(90.2, 90.2, 99.7, 99.9))
    mask, info = ev.rasterize([geom], (0, 0, 100, 100), grid=137, margin=3)
    h = info["pixel_size"]
    ii, jj = np.indices(mask.shape)
    inside = shapely.contains_xy(geom, info["x0"] + (jj + 0.5) * h, info["y0"] + (ii + 0.5) * h)
    assert np.array_equal(mask, inside)


def test_rasterize_hole_and_pixel_centres():
    ring = box(0, 0, 10, 10).difference(box(2, 2, 6, 6))
    mask, info = ev.rasterize([ring], (0, 0, 10, 10), grid=10, margin=2)
    assert info["pixel_size"] == 1.0 and mask.shape == (14, 14)
    assert mask.sum() == 100 - 16
    assert not mask[2 + 3, 2 + 3] and mask[2 + 7, 2 + 7] and not mask[0, 0]


# --------------------------------------------------------------------------- metrics


def test_overlap_area_two_unit_squares():
    assert ev.overlap_area([box(0, 0, 1, 1), box(0.5, 0.5, 1.5, 1.5)]) == pytest.approx(0.25, abs=1e-12)
    assert ev.overlap_area([box(0, 0, 1, 1), box(2, 0, 3, 1)]) == 0.0
    assert ev.overlap_area([box(0, 0, 1, 1)]) == 0.0


def test_area_fraction_counts_overlaps_once_and_clips():
    c = box(0, 0, 10, 10)
    arts = [box(0, 0, 5, 5), box(0, 0, 5, 5), box(8, 8, 12, 12)]
    assert ev.area_fraction(c, arts) == pytest.approx((25 + 4) / 100)


def test_gap_statistics():
    res = ev.gap_statistics([box(0, 0, 1, 1), box(4, 0, 5, 1)])
    assert res["median"] == pytest.approx(3.0) and res["values"] == [3.0, 3.0]
    res = ev.gap_statistics([box(0, 0, 1, 1), box(3, 0, 4, 1), box(10, 0, 11, 1), Polygon()])
    assert res["values"][:3] == pytest.approx([2.0, 2.0, 6.0]) and res["values"][3] is None
    assert res["median"] == pytest.approx(2.0)
    assert res["p90"] > res["p10"]
    # exact duplicates and touching elements are at distance 0
    res = ev.gap_statistics([box(0, 0, 1, 1), box(0, 0, 1, 1), box(5, 5, 6, 6)])
    assert res["values"][:2] == [0.0, 0.0]
    assert ev.gap_statistics([box(0, 0, 1, 1)])["median"] is None


def test_gap_statistics_matches_all_pairs_on_crowded_irregular_shapes():
    """Nearest distances found by growing search radii equal the minimum over all pairs:
    irregular stars whose bounding boxes overlap, of mixed sizes, one far from the rest."""
    rng = np.random.default_rng(5)
    shapes = []
    for k in range(40):
        n = int(rng.integers(5, 9))
        t = np.linspace(0, 2 * np.pi, 2 * n, endpoint=False)
        r = np.where(np.arange(2 * n) % 2 == 0, 1.0, 0.4) * rng.uniform(0.5, 3.0)
        c = rng.uniform(0, 20, 2)
        shapes.append(Polygon(np.column_stack([c[0] + r * np.cos(t), c[1] + r * np.sin(t)])))
    shapes.append(box(500, 500, 501, 501))  # alone: its nearest is hundreds of sizes away
    brute = [min(a.distance(b) for j, b in enumerate(shapes) if j != i) for i, a in enumerate(shapes)]
    assert ev.gap_statistics(shapes)["values"] == pytest.approx(brute, abs=1e-12)
    assert brute[-1] > 400 and min(brute) == 0.0  # some stars touch or overlap


def test_outside():
    c = box(0, 0, 10, 10)
    arts = [box(1, 1, 2, 2), box(9, 9, 10.5, 10.5), box(0, 0, 10, 10), box(9.5, 5, 10.05, 6)]
    assert ev.outside(c, arts, 0.0) == [1, 3]
    assert ev.outside(c, arts, 0.1) == [1]
    assert ev.outside(c, arts, 1.0) == []


# --------------------------------------------------------------------------- art


def test_art_geometry_evenodd_vs_nonzero():
    outer, inner = sq(0, 0, 10, 10), sq(3, 3, 7, 7)
    eo = PlacedArt("a", "primary", (ArtPath((outer, inner), (True, True), Style(fill_rule="evenodd")),))
    nz_same = PlacedArt("a", "primary", (ArtPath((outer, inner), (True, True), Style(fill_rule="nonzero")),))
    nz_opp = PlacedArt(
        "a", "primary", (ArtPath((outer, sq(3, 3, 7, 7, ccw=False)), (True, True), Style(fill_rule="nonzero")),)
    )
    assert ev.art_geometry(eo).area == pytest.approx(84.0)
    assert ev.art_geometry(nz_same).area == pytest.approx(100.0)
    assert ev.art_geometry(nz_opp).area == pytest.approx(84.0)
    # three nested levels, alternating orientation: ring with an island
    island = PlacedArt(
        "a",
        "primary",
        (ArtPath((outer, sq(2, 2, 8, 8, ccw=False), sq(4, 4, 6, 6)), (True,) * 3, Style()),),
    )
    assert ev.art_geometry(island).area == pytest.approx(100 - 36 + 4)
    # evenodd with a partial overlap: symmetric difference
    eo2 = PlacedArt("a", "primary", (ArtPath((sq(0, 0, 2, 2), sq(1, 1, 3, 3)), (True, True), Style(fill_rule="evenodd")),))
    assert ev.art_geometry(eo2).area == pytest.approx(8 - 2)


def test_art_geometry_self_intersecting_star():
    t = np.linspace(0, 4 * np.pi, 6)[:-1]
    star = np.c_[np.cos(t), np.sin(t)] * 10
    nz = ev.art_geometry(PlacedArt("s", "primary", (ArtPath((star,), (True,), Style(fill_rule="nonzero")),)))
    eo = ev.art_geometry(PlacedArt("s", "primary", (ArtPath((star,), (True,), Style(fill_rule="evenodd")),)))
    assert nz.is_valid and eo.is_valid
    assert nz.area > eo.area * 1.3  # nonzero fills the central pentagon


def test_art_geometry_strokes():
    line = np.array([[0.0, 0.0], [10.0, 0.0]])
    mk = lambda cap: PlacedArt(  # noqa: E731
        "l",
        "secondary",
        (ArtPath((line,), (False,), Style(fill=None, stroke="#000", stroke_width=2.0, stroke_linecap=cap)),),
        stroke_scale=1.5,
    )
    assert ev.art_geometry(mk("butt")).area == pytest.approx(10 * 3.0, rel=1e-9)
    assert ev.art_geometry(mk("square")).area == pytest.approx(13 * 3.0, rel=1e-9)
    assert ev.art_geometry(mk("round")).area == pytest.approx(30 + math.pi * 1.5**2, rel=2e-3)
    # closed ring stroke with mitre joins: 11² − 9²
    ring = PlacedArt("r", "primary", (ArtPath((sq(0, 0, 10, 10),), (True,), Style(fill=None, stroke="#000")),))
    assert ev.art_geometry(ring).area == pytest.approx(40.0)
    # polyline stroke: sum of segment lengths x width (round joins add a bit)
    zig = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    pa = PlacedArt("z", "primary", (ArtPath((zig,), (False,), Style(fill=None, stroke="#000", stroke_width=0.5)),))
    assert ev.art_geometry(pa).area == pytest.approx(20 * 0.5, rel=0.02)


def test_art_geometry_fill_open_subpath_and_invisible():
    tri = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]])
    filled = PlacedArt("t", "primary", (ArtPath((tri,), (False,), Style()),))
    assert ev.art_geometry(filled).area == pytest.approx(6.0)
    none = PlacedArt("t", "primary", (ArtPath((tri,), (False,), Style(fill=None)),))
    assert ev.art_geometry(none).is_empty
    hidden = PlacedArt("t", "primary", (ArtPath((tri,), (True,), Style(opacity=0.0)),))
    assert ev.art_geometry(hidden).is_empty
    both = PlacedArt(
        "t", "primary", (ArtPath((sq(0, 0, 10, 10),), (True,), Style(fill="#fff", stroke="#000", stroke_width=2)),)
    )
    assert ev.art_geometry(both).area == pytest.approx(144.0)  # fill + outer half of the stroke
    degenerate = PlacedArt("d", "primary", (ArtPath((np.array([[0.0, 0], [1, 1]]),), (True,), Style()),))
    assert ev.art_geometry(degenerate).is_empty


# --------------------------------------------------------------------------- evaluate


CONTRACT = {
    "area_fraction", "overlap_area", "n_primary", "n_secondary", "n_outside", "gap",
    "deformation", "scp", "scp_at_half_gap", "scp_ratio",
}


@pytest.fixture(scope="module")
def evaluated():
    c, arts = ev.perturbed_squares_reference(30.0, 10.0, 400.0, 11)
    kinds = ["primary" if i % 3 else "secondary" for i in range(len(arts))]
    defs = [None if i == 0 else 0.01 * i for i in range(len(arts))]
    container = Container(source="c.svg", region=c)
    return ev.evaluate(container, placed_from(arts, kinds, defs), gap=10.0, grid=500)


def test_evaluate_contract(evaluated):
    res = evaluated
    assert CONTRACT <= set(res)
    assert {"median", "p10", "p90", "requested"} <= set(res["gap"])
    assert {"mean", "max", "values"} <= set(res["deformation"])
    assert {"r", "q", "h"} <= set(res["scp"])
    assert res["n_primary"] + res["n_secondary"] == 100 and res["n_secondary"] == 34
    json.loads(json.dumps(res, allow_nan=False))
    assert abs(res["scp"]["q"][0] - (1 - res["area_fraction"])) <= 0.01
    assert 5.0 in res["scp"]["r"] and res["scp"]["r"][-1] >= 15.0
    assert res["scp_at_half_gap"] == res["scp"]["q"][res["scp"]["r"].index(5.0)]
    assert res["scp_ratio"] == pytest.approx(res["scp_at_half_gap"] / res["scp"]["q"][0])
    assert res["deformation"]["values"][0] is None
    assert res["deformation"]["max"] == pytest.approx(0.99)
    assert res["overlap_area"] == 0.0
    assert res["gap"]["requested"] == 10.0 and 5.0 < res["gap"]["median"] < 15.0
    assert res["scp"]["h"][0] == 0.0


def test_evaluate_rejects_bad_gap():
    with pytest.raises(ParameterError):
        ev.evaluate(Container("c", box(0, 0, 1, 1)), [], gap=0.0)


def test_evaluate_empty_packing():
    res = ev.evaluate(Container("c", box(0, 0, 10, 10)), [], gap=1.0, grid=100)
    assert res["area_fraction"] == 0.0 and res["scp"]["q"][0] == pytest.approx(1.0)
    assert res["gap"]["median"] is None and res["deformation"]["mean"] is None
    json.dumps(res, allow_nan=False)


def test_evaluate_file_uses_data_gap(monkeypatch):
    import repulsionpak.io as rio

    c, arts = ev.square_grid_reference(10, 5, 60)
    meta = {"gap": "5"}
    monkeypatch.setattr(rio, "read_packing_svg", lambda p: (Container("c", c), placed_from(arts), meta), raising=False)
    res = ev.evaluate_file("x.svg", grid=200)
    assert res["gap"]["requested"] == 5.0 and res["file"] == "x.svg"
    assert ev.evaluate_file("x.svg", gap=4.0, grid=200)["gap"]["requested"] == 4.0
    meta.clear()
    with pytest.raises(ParameterError):
        ev.evaluate_file("x.svg", grid=200)


def test_format_table(evaluated):
    text = ev.format_table(evaluated)
    lines = text.splitlines()
    assert lines[0].startswith("metric")
    assert any(l.startswith("area fraction") and f"{evaluated['area_fraction']:.4f}" in l for l in lines)
    assert any("Q_s(gap/2)" in l for l in lines)
    starts = {l.index(l.split("  ")[-1].strip()) for l in lines[2:] if "  " in l}
    assert len(starts) == 1  # values aligned in one column


# --------------------------------------------------------------------------- plots


def test_scp_plot_png(squares_scp, stripes_scp):
    png = ev.scp_plot_png([("squares", squares_scp[2]), ("stripes", stripes_scp[2])], gap=GAP)
    assert len(png) > 5000
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ParameterError):
        ev.scp_plot_png([], gap=GAP)


def test_scp_bands_png(squares_scp):
    groups = {}
    for k, label in enumerate(["rotated", "translated"]):
        res = []
        for seed in range(3):
            c, a = ev.perturbed_squares_reference(SIDE, GAP, 300.0, seed, rotate=k == 0, translate=k == 1)
            res.append(ev.scp(c, a, grid=300, gap=GAP))
        groups[label] = res
    groups["grid"] = [squares_scp[2]]
    png = ev.scp_bands_png(groups, GAP)
    assert len(png) > 5000 and png[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ParameterError):
        ev.scp_bands_png({}, GAP)


def test_area_fraction_unites_only_elements_that_meet(monkeypatch):
    """area_fraction: overlaps are counted once, art outside the container not at all,
    and only clusters of intersecting elements are united (one union of a whole packing
    of dotted art noded 27,000 polygons together: 4 s for what is a sum of areas)."""
    rng = np.random.default_rng(3)
    region = box(0, 0, 100, 100)
    dotted = [shapely.union_all([Point(x + 1.5 * i, y + 1.5 * j).buffer(0.5) for i in range(4) for j in range(4)])
              for x, y in rng.uniform(2, 90, (30, 2)) // 10 * 10]
    dotted = [g for k, g in enumerate(dotted) if not any(g.intersects(h) for h in dotted[:k])]
    pair = [box(40, 95, 60, 110), box(50, 90, 70, 98)]  # overlapping, and partly outside
    geoms = dotted + pair
    want = shapely.intersection(shapely.union_all(geoms), region).area / region.area
    united: list[int] = []
    union_all = coverage.robust_union_all

    def spy(gs, **kw):
        united.append(len(list(gs)))
        return union_all(gs, **kw)

    monkeypatch.setattr(coverage, "robust_union_all", spy)
    got = coverage.area_fraction(region, geoms)
    assert got == pytest.approx(want, rel=1e-12)
    assert united == [2]  # the overlapping pair only
    assert coverage.area_fraction(region, []) == 0.0


def test_primaries_alone_and_the_smallest_copy():
    """evaluate() measures the primaries without the pocket copies (area fraction and
    Q_s(gap/2)/Q_s(0) of their art only) and the smallest copy against the median
    primary (square roots of art areas); every earlier key stays."""
    cont = Container("c.svg", box(0, 0, 100, 100))
    prim = [box(5, 5, 45, 45), box(55, 5, 95, 45), box(5, 55, 35, 85)]  # sizes 40, 40, 30
    sec = [box(60, 60, 68, 68), box(75, 75, 87, 87)]  # sizes 8 and 12
    placed = placed_from(prim + sec, kinds=["primary"] * 3 + ["secondary"] * 2)
    r = ev.evaluate(cont, placed, gap=4.0, grid=400)
    assert r["n_primary"] == 3 and r["n_secondary"] == 2
    assert r["area_fraction"] == pytest.approx((1600 + 1600 + 900 + 64 + 144) / 1e4)
    assert r["area_fraction_primary"] == pytest.approx(4100 / 1e4)
    assert r["median_primary_size"] == pytest.approx(40.0)
    assert r["smallest_secondary_rel"] == pytest.approx(8.0 / 40.0)
    alone = ev.evaluate(cont, placed[:3], gap=4.0, grid=400)
    assert r["scp_ratio_primary"] == pytest.approx(alone["scp_ratio"])
    assert r["scp_ratio_primary"] > r["scp_ratio"]  # the copies sit in the largest void
    assert alone["smallest_secondary_rel"] is None
    quick = ev.evaluate(cont, placed, gap=4.0, grid=400, with_scp=False)
    assert quick["scp_ratio_primary"] is None and quick["area_fraction_primary"] == r["area_fraction_primary"]
    assert ev.evaluate(cont, placed, gap=4.0, grid=400, with_scp=False,
                       primary_scp=True)["scp_ratio_primary"] == pytest.approx(r["scp_ratio_primary"])
    table = ev.format_table(r)
    assert "primaries alone: area fraction" in table and "0.2000" in table


def test_evaluate_is_a_function_and_measure_its_package():
    """``repulsionpak.evaluate`` is the function (``repulsionpak.measure.evaluate``), not
    also a module of that name."""
    assert repulsionpak.evaluate is ev.evaluate and callable(ev.evaluate)
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("repulsionpak.evaluate")
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("repulsionpak.metrics")


def test_the_library_imports_and_measures_without_matplotlib():
    """matplotlib is imported by the plots only: with it missing, the library imports and
    measures, and a plot says what is missing."""
    code = """
import sys
sys.modules["matplotlib"] = None  # as if it were not installed
import repulsionpak, repulsionpak.measure as m
c, a = m.stripes_reference(10.0, 5.0, 90.0)
r = m.scp(c, a, grid=90, gap=5.0)
assert abs(r["q0"] - 5.0 / 15.0) < 1e-9, r["q0"]
try:
    m.scp_plot_png([("s", r)], gap=5.0)
except ImportError:
    print("no matplotlib")
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "no matplotlib"


def _imports_of(path) -> set[str]:
    """Absolute names of the repulsionpak modules ``path`` imports, inside functions too."""
    import ast
    from pathlib import Path

    path = Path(path)
    package = ["repulsionpak", *path.parent.relative_to(Path(repulsionpak.__file__).parent).parts]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            name = ".".join(base + ([node.module] if node.module else []))
            out |= {name} if node.module else {f"{name}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
    return {n for n in out if n.startswith("repulsionpak")}


def test_measure_and_checks_point_down():
    """measure/ imports no writer and nothing above it (stages, render, pack, the CLI);
    verify/checks measures without the repairs."""
    from pathlib import Path

    root = Path(repulsionpak.__file__).parent
    above = ("repulsionpak.render", "repulsionpak.io.files", "repulsionpak.pack", "repulsionpak.verify",
             "repulsionpak.secondary", "repulsionpak.holes", "repulsionpak.sim", "repulsionpak.cli",
             "repulsionpak.live", "repulsionpak.batch", "repulsionpak.kernel_cache")
    files = sorted((root / "measure").glob("*.py"))
    assert len(files) >= 10
    for f in files:
        bad = {n for n in _imports_of(f) if n == "repulsionpak" or n.startswith(above)}
        assert not bad, f"{f.name} imports {sorted(bad)}"
    assert "repulsionpak.measure.evaluation" in _imports_of(root / "measure" / "__init__.py")
    assert not {n for n in _imports_of(root / "verify" / "checks.py") if n.startswith("repulsionpak.verify")}
