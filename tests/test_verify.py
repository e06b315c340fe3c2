"""The final verification and repair of a packing's promises (verify.py), on geometry
built by hand: overlaps, art outside, edge margin and the gap floor."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from repulsionpak.geometry.outline import art_area
from repulsionpak.types import ArtPath, PlacedArt, Style
from repulsionpak.verify import verify_and_repair

CONTAINER = shapely.box(0, 0, 100, 100)


def square(x, y, side=20.0, source="sq.svg"):
    pts = np.array([[x, y], [x + side, y], [x + side, y + side], [x, y + side]], dtype=float)
    return PlacedArt(source, "primary", (ArtPath((pts,), (True,), Style()),))


def geoms(placed):
    return [art_area(p.paths, p.stroke_scale) for p in placed]


def check(placed, gap, margin, min_gap):
    g = geoms(placed)
    for i in range(len(g)):
        assert CONTAINER.contains(g[i])
        assert CONTAINER.exterior.distance(g[i]) >= margin - 1e-6
        for j in range(i + 1, len(g)):
            assert g[i].distance(g[j]) >= min_gap - 1e-6


def test_well_spaced_packing_is_left_alone():
    placed = [square(10, 10), square(40, 10), square(10, 40)]
    out, v = verify_and_repair(placed, CONTAINER, gap=5, margin=2.5, min_gap=4.5)
    assert v.ok and not v.shrunk and not v.dropped
    assert all(a is b for a, b in zip(out, placed))


def test_overlap_and_close_pairs_are_separated_keeping_shapes():
    placed = [square(30, 30), square(45, 32), square(30, 52)]  # overlap, and a 2-unit gap
    before = geoms(placed)
    out, v = verify_and_repair(placed, CONTAINER, gap=5, margin=2.5, min_gap=4.5)
    assert v.ok and len(out) == 3 and v.overlap_pairs == 0
    check(out, 5, 2.5, 4.5)
    for g0, g1 in zip(before, geoms(out)):  # similar copies: squares stay squares
        s = np.sqrt(g1.area / g0.area)
        assert 0.5 <= s <= 1.0
        assert shapely.oriented_envelope(g1).area == pytest.approx(g1.area, rel=1e-9)


def test_art_outside_or_within_the_margin_is_brought_in():
    placed = [square(-5, 40), square(80, 79.5)]
    out, v = verify_and_repair(placed, CONTAINER, gap=4, margin=3, min_gap=3.6)
    assert v.ok and v.min_edge_distance >= 3 - 1e-6
    check(out, 4, 3, 3.6)


def test_hopeless_element_is_dropped_with_a_warning_naming_it():
    placed = [square(10, 10), square(-50, -50, side=300, source="huge.svg")]
    with pytest.warns(UserWarning, match="huge.svg"):
        out, v = verify_and_repair(placed, CONTAINER, gap=4, margin=2, min_gap=3.6)
    assert v.ok and v.dropped == [(1, "huge.svg")] and len(out) == 1


def test_without_repair_violations_are_reported_not_fixed():
    placed = [square(30, 30), square(45, 32), square(-5, 40)]
    out, v = verify_and_repair(placed, CONTAINER, gap=5, margin=2.5, min_gap=4.5, repair=False)
    assert not v.ok
    assert v.overlap_pairs == 1 and v.outside == 1 and v.margin_violations == 1
    assert out == placed


def test_a_secondary_too_close_to_a_primary_gives_way_alone():
    """Of a primary and a secondary too close, only the secondary moves or shrinks (a
    pocket filler never costs the element it fills around); two primaries share."""
    import dataclasses

    small = dataclasses.replace(square(42, 30, side=10.0, source="small.svg"), kind="secondary")
    placed = [square(20, 30), small]  # 2 units apart, overlapping in y
    before = geoms(placed)
    out, v = verify_and_repair(placed, CONTAINER, gap=5, margin=2.5, min_gap=4.5, grow_to=0.0)
    assert v.ok and len(out) == 2
    check(out, 5, 2.5, 4.5)
    after = geoms(out)
    assert after[0].equals(before[0])  # the primary is untouched
    assert not after[1].equals(before[1])
    # the same pair as two primaries: both give way (the push is shared)
    both = [square(20, 30), square(42, 30, side=10.0, source="small.svg")]
    out2, v2 = verify_and_repair(both, CONTAINER, gap=5, margin=2.5, min_gap=4.5, grow_to=0.0)
    assert v2.ok and not geoms(out2)[0].equals(before[0])
