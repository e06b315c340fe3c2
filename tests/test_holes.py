"""Hole fill: the holes of packed rings and letters' counters get undeformed copies, a gap
away from their host, and the negative space gets more even."""

import dataclasses
import itertools
import math

import numpy as np
import pytest
import shapely

import scenes
from repulsionpak.types import ElementControls
from repulsionpak.errors import ConfigError, ParameterError
from repulsionpak.measure import art_geometry, scp
from repulsionpak.art_area import art_area
from repulsionpak.holes import HoleLibrary, fill_holes, fill_pockets
from repulsionpak.io import load_container, load_element, read_packing_svg
from repulsionpak.pack import pack
from repulsionpak.params import Params, params_from_dict
from repulsionpak.types import PlacedArt

GAP = 12.0


@pytest.fixture(scope="module")
def ring_scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("rings")
    (d / "ring.svg").write_text(scenes.element_svg("ring"))
    (d / "o.svg").write_text(scenes.glyph_svg("O"))
    (d / "circle.svg").write_text(scenes.container_svg("circle", size=600))
    cont = load_container(d / "circle.svg")
    elems = [load_element(d / "ring.svg"), load_element(d / "o.svg")]
    params = params_from_dict({"gap": GAP, "seed": 2, "placement": {"count": 8},
                               "secondary": {"fill_holes": False, "fill_leftover": False}})
    packing = pack(cont, elems, params)
    return cont, elems, packing


def _ratio(cont, placed):
    r = scp(cont.region, [art_geometry(p) for p in placed], gap=GAP)
    i = int(np.argmin(np.abs(np.asarray(r["r"]) - GAP / 2)))
    return r["q"][i] / r["q"][0]


def test_holes_get_copies_a_gap_from_their_host(ring_scene):
    cont, elems, packing = ring_scene
    placed = packing.placed
    big = 0  # holes whose free part (shrunk by the gap) holds a circle of radius GAP
    for p in placed:
        g = art_area(p.paths, p.stroke_scale)
        for poly in getattr(g, "geoms", [g]):
            for ring in poly.interiors:
                free = shapely.Polygon(ring).buffer(-1.005 * GAP)
                if not free.is_empty and shapely.maximum_inscribed_circle(free).length >= GAP:
                    big += 1
    assert big >= 4  # the rings and the Os of the packing
    extra = fill_holes(placed, HoleLibrary.of(elems), GAP, np.random.default_rng(0), min_radius=GAP)
    assert len(extra) >= big  # every big hole got one (some copies got their own)
    geoms = [art_area(p.paths, p.stroke_scale) for p in placed]
    for e in extra:
        g = art_area(e.paths, e.stroke_scale)
        assert e.kind == "secondary" and e.deformation == 0.0
        assert cont.region.contains(g)
        others = geoms + [art_area(x.paths, x.stroke_scale) for x in extra if x is not e]
        d = min(float(shapely.distance(g, o)) for o in others)
        assert d >= GAP, d  # never closer than the gap ...
        assert d <= 1.1 * GAP, d  # ... and grown until it touches the hole's free part
    # the holes were the big pockets: the negative space gets much more even
    before, after = _ratio(cont, placed), _ratio(cont, placed + extra)
    assert after < 0.75 * before, (before, after)


def test_hole_copies_are_undeformed_and_keep_their_rotation_control(ring_scene):
    cont, elems, packing = ring_scene
    fixed = [dataclasses.replace(elems[0], controls=ElementControls(rotation="fixed", angle=30.0)),
             dataclasses.replace(elems[1], controls=ElementControls(weight=0.0))]  # weight 0: never used
    extra = fill_holes(packing.placed, HoleLibrary.of(fixed), GAP, np.random.default_rng(1), min_radius=GAP)
    assert extra and all(e.source == elems[0].source for e in extra)
    for e in extra:
        m = e.frame
        angle = math.degrees(math.atan2(m[1, 0], m[0, 0]))
        assert abs(angle - 30.0) < 1e-6
        # undeformed: the written curves are the source's under the similarity (rounded
        # to the written decimals)
        for a_src, a_out in zip(elems[0].paths, e.paths):
            for c_src, c_out in zip(a_src.source.curves, a_out.source.curves):
                exact = c_src.ctrl @ m[:2, :2].T + m[:2, 2]
                assert np.abs(c_out.ctrl - exact).max() < 1e-3 * e.stroke_scale * 100
                assert np.abs(c_out.ctrl - exact).max() <= e.tolerance


