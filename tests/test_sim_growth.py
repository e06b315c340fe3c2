"""Fast growth while an element has room (``sim.fast_growth``): the rate per element, the
velocity caps that follow it, and determinism; and what growth does to a skin's width.

The kernel cases are built by hand; the run cases use the small square scene of
``test_sim.py`` (a 200×200 square, 8 elements, gap 4).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from repulsionpak.pack import pack
from repulsionpak.params import Params
from repulsionpak.sim.integrate import grow, growth_steps
from test_sim import CONTAINER, library, mesh_lag, scene_params


pytestmark = pytest.mark.usefixtures("one_numba_thread")


def _square_field(side=100.0, h=1.0):
    """Signed distance (negative inside) of the square [0, side]² on a grid with margin."""
    xs = np.arange(-10.0, side + 10.0 + h, h)
    gx, gy = np.meshgrid(xs, xs)
    inside = np.minimum(np.minimum(gx, side - gx), np.minimum(gy, side - gy))
    return np.ascontiguousarray(-inside), -10.0, -10.0, 1.0 / h


def _elements(centres, r=3.0, n=8):
    """Rings of ``n`` skin vertices of radius ``r`` around ``centres``."""
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.column_stack([np.cos(t), np.sin(t)]) * r
    x = np.concatenate([ring + c for c in centres])
    m = len(centres)
    return (x, np.arange(0, n * m, n).astype(np.int32), np.full(m, n, np.int32))


def test_growth_steps_are_fast_only_with_room():
    """Element 0 has a neighbouring skin 1.0 from one vertex (< clearance 2), element 1
    none, element 2 is 1.5 from the container's edge, element 3 is pinned, element 4 has
    room but has grown past ``until``: only element 1 grows fast."""
    x, vstart, nskin = _elements([(30, 30), (60, 60), (4.5, 50), (80, 20), (50, 85)])
    N, K = len(x), 4
    nb_count = np.zeros(N, np.int64)
    nb_d2 = np.zeros((N, K))
    nb_count[3], nb_d2[3, 0] = 1, 1.0 ** 2        # element 0: a neighbour 1.0 away
    nb_count[8:16], nb_d2[8:16, 0] = 1, 2.5 ** 2  # element 1: its neighbours 2.5 away
    values, ox, oy, inv_h = _square_field()
    moving = np.array([True, True, True, False, True])
    growth = np.array([1.0, 1.0, 1.0, 1.0, 2.0])
    until = np.full(5, 1.8)
    steps = np.zeros(5, np.int64)
    n = growth_steps(x, vstart, nskin, moving, nb_count, nb_d2, values, ox, oy, inv_h, 2.0, 4,
                     growth, until, steps)
    assert n == 1
    assert steps.tolist() == [1, 4, 1, 1, 1]
    # the paper's rule (fast = 1): every element one step
    n = growth_steps(x, vstart, nskin, moving, nb_count, nb_d2, values, ox, oy, inv_h, 2.0, 1,
                     growth, until, steps)
    assert n == 0 and steps.tolist() == [1] * 5


def test_grow_takes_the_steps_that_fit_under_the_largest_size():
    vstart = np.array([0, 4, 8], np.int32)
    nskin = np.array([4, 4, 4], np.int32)
    inside = np.zeros(12, np.bool_)
    inside[9] = True  # element 2 touches a mesh: no growth at any rate
    n_grow = np.array([0, 8, 0], np.int64)
    growth = 1.0 + n_grow * 0.01
    grew = grow(inside, np.zeros(12, np.bool_), vstart, nskin, np.ones(3, np.bool_), n_grow, growth,
                0.01, True, np.array([2.0, 1.1, 2.0]), np.array([4, 4, 4], np.int64))
    assert grew == 2
    assert n_grow.tolist() == [4, 10, 0]  # element 1 stops at 1.1 = 1 + 10·0.01
    np.testing.assert_allclose(growth, 1.0 + n_grow * 0.01)


def _fast(p: Params, fast=4, clearance=2.0, until=1.0) -> Params:
    """``p`` with fast growth, over the paper's growth rate (k_g = 0.01)."""
    return replace(p, sim=replace(p.sim, k_growth=0.01, fast_growth=fast, fast_growth_clearance=clearance,
                                  fast_growth_until=until))


