"""Size follows the space (repulsionpak.room, repulsionpak.sizing): the room a container
has, the count and size of the primaries per region, and a packed archipelago."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest
import shapely

from repulsionpak import load_container, load_elements
from repulsionpak.params import PlacementParams, params_from_dict
from repulsionpak.pack import pack
from repulsionpak.preprocess import outline_of
from region_scenes import REGION_KINDS, container_svg
from repulsionpak.room import room_of
from repulsionpak.sizing import is_even, part_counts, plan_sizes, size_field

GAP = 15.0  # 1.5 % of the region scenes' 1000-unit width


@pytest.fixture(scope="module")
def examples():
    d = resources.files("repulsionpak.examples") / "elements"
    return load_elements([str(d)])


def _container(tmp_path, kind, seed=1):
    p = tmp_path / f"{kind}{seed}.svg"
    p.write_text(container_svg(kind, seed))
    return load_container(str(p))


def test_local_width_of_a_band_and_a_disc():
    band = shapely.box(0, 0, 1000, 90)
    r = room_of(band, GAP)
    inside = r.part >= 0
    # the largest disc covering a point of a 90-wide band is 90 across (one level, one pixel)
    mid = inside & (np.abs(r.centres(np.ones_like(inside))[:, 0].reshape(inside.shape) - 500) < 300)
    assert np.all(r.width[mid] <= 90.0 + 1e-9)
    assert np.all(r.width[mid] >= 90.0 / 1.12 - 2 * r.h)
    disc = shapely.Point(0, 0).buffer(200, quad_segs=64)
    r = room_of(disc, GAP)
    assert r.part_width()[0] == pytest.approx(400, rel=0.13)
    assert is_even(r, 15 * GAP)
    assert not is_even(room_of(band, GAP), 15 * GAP)


@pytest.mark.parametrize("kind", REGION_KINDS)
def test_wide_pixels_from_the_large_levels_alone_are_those_of_the_width(tmp_path, kind):
    """``Room.wide(base)`` transforms only the levels of at least base/2 and finds exactly
    the pixels ``width >= base`` marks, for bases below the first level up to above the
    deepest point; it computes no width on the way (the even-container check of the
    paper's heart needs 10 of its 41 levels)."""
    region = _container(tmp_path, kind).region
    for gap in (GAP, 4 * GAP):
        room = room_of(region, gap)
        bases = [2.0 * room.levels[0], 5 * gap, 15 * gap, 3.0 * room.levels[-1], room.levels[0], 0.5 * gap]
        got = [room.wide(b) for b in bases[:4]]
        assert "width" not in room.__dict__  # no base below twice the first level yet
        got += [room.wide(b) for b in bases[4:]]
        fresh = room_of(region, gap)
        for b, w in zip(bases, got):
            np.testing.assert_array_equal(w, (fresh.width >= b) & (fresh.part >= 0), err_msg=f"{kind} base {b}")
        assert got[3].sum() == 0 and got[0].sum() > 0


def test_counts_give_every_wide_enough_island_a_primary(tmp_path):
    c = _container(tmp_path, "archipelago", 1)
    r = room_of(c.region, GAP)
    assert len(r.parts) >= 8 and not is_even(r, 15 * GAP)
    params = PlacementParams()
    counts = part_counts(r, size_field(r, 15 * GAP), GAP, params)
    wide = r.part_width() >= params.min_element_size * GAP
    assert np.all(counts[wide] >= 1) and np.all(counts[~wide] == 0)
    # big islands get several: about their area over (15 gaps)², never fewer than one
    big = int(np.argmax(r.part_area()))
    assert counts[big] >= round(r.part_area()[big] / (15 * GAP) ** 2) - 1
    given = part_counts(r, size_field(r, 15 * GAP), GAP, params, count=40)
    assert given.sum() == 40 and np.all(given[wide] >= 1)


def test_plan_puts_each_copy_inside_its_island_and_fitting(tmp_path, examples):
    c = _container(tmp_path, "archipelago", 2)
    r = room_of(c.region, GAP)
    outlines = [outline_of(e) for e in examples]
    plan = plan_sizes(r, outlines, GAP, 0.6 * GAP, PlacementParams(), np.random.default_rng(3))
    for k, (pos, part) in enumerate(zip(plan.position, plan.part)):
        assert r.parts[part].contains(shapely.Point(pos))
        # a copy alone in its island fits it, turned as planned, the skin's width from the edge
        if np.sum(plan.part == part) == 1:
            o = outlines[plan.library[k]]
            art = shapely.affinity.scale(o.geometry, plan.scale[k], plan.scale[k], origin=tuple(o.center))
            art = shapely.affinity.rotate(art, plan.angle[k], origin=tuple(o.center), use_radians=True)
            art = shapely.affinity.translate(art, *(pos - o.center))
            assert r.parts[part].buffer(-0.6 * GAP).buffer(r.h).contains(art)
    assert len(np.unique(plan.scale)) <= 40  # size classes, not one template per copy


@pytest.mark.parametrize("kind", REGION_KINDS)
def test_region_scenes_are_valid(kind):
    for seed in (1, 2):
        text = container_svg(kind, seed)
        assert text.startswith("<svg") and "evenodd" in text


def test_packed_archipelago_fills_its_islands(tmp_path, examples):
    """The acceptance scene of issue 41 part 2 with the shipped examples: every island that
    can hold a primary has one, and the primaries alone cover well (the paper's placement:
    a handful of primaries in the largest islands)."""
    c = _container(tmp_path, "archipelago", 1)
    params = params_from_dict({"gap": GAP, "seed": 1, "secondary": {"auto": False}})
    p = pack(c, examples, params)
    prim = [a for a in p.placed if a.kind == "primary"]
    r = room_of(c.region, GAP)
    wide = np.nonzero(r.part_width() >= PlacementParams().min_element_size * GAP)[0]
    holders = {k for k in wide for a in prim if r.parts[k].contains(a.art.representative_point())}
    assert holders == set(wide.tolist())
    area = sum(a.art.area for a in prim) / c.area
    assert len(prim) >= 10 and area >= 0.5  # the paper's placement: 7 primaries, 0.41
    assert p.verification.ok


def test_round_containers_and_given_counts_keep_the_papers_placement(tmp_path, examples):
    """room_placement steps aside (None) for an even container and for a count given in one
    region, so those packings are exactly the paper's placement."""
    from repulsionpak.pack import room_placement

    outlines = [outline_of(e) for e in examples[:3]]
    disc = tmp_path / "disc.svg"
    disc.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="1000" height="1000">'
                    '<circle cx="500" cy="500" r="480"/></svg>')
    c = load_container(str(disc))
    rng = np.random.default_rng(1)
    assert room_placement(c, outlines, GAP, params_from_dict({"gap": GAP}), rng) is None
    band = _container(tmp_path, "band")
    assert room_placement(band, outlines, GAP, params_from_dict({"gap": GAP, "placement": {"count": 12}}),
                          rng) is None
    assert room_placement(band, outlines, GAP, params_from_dict({"gap": GAP, "placement": {"follow_room": False}}),
                          rng) is None
    templates, placement = room_placement(band, outlines, GAP, params_from_dict({"gap": GAP}), rng)
    assert len(placement.template_index) >= 10  # a band 6 gaps wide: a row of copies along it
    assert all(band.region.contains(shapely.Point(p)) for p in placement.position)