def test_small_holes_are_left_alone(ring_scene):
    cont, elems, packing = ring_scene
    assert fill_holes(packing.placed, HoleLibrary.of(elems), GAP, np.random.default_rng(0),
                      min_radius=1000.0) == []
    assert HoleLibrary.of([dataclasses.replace(elems[0], controls=ElementControls(weight=0.0))]) is None


def test_holes_are_filled_only_when_asked(ring_scene):
    """A designer never wants a logo inside a logo: the holes stay empty by default
    (``--fill-holes`` asks for them), the leftover pockets are filled."""
    assert not Params().secondary.fill_holes and Params().secondary.fill_leftover
    from repulsionpak.cli import resolve_params

    off = resolve_params(pocket_fill=False).secondary
    assert not off.fill_holes and not off.fill_leftover and not off.auto
    with pytest.raises((ConfigError, ParameterError)):
        params_from_dict({"secondary": {"hole_min_radius": 0}})
    with pytest.raises((ConfigError, ParameterError)):
        params_from_dict({"secondary": {"min_size": -0.1}})


def test_leftover_fill_keeps_out_of_holes_unless_asked(tmp_path):
    """fill_pockets: the middle of a ring is a hole of its art, not a pocket: no copy goes
    there unless ``into_holes`` (the octocat got a YouTube logo in its belly)."""
    (tmp_path / "disc.svg").write_text(scenes.element_svg("disc"))
    ring = shapely.Point(200, 100).buffer(90, 64).difference(shapely.Point(200, 100).buffer(60, 64))
    d = " ".join("M" + " L".join(f"{x:.3f} {y:.3f}" for x, y in np.asarray(r.coords)) + " Z"
                 for r in (ring.exterior, *ring.interiors))
    (tmp_path / "ring.svg").write_text(
        f'<svg xmlns="http://www.w3.org/2000/svg" width="600" height="200"><path fill-rule="evenodd" d="{d}"/></svg>')
    (tmp_path / "box.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" width="600" height="200">'
                                      '<path d="M0 0H600V200H0Z"/></svg>')
    cont = load_container(tmp_path / "box.svg")
    host = load_element(tmp_path / "ring.svg")
    placed = [PlacedArt(host.source, "primary", host.paths)]
    lib = HoleLibrary.of([load_element(tmp_path / "disc.svg")])
    hole = shapely.Polygon(ring.interiors[0])
    for into, expect_inside in ((False, False), (True, True)):
        extra = fill_pockets(placed, lib, cont.region, 10.0, 5.0, np.random.default_rng(0), min_radius=5.0,
                             into_holes=into)
        inside = [e for e in extra if hole.contains(e.art)]
        assert extra and bool(inside) is expect_inside, (into, len(inside))
        assert all(shapely.distance(e.art, placed[0].art) >= 10.0 for e in extra)


def test_leftover_copies_are_never_below_the_size_floor(tmp_path):
    """fill_pockets with ``min_size``: the corners and the narrow ends of a pocket that took
    specks (copies a few gaps across beside 100-unit ones) get nothing smaller than the
    floor (the square root of a copy's art area, container units)."""
    _, specks = _fill_strip(tmp_path, 640, '<circle cx="320" cy="100" r="95"/>')
    sizes = sorted(math.sqrt(g.area) for g in specks)
    assert sizes[0] < 0.5 * sizes[-1]  # without a floor: small copies in the corners
    floor = 0.8 * sizes[-1]
    (tmp_path / "strip.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" width="640" height="200">'
                                        '<path d="M0 40H640V160H0Z"/><circle cx="320" cy="100" r="95"/></svg>')
    cont = load_container(tmp_path / "strip.svg")
    lib = HoleLibrary.of([load_element(tmp_path / "disc.svg")])
    kept = fill_pockets([], lib, cont.region, 10.0, 5.0, np.random.default_rng(0), min_radius=5.0, min_size=floor)
    assert kept and all(math.sqrt(e.art.area) >= floor for e in kept)
    _assert_gap_and_margin(cont, [e.art for e in kept])


