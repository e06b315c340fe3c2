"""Pocket fill (secondary.py): seeds, the pocket's long axis, copies sized to their pocket."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from repulsionpak.params import SecondaryParams
from repulsionpak.preprocess import outline_of
from repulsionpak.geometry.pockets import fit_scale, fit_scales, outline_samples
from repulsionpak.secondary import (MAX_POCKET_GRID, PIXELS_PER_GAP, SIZE_STEP, _fit_to_pockets, pocket_axes,
                                    pocket_grid, pocket_seeds)
from repulsionpak.types import ArtPath, Element


def _box(x0, y0, x1, y1):
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float)


def _bar_element(length=50.0, width=10.0) -> Element:
    pts = _box(0, 0, length, width)
    return Element("bar", "bar.svg", (ArtPath((pts,), (True,)),))


def _sliver(angle_deg: float):
    """A 200×200 container crossed by a sliver 16 units wide at ``angle_deg``, the rest
    covered by two skins."""
    region = shapely.box(-100, -100, 100, 100)
    a = math.radians(angle_deg)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    top = _box(-300, 8, 300, 300) @ rot.T
    bottom = _box(-300, -300, 300, -8) @ rot.T
    return region, [top, bottom]


def test_pocket_axis_runs_along_a_sliver():
    for deg in (0.0, 30.0, 75.0, 120.0):
        region, skins = _sliver(deg)
        pockets = pocket_seeds(region, skins, gap=2.0, params=SecondaryParams(grid=400))
        assert len(pockets.seeds) >= 3  # a long sliver gets a row of seeds
        axes = pocket_axes(pockets)
        # deepest seeds, away from the container's edges
        inner = np.abs(pockets.seeds).max(axis=1) < 60
        assert inner.any()
        for ax in axes[inner]:
            diff = (math.degrees(ax) - deg + 90.0) % 180.0 - 90.0
            assert abs(diff) < 5.0, (deg, math.degrees(ax))


def test_a_bar_fits_larger_along_its_sliver_and_keeps_the_offset():
    region, skins = _sliver(30.0)
    pockets = pocket_seeds(region, skins, gap=2.0, params=SecondaryParams(grid=400))
    k = int(np.argmin(np.hypot(*pockets.seeds.T)))
    seed = pockets.seeds[k]
    outline = outline_of(_bar_element())
    pts = outline_samples(outline)
    offset = 1.0
    steps = np.geomspace(0.05, 2.0, 80)
    along = fit_scale(pockets, seed, pts, math.radians(30.0), offset, 1.0, steps)
    across = fit_scale(pockets, seed, pts, math.radians(120.0), offset, 1.0, steps)
    assert along > 2.5 * across
    # the fitted copy is inside the sliver with the offset kept (to a pixel)
    art = shapely.affinity.translate(
        shapely.affinity.rotate(shapely.affinity.scale(
            shapely.affinity.translate(outline.geometry, *(-outline.center)), along, along, origin=(0, 0)),
            30.0, origin=(0, 0)), *seed)
    for s in skins:
        assert shapely.distance(art, shapely.Polygon(s)) >= offset - 2 * pockets.h
    # width across the sliver (16) minus the offset on both sides: the bar is 10 wide
    assert along * 10.0 <= 16.0 - 2 * offset + 2 * pockets.h
    assert along * 10.0 >= 0.8 * (16.0 - 2 * offset)


def _scan_every_scale(pockets, seed, pts, angle, offset, s0, steps):
    """The reference fit: every scale tested at once with numpy, the first misfit kept."""
    c, s = np.cos(angle), np.sin(angle)
    q = pts @ np.array([[c, s], [-s, c]])
    cand = seed + (s0 * steps)[:, None, None] * q[None, :, :]
    ok = (pockets.lookup(cand) >= offset).all(axis=1)
    bad = np.nonzero(~ok)[0]
    j = (len(steps) if len(bad) == 0 else int(bad[0])) - 1
    return float(s0 * steps[max(j, 0)])


def test_fit_scales_stop_at_the_first_misfit_exactly_like_a_full_scan():
    region, skins = _sliver(30.0)
    pockets = pocket_seeds(region, skins, gap=2.0, params=SecondaryParams(grid=400))
    pts = outline_samples(outline_of(_bar_element()))
    rng = np.random.default_rng(5)
    steps = np.geomspace(0.05, 2.0, 80)
    for k in range(len(pockets.seeds)):
        angles = rng.uniform(0, 2 * np.pi, 7)
        got = fit_scales(pockets, pockets.seeds[k], pts, angles, 1.0, 1.3, steps)
        want = [_scan_every_scale(pockets, pockets.seeds[k], pts, a, 1.0, 1.3, steps) for a in angles]
        assert got.tolist() == want  # bit for bit
    # a seed off the grid fits nothing: the smallest scale is returned
    assert fit_scale(pockets, np.array([1e4, 1e4]), pts, 0.0, 1.0, 1.3, steps) == 1.3 * steps[0]


def test_each_pocket_takes_the_element_whose_fitted_copy_covers_most():
    """A bar fills a sliver better than a square does, a square an open pocket better than a
    bar: with both as candidates each pocket takes its better one, in either order; with one
    candidate the assignment stands."""
    square = Element("square", "square.svg", (ArtPath((_box(0, 0, 10, 10),), (True,)),))
    outlines = [outline_of(_bar_element()), outline_of(square)]
    region, skins = _sliver(0.0)
    sliver = pocket_seeds(region, skins, gap=2.0, params=SecondaryParams(grid=400))
    far = np.array([[-400, -400], [-399, -400], [-399, -399]], float)  # a skin outside the box
    open_box = pocket_seeds(shapely.box(-100, -100, 100, 100), [far], gap=2.0, params=SecondaryParams(grid=400))
    for pockets, best in ((sliver, 0), (open_box, 1)):
        n = len(pockets.seeds)
        inner = np.abs(pockets.seeds).max(axis=1) < 60  # seeds not pressed against the box's edge
        for order in ((0, 1), (1, 0)):
            cand = np.tile(np.array(order), (n, 1))
            _, scales, chosen = _fit_to_pockets(pockets, outlines, cand, None, 1.0, True, np.random.default_rng(1))
            assert (chosen[inner] == best).all()
            areas = np.array([outlines[i].geometry.area for i in chosen]) * scales ** 2
            for i in (0, 1):  # no candidate alone would have covered more
                _, alone, _ = _fit_to_pockets(pockets, outlines, np.full((n, 1), i), None, 1.0, True,
                                              np.random.default_rng(1))
                assert (areas >= outlines[i].geometry.area * alone ** 2 * (1 - 1e-9)).all()
        _, _, chosen = _fit_to_pockets(pockets, outlines, np.full((n, 1), 1 - best), None, 1.0, True,
                                       np.random.default_rng(1))
        assert (chosen == 1 - best).all()


def test_outline_samples_cover_the_inside():
    outline = outline_of(_bar_element(40.0, 40.0))
    pts = outline_samples(outline, n=40, n_inside=64)
    assert np.allclose(pts.mean(axis=0), 0.0, atol=2.0)  # centred on the centroid
    inside = np.abs(pts).max(axis=1) < 15
    assert inside.sum() >= 30  # points on a grid inside, not only on the boundary
    assert np.abs(pts).max() <= 20 + 1e-9


def test_pack_sizes_secondaries_to_their_pockets():
    """Copies come in size classes (one template each), a skin built for about their
    own size: the smallest and the largest copy differ by more than one class."""
    from repulsionpak import pack
    from repulsionpak.params import Params, PlacementParams
    from repulsionpak.types import Container

    region = shapely.box(0, 0, 300, 200)
    el = _bar_element(60.0, 12.0)
    p = Params(gap=4.0, seed=1, placement=PlacementParams(count=8))  # 15 copies, 5 classes
    packing = pack(Container("box.svg", region), [el], p)
    sec = [i for i, k in enumerate(packing.model.kind) if k == "secondary"]
    assert len(sec) >= 5
    scales = sorted({packing.templates[int(packing.model.template_index[i])].scale for i in sec})
    assert len(scales) >= 2 and scales[-1] / scales[0] >= SIZE_STEP ** 2 * 0.999
    assert packing.verification.ok


def test_max_count_bounds_every_secondary_copy():
    """`secondary.max_count` is an upper bound on the secondaries, the leftover and hole
    fills' copies included (max_count 1 gave 116 copies), and 0 means none (it seeded one)."""
    import dataclasses

    from repulsionpak import examples
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.pack import pack
    from repulsionpak.params import Params

    cont = load_container(examples.container_file("circle"))
    els = load_elements(examples.element_files()[:4])
    for cap in (0, 1, 5):
        p = dataclasses.replace(Params(), gap=8.0, seed=1)
        p = dataclasses.replace(p, placement=dataclasses.replace(p.placement, count=6),
                                sim=dataclasses.replace(p.sim, max_iterations=300),
                                secondary=dataclasses.replace(p.secondary, max_count=cap))
        packing = pack(cont, els, p)
        assert packing.n_secondary <= cap
        assert packing.n_primary == 6
    assert packing.n_secondary == 5  # the room was there