def test_an_element_near_a_neighbour_grows_at_the_papers_rate():
    """Every iteration of a run with fast growth: an element with a neighbouring skin or
    the container's edge within the clearance takes one growth step (or none), one with
    room takes ``fast_growth`` steps; the counters advance by exactly that."""
    p = _fast(scene_params(max_iterations=600, settle=0))
    # a start at 22 % cover: the elements meet their neighbours within the 600 iterations
    p = replace(p, placement=replace(p.placement, initial_fraction=0.22))
    clear = p.sim.fast_growth_clearance
    seen = {"fast": 0, "near": 0}
    last = {}

    def snap(s):
        if s.phase != "primary" or s.done:
            return
        sim, m, st = s.sim, s.model, s.state
        steps = sim.grow_steps
        for e in range(m.n_elements):
            a, n = int(m.elem_vstart[e]), int(m.elem_nskin[e])
            c = st.nb_count[a:a + n]
            d2 = [st.nb_d2[i, j] for i in range(a, a + n) for j in range(c[i - a])]
            near = bool(d2) and min(d2) < (clear * m.gap) ** 2
            grew = st.n_grow[e] - last[e] if e in last else 0
            if near:
                assert steps[e] == 1 and grew <= 1, (s.iteration, e)
                seen["near"] += 1
            elif steps[e] > 1:
                seen["fast"] += 1
            assert 0 <= grew <= steps[e]
            last[e] = int(st.n_grow[e])

    pack(CONTAINER, library(), p, on_snapshot=snap, snapshot_every=1)
    assert seen["fast"] > 0 and seen["near"] > 0


def test_fast_growth_is_deterministic_and_faster():
    """Same seed, same bytes; and the skins reach the paper's area at iteration 300 in
    fewer iterations."""
    p = _fast(scene_params(max_iterations=300, settle=0))
    a, b = pack(CONTAINER, library(), p), pack(CONTAINER, library(), p)
    assert np.array_equal(a.state.x, b.state.x)
    assert np.array_equal(a.state.n_grow, b.state.n_grow)
    paper = pack(CONTAINER, library(), _fast(scene_params(max_iterations=300, settle=0), fast=1))
    target = paper.state.area_history[-1]
    first = next(i for i, v in enumerate(a.state.area_history) if v >= target)
    assert first < 0.6 * len(paper.state.area_history)


def _fast_lag(headroom: float, at: int = 50) -> list[float]:
    """:func:`test_sim.mesh_lag` at iteration ``at`` of the two large discs that grew fast
    until then (placed at 5 % cover, ``growth_headroom`` as given)."""
    p = _fast(scene_params(count=2, max_iterations=at, settle=0), clearance=0.5)
    p = replace(p, placement=replace(p.placement, initial_fraction=0.05),
                sim=replace(p.sim, growth_headroom=headroom))
    # the elements that took fast steps for most of the run
    return mesh_lag(p, at, select=lambda state, at: state.n_grow >= 2 * at, every=5)


def test_fast_growing_meshes_keep_up_with_their_growth():
    """A disc ~100 units across in the 1000-unit frame growing four times the paper's
    rate: its velocity cap follows the rate, so its skin keeps up with its rest lengths;
    with the paper's cap alone it lags."""
    now = _fast_lag(Params().sim.growth_headroom)
    paper = _fast_lag(0.0)
    assert len(now) >= 1 and min(now) > 0.97
    assert len(paper) >= 1 and max(paper) < 0.9


def test_without_pocket_fill_elements_with_room_grow_past_the_filled_cap():
    """The growth cap (``sim.max_size``) is 1.3× the nominal size where pocket copies fill
    the voids and 2× where nothing does: elements built to fill a tenth of the square
    (``placement.target_fraction``) have room to grow to 2× (and no further) without the
    pockets filled, to 1.3× with the cap given."""
    from repulsionpak.params import MAX_SIZE_FILLED, MAX_SIZE_UNFILLED

    p = scene_params(count=4, max_iterations=2500)
    p = replace(p, placement=replace(p.placement, target_fraction=0.1))
    assert p.sim.max_size is None and not p.secondary.auto
    free = pack(CONTAINER, library(), p)
    capped = pack(CONTAINER, library(), replace(p, sim=replace(p.sim, max_size=MAX_SIZE_FILLED)))
    reach = [float(np.max(k.state.growth / k.model.max_growth)) for k in (free, capped)]
    assert MAX_SIZE_FILLED + 0.2 < reach[0] <= MAX_SIZE_UNFILLED + 1e-9
    assert reach[1] <= MAX_SIZE_FILLED + 1e-9
    assert p.sim.growth_cap(filled=True) == MAX_SIZE_FILLED
    assert p.sim.for_run(filled=False).max_size == MAX_SIZE_UNFILLED
    assert replace(p.sim, max_size=1.5).for_run(filled=False).max_size == 1.5  # a given cap is kept