def test_copies_in_a_pinched_hole_keep_the_gap_from_each_other(tmp_path):
    """A hole pinched in the middle splits into two free parts once shrunk by the gap:
    one copy each, a gap from the host and from each other (fill_holes also subtracts a
    copy's dilated art from the hole's other parts, for pinches sharper than this one)."""
    from repulsionpak.types import PlacedArt

    a = shapely.Point(100, 100).buffer(40, 64).union(shapely.Point(178, 100).buffer(40, 64))
    outer = a.buffer(30, 64)
    d = " ".join("M" + " L".join(f"{x:.3f} {y:.3f}" for x, y in np.asarray(r.coords)) + " Z"
                 for r in (outer.exterior, a.exterior))
    (tmp_path / "host.svg").write_text(
        f'<svg xmlns="http://www.w3.org/2000/svg" width="400" height="300"><path fill-rule="evenodd" d="{d}"/></svg>')
    (tmp_path / "bar.svg").write_text(scenes.element_svg("bar"))
    host = load_element(tmp_path / "host.svg")
    lib = HoleLibrary.of([load_element(tmp_path / "bar.svg")])
    placed = [PlacedArt(host.source, "primary", host.paths)]
    hg = art_area(host.paths)
    for seed in range(6):
        extra = fill_holes(placed, lib, GAP, np.random.default_rng(seed), min_radius=4.0, depth=1)
        gs = [art_area(e.paths, e.stroke_scale) for e in extra]
        assert len(gs) >= 2  # one per lobe
        for i, g in enumerate(gs):
            assert shapely.distance(g, hg) >= GAP
            for h in gs[i + 1:]:
                assert shapely.distance(g, h) >= GAP, seed


def test_leftover_pockets_get_copies_a_gap_from_everything(ring_scene):
    """fill_pockets: the room left after the verification (here: one primary taken out of
    the packing, as the verification does when it must drop one) gets undeformed copies,
    each a gap from all art and the margin from the edge."""
    cont, elems, packing = ring_scene
    placed = list(packing.placed)
    areas = [art_area(p.paths, p.stroke_scale).area for p in placed]
    del placed[int(np.argmax(areas))]  # a dropped primary leaves its room empty
    margin = GAP / 2
    extra = fill_pockets(placed, HoleLibrary.of(elems), cont.region, GAP, margin,
                         np.random.default_rng(0), min_radius=GAP)
    assert len(extra) >= 1
    geoms = [art_area(p.paths, p.stroke_scale) for p in placed]
    new = [art_area(e.paths, e.stroke_scale) for e in extra]
    biggest = max(g.area for g in new)
    assert biggest >= 0.3 * max(areas)  # the dropped element's room is used, not dusted
    for k, g in enumerate(new):
        assert cont.region.contains(g)
        assert g.distance(cont.region.boundary) >= margin
        assert min(g.distance(h) for h in geoms) >= GAP
        assert all(g.distance(h) >= GAP for j, h in enumerate(new) if j != k)
    assert all(e.kind == "secondary" and e.deformation == 0.0 for e in extra)
    # the negative space gets more even
    assert _ratio(cont, placed + extra) < _ratio(cont, placed) - 0.02


def _fill_strip(tmp_path, width: int, extra: str = "", min_radius: float = 5.0):
    """Leftover fill of discs in a strip ``width`` × 120 units (y 40–160), plus the
    ``extra`` markup; returns (container, the copies' art), gap 10, margin 5."""
    (tmp_path / "disc.svg").write_text(scenes.element_svg("disc"))
    (tmp_path / "strip.svg").write_text(
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="200">'
        f'<path d="M0 40H{width}V160H0Z"/>{extra}</svg>')
    cont = load_container(tmp_path / "strip.svg")
    lib = HoleLibrary.of([load_element(tmp_path / "disc.svg")])
    extra_copies = fill_pockets([], lib, cont.region, 10.0, 5.0, np.random.default_rng(0), min_radius=min_radius)
    return cont, [art_area(e.paths, e.stroke_scale) for e in extra_copies]