def test_seeds_in_a_wide_sliver_leave_room_for_copies_as_wide_as_it():
    """A copy in a pocket of half-width d grows to about 2(d − 0.6 gap) across, so copies
    a gap apart stand 2d − 0.2 gap apart: seeds taken in random order keep 0.75 of that
    (2d/1.34 − 0.15 gap) between them, not the fixed 2 gaps or d they kept before (more,
    smaller copies, each with its own gap ring: the suite's mean area 0.559 → 0.563)."""
    region, skins = _sliver(0.0)  # 16 units wide: d = 8 = 4 gaps
    gap = 2.0
    pockets = pocket_seeds(region, skins, gap=gap, params=SecondaryParams(grid=400))
    s = pockets.seeds
    d = np.hypot(s[:, None, 0] - s[None, :, 0], s[:, None, 1] - s[None, :, 1])
    np.fill_diagonal(d, np.inf)
    depth = float(pockets.distance.max())
    assert depth == pytest.approx(8.0, abs=1.0)
    # each seed keeps the deeper seeds' claims (taken deepest first): as far from each as
    # that one's copy is wide, a gap added, not the fixed 2 gaps or d they kept before
    claim = np.maximum(2.0 * gap, 2.0 * pockets.distance / 1.34 - 0.15 * gap)
    deeper = np.arange(len(s))[:, None] < np.arange(len(s))[None, :]
    assert (d >= claim[:, None] - 2 * pockets.h)[deeper].all()
    inner = np.abs(s[:, 0]) < 80  # along the sliver, away from the container's edges
    assert d[np.ix_(inner, inner)].min() >= 2.0 * depth / 1.34 - 0.15 * gap - 2 * pockets.h  # was 8
    assert len(s) >= 5  # still a row along the 200-unit sliver