def test_the_growth_rate_follows_whether_the_pockets_are_filled():
    """``sim.k_growth`` None: 0.06 where pocket copies fill the voids (the jam walked in
    fewer steps at the same density), 0.04 where the primaries must fill them alone; the
    primary simulation grows its elements at the rate resolved, and a rate given is kept."""
    from repulsionpak.params import K_GROWTH_FILLED, K_GROWTH_UNFILLED

    p = scene_params(count=4, max_iterations=40)
    assert p.sim.k_growth is None
    seen = {}
    for auto in (True, False):
        def snap(s, auto=auto):
            if s.phase == "primary" and s.done:
                seen[auto] = (s.sim.k_growth, s.state.growth[s.state.moving].copy(),
                              s.state.n_grow[s.state.moving].copy())

        pack(CONTAINER, library(), replace(p, secondary=replace(p.secondary, auto=auto)), on_snapshot=snap)
    assert seen[True][0] == K_GROWTH_FILLED
    assert seen[False][0] == K_GROWTH_UNFILLED
    for kg, growth, n in seen.values():
        assert n.max() > 10  # (grown: the rate shows)
        np.testing.assert_allclose(growth, 1.0 + n * kg * p.sim.dt)
    assert p.sim.growth_rate() == K_GROWTH_FILLED
    assert replace(p.sim, k_growth=0.01).for_run(filled=True).k_growth == 0.01


class _SceneFault(Exception):
    """The scene no longer shows what the tests below are about (not the expected failure)."""


def _skin_widths(narrow: bool = True):
    """Twelve copies of the square scene (no repair: the simulation's own output): each
    copy's size over its planned size, and the median distance from its skin vertices to its
    mapped art, in gaps."""
    import shapely

    p = scene_params(count=12)
    p = replace(p, verify=replace(p.verify, repair=False, dent=0), sim=replace(p.sim, narrow_skins=narrow))
    run = pack(CONTAINER, library(), p)
    m, st = run.model, run.state
    size = st.growth / m.max_growth
    if len(run.placed) != m.n_elements or not (size.min() < 0.85 and size.max() > 1.15):
        raise _SceneFault(f"copies end at {size.min():.2f}-{size.max():.2f} of their planned sizes")
    skins = run.skins()
    width = np.array([np.median(shapely.distance(shapely.points(skins[e]), q.art.boundary))
                      for e, q in enumerate(run.placed)]) / run.gap
    return size, width


def test_a_copy_grown_past_its_planned_size_keeps_its_skin_half_a_gap_wide():
    """A skin stands for half the gap beside its art. It grows with its copy, so a copy
    grown past its planned size kept its neighbours farther off (0.59 gap on a copy at 1.22
    of its size); narrowed when growth stops (``sim.narrow_skins``), every grown copy's skin
    ends at most 0.55 gap from its art (median over its skin vertices), and the copies short
    of their size are not touched."""
    size, width = _skin_widths()
    grown = size > 1.0
    assert grown.sum() >= 3
    assert width[grown].max() <= 0.55, np.round(width, 3)
    size0, width0 = _skin_widths(narrow=False)
    np.testing.assert_allclose(size0, size)  # (growth ends before the skins change)
    assert width0[grown].max() > 0.57
    short = size < 0.95
    np.testing.assert_allclose(width[short], width0[short], atol=0.02)


@pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
    "limitation (docs/algorithm.md, 'Not done'): a copy short of its planned size keeps the "
    "narrower skin it grew with; widened in the simulation, such skins pushed the jam apart"))
def test_a_copy_short_of_its_planned_size_keeps_its_skin_half_a_gap_wide():
    """The other side: a copy that stopped short of its planned size should not let its
    neighbours closer than the gap either. Today its skin is as narrow as its size: 0.37 gap
    on the copy at 0.78 of its size."""
    size, width = _skin_widths()
    assert width.min() >= 0.45, np.round(width, 3)