def _assert_gap_and_margin(cont, geoms, gap=10.0, margin=5.0):
    """Measured on the written curves' flattening: the fill fits those, not the source's
    coarser polylines (on which a disc came within 0.989 of the margin)."""
    assert all(g.distance(cont.region.boundary) >= margin for g in geoms)
    near = shapely.STRtree(geoms).query(geoms, predicate="dwithin", distance=gap)
    pairs = [(i, j) for i, j in near.T if i < j]
    assert all(geoms[i].distance(geoms[j]) >= gap for i, j in pairs)  # touching at gap exactly


def test_every_piece_of_a_split_pocket_gets_copies(tmp_path):
    """A long pocket with a bulge in the middle: the first copy goes in the bulge and
    splits the pocket in two; both pieces are filled (only the larger one was, and the
    other stayed empty)."""
    cont, geoms = _fill_strip(tmp_path, 640, '<circle cx="320" cy="100" r="95"/>')
    xs = sorted(g.centroid.x for g in geoms)
    assert len(geoms) >= 5  # ~100-unit discs along a 640-unit strip
    assert xs[0] < 160 and xs[-1] > 480  # both ends reached
    _assert_gap_and_margin(cont, geoms)


def test_a_long_pocket_gets_as_many_copies_as_it_holds(tmp_path):
    """A pocket that holds many copies gets them all, not a fixed handful: a 14,000-unit
    strip takes ~100 discs of ~100 units (up to 8 per pocket until November 26 left eight
    large L-shapes at a 0.5 % gap at Q_s(gap/2)/Q_s(0) 0.476; up to 64 left the one
    connected pocket between ten '5' glyphs 40 gaps tall at 0.604)."""
    cont, geoms = _fill_strip(tmp_path, 14000, min_radius=20.0)  # no corner copies
    big = [g for g in geoms if g.area > 0.5 * math.pi * 50 ** 2]  # the ~100-unit discs
    assert len(big) >= 90
    xs = sorted(g.centroid.x for g in big)
    assert xs[0] < 120 and xs[-1] > 13880 and max(np.diff(xs)) < 150  # the whole strip, no hole
    _assert_gap_and_margin(cont, geoms)