def test_pocket_depth_is_measured_finely_whatever_the_gap():
    """A channel 3.2 gaps wide in a container 600 gaps long (a poster of 1,000 elements):
    at the default 1,000 pixels a gap spans 1.7 of them and the channel's depth came out
    0.2 gap too deep (a copy's fit ~20-40 % too large in such pockets); the raster now
    follows the gap."""
    gap = 2.5
    region = shapely.box(0, -500, 1500, 500)
    skins = [_box(-10, 4.0, 1510, 600), _box(-10, -600, 1510, -4.0)]
    pockets = pocket_seeds(region, skins, gap=gap, params=SecondaryParams())
    assert pockets.h <= gap / PIXELS_PER_GAP + 1e-9
    assert abs(float(pockets.distance.max()) - 4.0) < 0.1 * gap
    assert len(pockets.seeds) >= 100  # a row along the channel


def test_pocket_grid_is_the_given_one_at_the_default_gap_and_bounded():
    bounds = (0.0, 0.0, 1500.0, 1000.0)
    assert pocket_grid(bounds, 15.0, 1000) == 1000  # 1 % of the longer side: 10 pixels a gap
    assert pocket_grid(bounds, 15.0, 2000) == 2000  # a finer grid asked for is kept
    assert pocket_grid(bounds, 2.5, 1000) == 3600
    assert pocket_grid(bounds, 0.01, 1000) == MAX_POCKET_GRID
    assert pocket_grid(bounds, 0.0, 1000) == 1000


