"""The paper's initial placement (sec. 4): where the elements start."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from repulsionpak.pack import prepare
from repulsionpak.params import Params
from repulsionpak.placement import blue_noise, wide_part
from repulsionpak.types import ArtPath, Container, Element, Style

#: a crescent: a disc of radius 100 minus one of 80 shifted right; its horns end at HORN_TIPS
OUTER = shapely.Point(0, 0).buffer(100.0, 256)
INNER = shapely.Point(45.0, 0).buffer(80.0, 256)
CRESCENT = shapely.difference(OUTER, INNER)
_x = (100.0 ** 2 - 80.0 ** 2 + 45.0 ** 2) / (2 * 45.0)
HORN_TIPS = np.array([[_x, np.sqrt(100.0 ** 2 - _x ** 2)], [_x, -np.sqrt(100.0 ** 2 - _x ** 2)]])


def widths_at(region, points, radii=np.arange(0.5, 40.0, 0.5)) -> np.ndarray:
    """For each point, the diameter of the largest disc inside ``region`` that covers it
    (to 1; openings by larger discs are smaller)."""
    pts = shapely.points(np.asarray(points))
    best = np.zeros(len(pts))
    for r in radii:
        covered = shapely.covers(shapely.buffer(shapely.buffer(region, -r), r), pts)
        best[covered] = 2 * r
    return best


def disc_element(name: str, radius: float) -> Element:
    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    ring = np.column_stack([radius * np.cos(t), radius * np.sin(t)])
    return Element(name, name + ".svg", (ArtPath((ring,), (True,), Style(fill="#000")),))


def test_the_wide_part_of_a_crescent_leaves_out_its_horns():
    wide = wide_part(CRESCENT, 8.0)
    assert wide.area >= 0.5 * CRESCENT.area
    assert wide.area < CRESCENT.area
    for tip in HORN_TIPS:  # near the tips the crescent is narrower than 16
        assert shapely.distance(wide, shapely.Point(tip)) > 10.0
    assert wide.covers(shapely.Point(-90, 0))  # its widest part, 35 wide, is kept


def test_a_band_narrower_than_the_disc_everywhere_is_opened_by_a_smaller_one():
    band = shapely.box(0, 0, 100, 4)
    wide = wide_part(band, 10.0)  # no disc of 10 fits: halved to 2.5, then 1.25
    assert wide.area >= 0.5 * band.area
    assert band.covers(wide)
    assert wide_part(band, 0.0).equals(band)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_no_element_starts_where_the_container_is_narrower_than_it(seed):
    """Farthest-point sampling takes the extremes first: without the start width, seed 1
    started an element where the crescent is 7 wide, for a final radius of 14."""
    elements = [disc_element("disc", 5.0)]
    params = Params(seed=seed, gap=2.0).with_(placement__count=20, placement__follow_room=False)
    templates, placement, _ = prepare(Container("crescent.svg", CRESCENT), elements, params,
                                      np.random.default_rng(seed))
    radius = np.mean([templates[i].radius for i in placement.template_index])
    want = 0.6 * radius  # the default start width
    widths = widths_at(CRESCENT, placement.position)
    assert min(widths) >= want - 0.5, (min(widths), want)


def test_start_width_zero_is_the_papers_placement_anywhere():
    elements = [disc_element("disc", 5.0)]
    params = Params(seed=1, gap=2.0).with_(placement__count=20, placement__follow_room=False,
                                          placement__start_width=0.0)
    templates, placement, _ = prepare(Container("crescent.svg", CRESCENT), elements, params,
                                      np.random.default_rng(1))
    radius = np.mean([templates[i].radius for i in placement.template_index])
    widths = widths_at(CRESCENT, placement.position)
    assert min(widths) < 0.6 * radius  # an element starts in a horn


def test_start_width_must_not_be_negative():
    from repulsionpak.errors import ParameterError

    with pytest.raises(ParameterError, match="start_width"):
        Params(gap=2.0).with_(placement__start_width=-0.1).validate()


def test_blue_noise_is_farthest_point_sampling_of_its_candidates():
    """Each point after the first is the candidate farthest from those chosen (the first of
    equals): the same points as the plain loop over every candidate, to the bit."""
    region = shapely.Polygon([(0, 0), (120, 0), (120, 40), (40, 40), (40, 120), (0, 120)])
    got = blue_noise(region, 60, np.random.default_rng(5), candidates_per_point=20)
    rng = np.random.default_rng(5)  # the candidates blue_noise draws, then the plain loop
    minx, miny, maxx, maxy = region.bounds
    frac = region.area / ((maxx - minx) * (maxy - miny))
    cand = np.column_stack([rng.uniform(minx, maxx, int(60 * 20 / frac * 1.2) + 16),
                            rng.uniform(miny, maxy, int(60 * 20 / frac * 1.2) + 16)])
    cand = cand[shapely.contains_xy(region, cand[:, 0], cand[:, 1])][:60 * 20]
    chosen = [int(rng.integers(len(cand)))]
    d2 = ((cand - cand[chosen[0]]) ** 2).sum(axis=1)
    for _ in range(59):
        chosen.append(int(np.argmax(d2)))
        d2 = np.minimum(d2, ((cand - cand[chosen[-1]]) ** 2).sum(axis=1))
    assert len(cand) == 60 * 20
    assert np.array_equal(got, cand[chosen])