def test_hole_copies_keep_the_gap_from_their_host_s_island(tmp_path):
    """A bullseye (a ring with a disc in its hole) is one element: the copy put in its hole
    must keep the gap from the disc too (it was centred on the disc, inside the art)."""
    d = "M 2,50 A 48,48 0 1 1 98,50 A 48,48 0 1 1 2,50 Z " \
        "M 16,50 A 34,34 0 1 0 84,50 A 34,34 0 1 0 16,50 Z " \
        "M 36,50 A 14,14 0 1 1 64,50 A 14,14 0 1 1 36,50 Z"
    (tmp_path / "bullseye.svg").write_text(
        f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100"><path d="{d}"/></svg>')
    e = load_element(tmp_path / "bullseye.svg")
    host = PlacedArt(e.source, "primary", e.paths)
    gap = 2.0
    assert len(host.art.geoms) == 2  # the ring and the island
    extra = fill_holes([host], HoleLibrary.of([e]), gap, np.random.default_rng(0), min_radius=1.0, depth=1)
    assert extra  # the ring's inside between the disc and the ring holds small copies
    for c in extra:
        assert shapely.distance(c.art, host.art) >= gap
    for a, b in itertools.combinations(extra, 2):
        assert shapely.distance(a.art, b.art) >= gap


def test_bullseyes_in_a_target_keep_every_promise(tmp_path):
    """End to end (``repulsionpak pack``'s code path, measured on the written SVG): islands
    in the holes of the elements (the bullseye's disc) and of the container (the target's
    disc in its ring). The run overlapped 3% of its container before the hole fill kept
    the gap from a host's own island."""
    scene = scenes.Scene("bullseye-target", "target", ("bullseye",), gap=0.015, count=12, seed=3, scale=0.4)
    run = scenes.run_scene(scene, tmp_path)
    m = run["metrics"]
    assert run["report"]["invariants"]["ok"]
    assert any(p.kind == "secondary" for p in read_packing_svg(run["svg"])[1])
    p = m["promises"]
    assert p["overlap"]["ok"] and p["outside"]["ok"] and p["edge_margin"]["ok"], p
    assert p["gap_p10"]["ok"], p


def _dots_svg(nx: int, ny: int, x0: float = 20.0, y0: float = 60.0, step: float = 14.0, r: float = 4.0) -> str:
    d = "".join(f"M{x0 + i * step + r:g} {y0 + j * step:g}a{r:g} {r:g} 0 1 0 {-2 * r:g} 0a{r:g} {r:g} 0 1 0 {2 * r:g} 0Z"
                for i in range(nx) for j in range(ny))
    return f'<svg xmlns="http://www.w3.org/2000/svg" width="600" height="200"><path d="{d}"/></svg>'


@pytest.mark.parametrize("library", ["disc", "dots"])
def test_dotted_art_is_dilated_dot_by_dot_in_the_pocket_fill(tmp_path, monkeypatch, library):
    """Art of many parts (a grid of 40 dots as one element) is dilated part by part for
    the pocket fill: GEOS buffers a multipolygon as one outline, noding every part's
    offset curve together (100 dots whose buffers overlap: 16x slower than part by part,
    and the pocket fill of a 253-copy dotted packing spent 20 s there). The copies still
    keep the gap from every dot and the margin from the edge."""
    from repulsionpak.geometry.dilate import MANY_PARTS

    (tmp_path / "dots.svg").write_text(_dots_svg(8, 5))
    (tmp_path / "disc.svg").write_text(scenes.element_svg("disc"))
    (tmp_path / "strip.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" width="600" height="200">'
                                        '<path d="M0 40H600V160H0Z"/></svg>')
    cont = load_container(tmp_path / "strip.svg")
    dots = load_element(tmp_path / "dots.svg")
    art = art_area(dots.paths)
    assert len(art.geoms) == 40 > MANY_PARTS
    placed = [PlacedArt(dots.source, "primary", dots.paths, stroke_scale=1.0, deformation=0.0)]
    parts_buffered: list[int] = []
    buffer = shapely.buffer

    def spy(geom, *a, **kw):
        parts_buffered.extend(np.atleast_1d(shapely.get_num_geometries(geom)).tolist())
        return buffer(geom, *a, **kw)

    monkeypatch.setattr(shapely, "buffer", spy)
    lib = HoleLibrary.of([load_element(tmp_path / f"{library}.svg")])  # dots: the copies have 40 parts too
    extra = fill_pockets(placed, lib, cont.region, 10.0, 5.0, np.random.default_rng(0), min_radius=5.0)
    monkeypatch.undo()
    assert parts_buffered and max(parts_buffered) <= MANY_PARTS
    geoms = [art_area(e.paths, e.stroke_scale) for e in extra]
    assert len(geoms) >= (10 if library == "disc" else 2)  # the strip right of the dots is filled
    _assert_gap_and_margin(cont, geoms + [art])


def test_dilated_covers_the_same_region_as_a_whole_buffer():
    """dilated: art of few parts is buffered whole (the same vertices as before), art of
    many parts part by part: the union is the same region."""
    from repulsionpak.geometry.dilate import dilated

    dots = shapely.union_all([shapely.Point(x, y).buffer(3.0) for x in range(0, 100, 10) for y in range(0, 50, 10)])
    pair = shapely.MultiPolygon([shapely.box(0, 0, 5, 5), shapely.box(20, 0, 25, 5)])
    out = dilated([pair, shapely.Polygon(), dots], 4.0)
    assert shapely.equals_exact(out[0], pair.buffer(4.0, quad_segs=4), 0.0)
    assert len(out) == 1 + 50 and all(shapely.get_num_geometries(g) == 1 for g in out[1:])
    whole = dots.buffer(4.0, quad_segs=4)
    assert shapely.symmetric_difference(shapely.union_all(out[1:]), whole).area < 1e-9 * whole.area


def test_a_finely_jagged_outline_is_dilated_in_steps_that_cover_the_whole_buffer():
    """dilated: an outline of thousands of teeth finer than the distance (fur, a noisy
    trace) is dilated in doubling steps (one buffer crosses its offset curves ~280,000
    times here: 3 s and 780 MB; 40,000 points took 84 s and ~20 GB), each simplified
    before the next: the result covers the whole buffer, with few vertices, and lies
    within the true dilation but for the steps' simplifications (1 % of the distance;
    the whole 4-segment buffer is inscribed in it, its chords up to 1 - cos(π/16), 1.9 %,
    inside); ordinary art stays one buffer."""
    from repulsionpak.geometry import dilate

    n, reach = 8000, 4.6
    t = 2 * np.pi * np.arange(n) / n
    r = 150.0 + 1.1 * (np.arange(n) % 2)
    fur = shapely.Polygon(np.c_[r * np.cos(t), r * np.sin(t)])
    assert dilate.crossings(fur, reach) > dilate.CROSSINGS
    stepped = dilate.dilated([fur], reach)[0]
    whole = fur.buffer(reach, quad_segs=4)
    assert stepped.covers(whole)
    assert shapely.hausdorff_distance(stepped.exterior, whole.exterior) <= (0.01 + 0.019 + 0.003) * reach
    assert shapely.get_num_coordinates(stepped) < 0.1 * shapely.get_num_coordinates(whole)
    disc = shapely.Point(0, 0).buffer(40.0)
    assert dilate.crossings(disc, reach) < dilate.CROSSINGS
    assert shapely.equals_exact(dilate.dilation(disc, reach), disc.buffer(reach, quad_segs=4), 0.0)


def test_a_budget_bounds_the_leftover_fill(tmp_path):
    """The fills stop once their work budget (art points handled) is spent, whatever room
    is left: the long strip that takes ~100 discs gets about as many copies as the budget
    pays for, and the work charged grows linearly with the copies placed."""
    from repulsionpak.holes import BUILD_COST, COPY_COST, FILL_WORK, MIN_FILL_WORK, FillBudget, budget_for

    cont, unbounded = _fill_strip(tmp_path, 14000, min_radius=20.0)
    lib = HoleLibrary.of([load_element(tmp_path / "disc.svg")])
    per_copy = COPY_COST + (6 + BUILD_COST) * float(lib.points[0])  # a fit of 6 picks, then the build
    spent = []
    for n in (10, 20):
        b = FillBudget(n * per_copy)
        got = fill_pockets([], lib, cont.region, 10.0, 5.0, np.random.default_rng(0), min_radius=20.0, budget=b)
        assert b.spent and 0.5 * n <= len(got) <= n < len(unbounded)
        spent.append((n * per_copy - b.left) / len(got))
        _assert_gap_and_margin(cont, [e.art for e in got])
    assert spent[1] == pytest.approx(spent[0], rel=0.3)  # linear: the same work per copy
    assert budget_for(1000, 20000).left == pytest.approx(2e7 * FILL_WORK)
    assert budget_for(10, 300).left == pytest.approx(MIN_FILL_WORK * FILL_WORK)


def test_free_copies_are_tried_along_a_long_pocket(tmp_path):
    """A bar longer than its pocket is wide fits only along it: the fit's first picks turn
    the copy's long axis along the pocket's, so a strip gets a row of bars lying along it
    (random angles alone found it seldom)."""
    (tmp_path / "bar.svg").write_text(scenes.element_svg("bar"))
    (tmp_path / "strip.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" width="600" height="100">'
                                        '<path d="M0 20H600V80H0Z"/></svg>')
    cont = load_container(tmp_path / "strip.svg")
    lib = HoleLibrary.of([load_element(tmp_path / "bar.svg")])
    got = fill_pockets([], lib, cont.region, 10.0, 5.0, np.random.default_rng(0), min_radius=5.0, min_size=20.0)
    along = [e for e in got if (e.art.bounds[2] - e.art.bounds[0]) > 2.5 * (e.art.bounds[3] - e.art.bounds[1])]
    assert len(along) >= 3  # a row of bars lying along the strip (the ends' square pieces may take one aslant)
    assert max(e.art.bounds[2] - e.art.bounds[0] for e in along) > 80.0  # longer than the strip is wide
    _assert_gap_and_margin(cont, [e.art for e in got])