def test_a_narrow_band_with_one_primary_gets_its_pockets_filled(tmp_path):
    """The default count of a band 2.5 gaps wide is one primary; the automatic fill's cap
    of 10 copies per primary left 10 copies at random points of the band (median gap
    1.68 here). At least AUTO_FILL_MIN copies are allowed now: the gap is kept (1.02)."""
    from repulsionpak.measure import gap_statistics
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.pack import AUTO_FILL_MIN, pack
    from repulsionpak.params import Params

    t = np.linspace(math.radians(200), math.radians(340), 60)
    outer = [(500 + 480 * math.cos(a), 600 + 480 * math.sin(a)) for a in t]
    inner = [(500 + 405 * math.cos(a), 600 + 405 * math.sin(a)) for a in t[::-1]]
    pts = " ".join(f"{x:.2f},{y:.2f}" for x, y in outer + inner)
    (tmp_path / "band.svg").write_text(f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 1000 700">'
                                       f'<polygon points="{pts}"/></svg>')
    (tmp_path / "disc.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 20 20">'
                                       '<circle cx="10" cy="10" r="9"/></svg>')
    (tmp_path / "square.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 60 60">'
                                         '<rect x="5" y="5" width="50" height="50"/></svg>')
    cont = load_container(tmp_path / "band.svg", tolerance=0.03)
    els = load_elements([tmp_path / "disc.svg", tmp_path / "square.svg"])
    packing = pack(cont, els, Params(gap=30.0, seed=1))
    assert packing.n_primary == 1 and AUTO_FILL_MIN > 10
    assert packing.n_secondary > 10
    gs = gap_statistics([p.art for p in packing.placed])
    assert 0.9 <= gs["median"] / 30.0 <= 1.1
    assert packing.verification.ok


def test_automatic_copies_keep_the_size_floor():
    """Without --secondary no pocket copy is smaller than ``secondary.min_size`` (0.2) of
    the median primary, sizes being the square root of the art's area; without the floor
    the same scene gets specks (the test can fail)."""
    import dataclasses

    from repulsionpak import pack
    from repulsionpak.params import Params, PlacementParams
    from repulsionpak.secondary import art_size, size_floor
    from repulsionpak.types import Container

    region = shapely.box(0, 0, 300, 200)
    el = _bar_element(60.0, 12.0)
    base = Params(gap=4.0, seed=2, placement=PlacementParams(count=8))
    rel = {}
    for share in (0.0, 0.2):
        p = dataclasses.replace(base, secondary=dataclasses.replace(base.secondary, min_size=share))
        packing = pack(Container("box.svg", region), [el], p)
        prim = [art_size(q.art) for q in packing.placed if q.kind == "primary"]
        sec = [art_size(q.art) for q in packing.placed if q.kind == "secondary"]
        assert sec and packing.verification.ok
        rel[share] = min(sec) / float(np.median(prim))
        if share:
            assert min(sec) >= size_floor(prim, share) * (1 - 1e-9)
    assert rel[0.0] < 0.2 <= rel[0.2], rel


def test_size_floor_is_a_share_of_the_median():
    from repulsionpak.secondary import art_size, size_floor

    assert size_floor([10.0, 30.0, 20.0], 0.2) == pytest.approx(4.0)
    assert size_floor([], 0.2) == 0.0 and size_floor([10.0], 0.0) == 0.0
    assert art_size(shapely.box(0, 0, 4, 9)) == pytest.approx(6.0)


def test_copies_not_mapped_are_the_ones_the_floor_drops():
    """``worth_mapping`` leaves out only pocket copies whose mapped art, even grown by the
    verification's ``max_grow``, stays below the floor: the mesh sizes it reads agree with
    the mapped art's within ``MESH_SIZE_SLACK``. A scene with enough pocket copies pressed
    below the floor that some are left out (the test can fail both ways)."""
    from repulsionpak import pack
    from repulsionpak.params import Params
    from repulsionpak.secondary import MESH_SIZE_SLACK, art_size, mesh_sizes, size_floor, worth_mapping
    from repulsionpak.sim.art import placed_art
    from repulsionpak.types import Container

    region = shapely.box(0, 0, 300, 200)
    p = Params(gap=4.0, seed=2).with_(placement__count=8)
    packing = pack(Container("box.svg", region), [_bar_element(60.0, 12.0)], p)
    m = packing.model
    art = np.array([art_size(q.art) for q in placed_art(packing.templates, m, packing.state, packing.frame,
                                                        params=p.render)])
    est = mesh_sizes(packing)
    assert np.all(est / art <= MESH_SIZE_SLACK) and np.all(art / est <= MESH_SIZE_SLACK), (est / art)
    primary = np.array([k == "primary" for k in m.kind])
    floor = size_floor(art[primary], p.secondary.min_size)
    drawn = worth_mapping(packing, p.secondary.min_size, p.verify.max_grow)
    left_out = np.setdiff1d(np.arange(m.n_elements), drawn)
    assert np.isin(np.flatnonzero(primary), drawn).all()  # every primary is drawn
    assert len(left_out) > 0 and not primary[left_out].any()
    assert np.all(art[left_out] * p.verify.max_grow < floor), (art[left_out], floor)
