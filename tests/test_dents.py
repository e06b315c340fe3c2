"""The repair by local bending (repulsionpak.verify.dents), on geometry built by hand: a
contact bent away clears the gap floor and the margin where shrinking would cost the
whole element, the art away from the contact stays put, frozen copies keep their shape,
and curves stay what is written."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from repulsionpak.types import ArtPath, PlacedArt, Style
from repulsionpak.verify import dent, verify_and_repair

CONTAINER = shapely.box(0, 0, 200, 100)
GAP = 2.0


def poly(pts, source="p.svg", **kw):
    return PlacedArt(source, "primary", (ArtPath((np.asarray(pts, dtype=float),), (True,), Style()),), **kw)


def bar_with_tip(x0, y0, length=60.0, width=16.0, tip=3.0):
    """A bar along x with a short tip sticking out of its right end's middle."""
    x1 = x0 + length
    return poly([[x0, y0], [x1, y0], [x1, y0 + 6], [x1 + tip, y0 + 7], [x1 + tip, y0 + 9], [x1, y0 + 10],
                 [x1, y0 + width], [x0, y0 + width]])


def square(x, y, side=30.0):
    return poly([[x, y], [x + side, y], [x + side, y + side], [x, y + side]])


def test_a_tip_too_close_is_bent_away_and_the_rest_stays():
    a = bar_with_tip(20, 40)  # tip ends at x = 83
    b = square(84.0, 33.0)  # 1.0 from the tip: half the gap floor of 1.8
    out, res = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP)
    d = shapely.distance(out[0].art, out[1].art)
    assert d >= 0.9 * GAP
    assert res.violations[0] == 1  # (later rounds chase the 6 % slack above the floor)
    assert set(res.dented) == {0, 1}
    # far from the contact nothing moved: the bar's left end and the square's right side
    assert np.allclose(out[0].paths[0].subpaths[0][[0, -1]], a.paths[0].subpaths[0][[0, -1]], atol=1e-6)
    assert np.allclose(out[1].paths[0].subpaths[0][[1, 2]], b.paths[0].subpaths[0][[1, 2]], atol=1e-6)
    # and the area kept is nearly all: shrinking the bar about its centre by the half of
    # 0.9 it clears would have cost ~2.8 % of it
    assert out[0].art.area > 0.99 * a.art.area and out[1].art.area > 0.995 * b.art.area


def test_dents_before_the_repair_keep_more_area_than_shrinking():
    # jammed between the container's sides (margin 1): no move clears the contact
    a = bar_with_tip(1.1, 40)  # tip ends at x = 64.1
    b = poly([[65.1, 20], [198.9, 20], [198.9, 80], [65.1, 80]])
    shrunk, v0 = verify_and_repair([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP, grow_to=0.0)
    bent, _ = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP)
    repaired, v1 = verify_and_repair(bent, CONTAINER, GAP, 1.0, 0.9 * GAP, grow_to=0.0)
    assert v0.ok and v1.ok
    assert min(v0.shrunk.values()) < 0.99  # without the dents something shrank
    assert all(s >= 0.999 for s in v1.shrunk.values())  # with them nothing had to
    assert sum(p.art.area for p in repaired) > sum(p.art.area for p in shrunk) + 10.0


def test_an_element_too_near_the_edge_is_bent_inside_the_margin():
    a = poly([[10, 0.5], [60, 0.5], [60, 30], [10, 30]])  # 0.5 from the top edge, margin 1
    (out,), res = dent([a], CONTAINER, GAP, 1.0, 0.9 * GAP)
    assert shapely.distance(out.art, CONTAINER.boundary) >= 1.0
    assert res.dented == (0,)


def test_a_frozen_copy_keeps_its_shape_and_the_other_gives_way_alone():
    a = bar_with_tip(20, 40)
    b = square(84.0, 33.0)
    out, res = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP, frozen=np.array([False, True]))
    assert out[1] is b
    assert shapely.distance(out[0].art, out[1].art) >= 0.9 * GAP
    assert res.dented == (0,)


def test_a_dent_beyond_the_shape_limit_is_undone():
    a, b = bar_with_tip(20, 40), square(84.0, 33.0)
    out, res = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP, rest=[a, b], limits=np.array([1e-6, np.inf]))
    assert out[0] is a and res.reverted == (0,)
    assert out[1] is not b  # unlimited: keeps its dent


def test_a_dent_beyond_the_shape_limit_keeps_the_part_that_fits():
    from repulsionpak.verify.repairs import rest_distortion

    a, b = bar_with_tip(20, 40), square(84.0, 33.0)
    full, _ = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP, frozen=np.array([False, True]))
    bent = rest_distortion(a, a, full[0].art)
    assert bent > 1e-4
    limit = 0.5 * bent
    out, res = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP, rest=[a, b], limits=np.array([limit, np.inf]),
                    frozen=np.array([False, True]))
    assert res.reverted == (0,) and out[0] is not a  # over its limit, yet bent
    assert rest_distortion(a, a, out[0].art) <= limit
    # about half of the way: the contact is partly cleared, not as far as unlimited
    d0, d1 = (shapely.distance(x.art, b.art) for x in (a, full[0]))
    assert d0 + 0.25 * (d1 - d0) < shapely.distance(out[0].art, b.art) < d1 - 0.1 * (d1 - d0)


def test_parts_of_an_art_a_hair_apart_are_measured_after_a_bump_pushes_one_across():
    # a wide bar and a spike whose tip is a hair above the bar's top edge, as the strokes
    # of an emoji meet: a bump at the spike's top moves the tip down more than the bar's
    # far corners move the edge, and the bumped outline crosses itself (GEOS then failed
    # on the dents' next measure: "side location conflict")
    from repulsionpak.verify.dents import _bumped_outline

    bar = np.array([[10.0, 40], [110, 40], [110, 50], [10, 50]])
    spike = np.array([[55.0, 62], [65, 62], [60, 50 + 1e-9]])
    art = PlacedArt("p.svg", "primary", (ArtPath((bar, spike), (True, True), Style()),))
    assert art.art.is_valid
    moved = _bumped_outline(art.art, [(np.array([60.0, 62.0]), np.array([0.0, -1.0]))], 2.0 * 4.0 ** 2)
    assert moved.is_valid and moved.area > 0.99 * art.art.area
    lid = square(40.0, 63.0)  # 1.0 above the spike's top: a bump pushes the spike down
    out, _ = dent([art, lid], CONTAINER, GAP, 1.0, 0.9 * GAP, radius=2.0)
    assert shapely.distance(out[0].art, out[1].art) > 1.0 + 0.5  # bent away, no GEOS error


def test_off_or_nothing_to_do_returns_the_same_objects():
    a, b = bar_with_tip(20, 40), square(120.0, 33.0)
    out, res = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP)
    assert out[0] is a and out[1] is b and res.dented == ()
    a, b = bar_with_tip(20, 40), square(84.0, 33.0)
    out, res = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP, rounds=0)
    assert out[0] is a and out[1] is b


def test_bent_curves_are_flattened_as_they_are_written(tmp_path):
    from repulsionpak.geometry.curves import flatten_subpath
    from repulsionpak.io import load_element
    from repulsionpak.render.placed import FLATTEN_SHARE, refined

    f = tmp_path / "disc.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 '<circle cx="50" cy="50" r="50"/></svg>')
    el = load_element(f)
    tol = 1e-3
    disc = PlacedArt(str(f), "primary", tuple(refined(a.transformed(lambda p: np.asarray(p) * 0.4 + [10.0, 10.0]), tol)
                                              for a in el.paths), tolerance=tol)  # r = 20 about (30, 30)
    wall = poly([[51.0, 0.0], [80, 0], [80, 60], [51.0, 60]])  # 1.0 from the disc
    # a broad contact (the disc is closer than the floor to the wall over ~6 gaps): bumps
    # two gaps wide clear it in the three rounds
    out, _ = dent([disc, wall], CONTAINER, GAP, 0.5, 0.9 * GAP, radius=2.0)
    bent = out[0].paths[0]
    assert shapely.distance(out[0].art, out[1].art) >= 0.9 * GAP
    exact = shapely.LinearRing(flatten_subpath(bent.source.curves[0], 1e-6))
    p = bent.subpaths[0]
    assert shapely.distance(exact, shapely.points(p)).max() <= FLATTEN_SHARE * tol * 1.01


def test_an_overlap_is_parted_along_the_line_between_the_two_arts():
    a = bar_with_tip(20, 40)  # tip from x = 80 to 83
    b = square(82.0, 33.0)  # the tip 1.0 deep in the square: 2.9 to part, at most 2 a round
    out, res = dent([a, b], CONTAINER, GAP, 1.0, 0.9 * GAP, rounds=8)
    assert shapely.intersection(a.art, b.art).area > 0.5
    assert shapely.distance(out[0].art, out[1].art) >= 0.9 * GAP
    # parted along x (the arts' line), not sideways: the tip is still level with its bar
    tip = out[0].paths[0].subpaths[0][3:5]
    assert np.allclose(tip[:, 1], [47.0, 49.0], atol=0.05)


def test_bending_keeps_smooth_joins_smooth(tmp_path):
    from repulsionpak.io import load_element
    from repulsionpak.render.placed import refined

    f = tmp_path / "disc.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 '<circle cx="50" cy="50" r="50"/></svg>')
    el = load_element(f)
    disc = PlacedArt(str(f), "primary", tuple(refined(a.transformed(lambda p: np.asarray(p) * 0.4 + [10.0, 10.0]), 1e-3)
                                              for a in el.paths), tolerance=1e-3)
    wall = poly([[50.5, 0.0], [80, 0], [80, 60], [50.5, 60]])  # 0.5 from the disc: a deep dent
    (bent, _), _ = dent([disc, wall], CONTAINER, GAP, 0.5, 0.9 * GAP, frozen=np.array([False, True]))
    c = bent.paths[0].source.curves[0]
    orig = disc.paths[0].source.curves[0].ctrl
    assert c.ctrl.shape != orig.shape or not np.allclose(c.ctrl, orig)  # bent
    for k in range(len(c.order)):  # every join of the circle's arcs stays tangent-continuous
        j = (k + 1) % len(c.order)
        u = c.ctrl[k, int(c.order[k])] - c.ctrl[k, int(c.order[k]) - 1]
        v = c.ctrl[j, 1] - c.ctrl[j, 0]
        assert abs(u[0] * v[1] - u[1] * v[0]) <= 1e-3 * np.hypot(*u) * np.hypot(*v)


def test_a_dent_in_segments_longer_than_the_bump_stays_local(tmp_path):
    """A disc of radius 60 written as arcs ~90 long, pressed to a wall: the dent (ρ = 2
    gaps = 4) moves the outline near the contact and leaves the rest on the circle, as
    the bump does. Bent through their ends and handles alone, the arcs spread the dent
    over their whole length (0.3-0.9 off the circle 18 from the contact)."""
    from repulsionpak.io import load_element
    from repulsionpak.render.placed import refined

    f = tmp_path / "disc.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 '<circle cx="50" cy="50" r="50"/></svg>')
    el = load_element(f)
    tol = 0.04
    box = shapely.box(0, 0, 400, 200)
    for wall_x in (130.5, 131.0, 131.5):  # the disc's right side is at x = 130
        disc = PlacedArt(str(f), "primary", tuple(refined(a.transformed(lambda p: np.asarray(p) * 1.2 + 10.0), tol)
                                                  for a in el.paths), tolerance=tol)  # r = 60 about (70, 70)
        wall = poly([[wall_x, 0.0], [200, 0], [200, 150], [wall_x, 150]])
        (bent, _), _ = dent([disc, wall], box, GAP, 0.5, 0.9 * GAP, radius=2.0, frozen=np.array([False, True]))
        assert shapely.distance(bent.art, wall.art) >= 0.9 * GAP
        pts = shapely.get_coordinates(bent.art.exterior)
        r = np.hypot(pts[:, 0] - 70.0, pts[:, 1] - 70.0)
        assert r.min() < 60.0 - 0.4  # dented
        far = np.hypot(pts[:, 0] - 130.0, pts[:, 1] - 70.0) > 4.5 * 2.0 * GAP
        assert np.abs(r[far] - 60.0).max() <= tol


def test_arts_a_hair_apart_count_as_touching_without_breaking_the_overlap_parting():
    """Two arts 1e-10 apart (closer than the distance test's 1e-9, yet not intersecting)
    among real overlaps: their empty overlap must not shift the others' points."""
    a = bar_with_tip(20, 40)
    b = square(82.0, 33.0)  # overlaps a's tip
    c = square(20.0, 56.0 + 1e-10, side=20.0)  # a hair below a's bottom edge (y = 56)
    d = square(120.0, 20.0)
    e = square(151.0, 20.0, side=20.0)  # 1.0 from d: apart, too close
    out, res = dent([a, b, c, d, e], CONTAINER, GAP, 1.0, 0.9 * GAP, rounds=8)
    assert shapely.distance(out[0].art, out[1].art) >= 0.9 * GAP
    assert shapely.distance(out[3].art, out[4].art) >= 0.9 * GAP


def test_a_container_narrower_than_twice_the_margin_bends_nothing_at_its_edge():
    a = poly([[10, 1.0], [60, 1.0], [60, 2.0], [10, 2.0]])
    (out,), res = dent([a], shapely.box(0, 0, 200, 3), GAP, 2.0, 0.9 * GAP)
    assert out is a and res.dented == ()


def test_the_bump_map_and_its_jacobian_are_the_gaussian_sum_and_its_derivative():
    """The compiled bump map: a point moves by Σ v·exp(−|p − c|²/2ρ²) (weights taken at
    the unmoved point), and the Jacobian is that map's derivative (central differences)."""
    from repulsionpak.verify.dents import _bumped, _bumped_with_jacobians

    rho = 1.7
    two_rho2 = 2.0 * rho ** 2
    bumps = [(np.array([0.0, 0.0]), np.array([0.5, -0.2])), (np.array([1.0, 2.0]), np.array([-0.3, 0.4]))]
    pts = np.array([[0.0, 0.0], [rho, 0.0], [1.0, 2.0], [0.3, -0.8], [40.0, 40.0]])
    moved = _bumped(pts, bumps, two_rho2)
    want = pts.copy()
    for c, v in bumps:
        want += np.exp(-((pts - c) ** 2).sum(axis=1) / two_rho2)[:, None] * v
    assert np.allclose(moved, want, rtol=0, atol=1e-14)
    assert np.allclose(moved[1] - pts[1], 0.5 * np.exp(-0.5) * np.array([1.0, -0.4])
                       + np.exp(-((rho - 1.0) ** 2 + 4.0) / two_rho2) * np.array([-0.3, 0.4]), atol=1e-14)
    assert np.array_equal(moved[4], pts[4])  # far from every bump: unmoved (to the last bit)
    assert _bumped(pts.reshape(5, 1, 2), bumps, two_rho2).shape == (5, 1, 2)  # any leading shape
    jac = _bumped_with_jacobians(pts, bumps, two_rho2)[1]
    h = 1e-6
    for k in range(2):
        e = np.zeros(2)
        e[k] = h
        fd = (_bumped(pts + e, bumps, two_rho2) - _bumped(pts - e, bumps, two_rho2)) / (2 * h)
        assert np.allclose(jac[:, :, k], fd, atol=1e-8)
    assert np.allclose(jac[4], np.eye(2), rtol=0, atol=1e-200)


@pytest.mark.parametrize("batch", [1, 64])
def test_copies_bent_together_are_bent_as_each_alone_to_the_bit(tmp_path, monkeypatch, batch):
    """The dents bend the copies in batches of arrays (``BATCH`` at a time); each copy's
    art must be what bending it alone gives, and its points the flattening of its written
    (rounded) curves."""
    from repulsionpak.io import load_element
    from repulsionpak.render.placed import refined
    from repulsionpak.verify import dents

    monkeypatch.setattr(dents, "BATCH", batch)

    f = tmp_path / "disc.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">'
                 '<circle cx="50" cy="50" r="50"/></svg>')
    el = load_element(f)
    box = shapely.box(0, 0, 400, 100)

    def disc(x0, scale, tol):
        return PlacedArt(str(f), "primary", tuple(refined(a.transformed(lambda p: np.asarray(p) * scale + [x0, 10.0]),
                                                          tol) for a in el.paths), tolerance=tol)

    pairs = [(disc(10.0, 0.4, 1e-3), poly([[50.6, 0.0], [80, 0], [80, 60], [50.6, 60]])),
             (disc(150.0, 0.6, 4e-3), poly([[210.8, 0.0], [240, 0], [240, 80], [210.8, 80]]))]
    frozen = np.array([False, True])
    alone = [dent(list(p), box, GAP, 0.5, 0.9 * GAP, frozen=frozen)[0] for p in pairs]
    together, res = dent([pairs[0][0], pairs[0][1], pairs[1][0], pairs[1][1]], box, GAP, 0.5, 0.9 * GAP,
                         frozen=np.array([False, True, False, True]))
    assert res.dented == (0, 2)
    for a, b, tol in ((alone[0][0], together[0], 1e-3), (alone[1][0], together[2], 4e-3)):
        assert a is not None and len(a.paths) == len(b.paths)
        for pa, pb in zip(a.paths, b.paths):
            for sa, sb in zip(pa.subpaths, pb.subpaths):
                assert np.array_equal(sa, sb)
            for ca, cb in zip(pa.source.curves, pb.source.curves):
                assert np.array_equal(ca.ctrl, cb.ctrl) and np.array_equal(ca.order, cb.order)
            again = refined(pb, tol)  # written curves, flattened as the writer's are: the same points
            assert all(np.array_equal(s, t) for s, t in zip(again.subpaths, pb.subpaths))
