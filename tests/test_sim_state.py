"""The simulation's State (every array a run changes), its checkpoints, and the force terms
summed by Simulator.step."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from shapely.geometry import Polygon

from repulsionpak.checkpoint import load_checkpoint, save_checkpoint
from repulsionpak.params import SimParams
from repulsionpak.placement import Placement
from repulsionpak.preprocess import build_template, outline_of
from repulsionpak.sim.model import SimFrame, State, build_model
from repulsionpak.sim.runner import Simulator
from repulsionpak.sim.terms import (Adhesion, Alignment, Boundary, Corners, Edges, Inversion, Overlap, Repulsion,
                                   ShapeMatching, terms_of)
from repulsionpak.types import ArtPath, Element, Style


pytestmark = pytest.mark.usefixtures("one_numba_thread")


def _square() -> Element:
    ring = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    return Element("sq", "sq.svg", (ArtPath((ring,), (True,), Style(fill="#000")),))


@pytest.fixture(scope="module")
def template():
    return build_template(outline_of(_square()), scale=1.0, gap=2.0)


def _sim(template, params: SimParams | None = None) -> Simulator:
    """Three squares, two overlapping, in an L-shaped container (reflex corner: the corner
    term runs too)."""
    region = Polygon([(0, 0), (100, 0), (100, 50), (50, 50), (50, 100), (0, 100)])
    placement = Placement(np.array([0, 0, 0]), np.array([[20.0, 20.0], [25.0, 22.0], [25.0, 70.0]]),
                          np.array([0.0, 0.3, 0.0]), 1.0)
    model, state = build_model([template], placement, SimFrame(1.0), region, cell_size=15.0, gap=3.0)
    sim = Simulator(model, state, params or SimParams())
    sim.refresh_growth()
    return sim


def _arrays(obj) -> dict:
    return {k: v.copy() for k, v in vars(obj).items() if isinstance(v, np.ndarray)}


def test_a_step_changes_no_array_outside_the_state(template):
    """Everything a step changes is in the State: the simulator's own arrays are constant
    (static derived data) except the force accumulator."""
    sim = _sim(template)
    before = _arrays(sim)
    state_before = _arrays(sim.state)
    for _ in range(2 * sim.params.requery_every):
        sim.step()
    after = _arrays(sim)
    changed = {k for k in before if not np.array_equal(before[k], after[k])}
    # scratch: the forces, the corner query's marks, the relaxation's sweep order (a warm
    # start for its sort; the order is by (x, vertex id), never by the previous one), each
    # element's growth steps and velocity caps (recomputed from the contacts every step)
    assert changed <= {"F", "_corner_mark", "relax_order", "grow_steps", "_vmax_step"}, changed
    assert "F" in changed
    moved = {k for k in state_before if not np.array_equal(state_before[k], getattr(sim.state, k))}
    assert {"x", "v", "n_grow", "growth", "inside", "nb_count", "nb_q", "areas"} <= moved, moved
    assert sim.state.iteration == 2 * sim.params.requery_every


def test_every_term_adds_into_the_forces(template):
    """``term(model, state, forces)`` adds: applied to non-zero forces it changes them by
    exactly what it gives on zeros."""
    sim = _sim(template, dataclasses.replace(SimParams(), k_shape=2.0))
    for _ in range(sim.params.requery_every):
        sim.step()
    sim.update_contacts(full=True)
    m, st = sim.model, sim.state
    assert [type(t) for t in sim.terms] == [Repulsion, Edges, ShapeMatching, Boundary, Overlap, Inversion,
                                            Corners, Alignment, Adhesion]
    rng = np.random.default_rng(1)
    for growing in (True, False):  # the adhesion acts only while the packing settles
        st.allow_growth = growing
        for term in sim.terms:
            alone = np.zeros_like(st.x)
            term(m, st, alone)
            base = rng.normal(size=st.x.shape)
            summed = base.copy()
            term(m, st, summed)
            np.testing.assert_allclose(summed - base, alone, atol=1e-9)
        adhesion = np.abs(_alone(sim.terms[-1], m, st)).max()
        assert (adhesion > 0) != growing
    # the repulsion, springs, boundary and overlap act on this overlapping scene
    assert all(np.abs(_alone(t, m, st)).max() > 0 for t in sim.terms[:2] + sim.terms[4:5])


def _alone(term, m, st):
    out = np.zeros_like(st.x)
    term(m, st, out)
    return out


def test_terms_follow_the_parameters():
    default = terms_of(SimParams())
    assert [type(t) for t in default][:2] == [Repulsion, Edges]
    assert ShapeMatching not in map(type, default)  # k_shape = 0: the paper's four forces
    no_fold = terms_of(dataclasses.replace(SimParams(), min_triangle_area=0.0))
    assert Inversion not in map(type, no_fold)
    assert default[-1] == Adhesion(SimParams().k_adhesion, SimParams().adhesion_reach)
    assert Adhesion not in map(type, terms_of(dataclasses.replace(SimParams(), k_adhesion=0.0)))
    p = SimParams()
    assert default[0] == Repulsion(80.0, p.soft)  # k_repulsion None: the pockets' own strength
    assert Boundary(p.k_boundary, p.outside_block, p.boundary_inset) in default
    # resolved for a run whose pockets stay empty, as pack() does: the stronger repulsion at the
    # default gap (10 simulation units) and above, following the gap squared below it, never
    # below the pockets' 80
    assert terms_of(p.for_run(filled=False))[0] == Repulsion(320.0, p.soft)
    assert p.for_run(filled=False, gap=20.0).k_repulsion == 320.0  # (above the default gap: kept)
    assert p.for_run(filled=False, gap=7.0).k_repulsion == pytest.approx(156.8)
    assert p.for_run(filled=False, gap=5.0).k_repulsion == 80.0
    assert terms_of(p.for_run(filled=True, gap=20.0))[0] == Repulsion(80.0, p.soft)
    # below 0.5 % of the container (5 units) both follow the gap: the push across a gap,
    # k_r / (gap² + ς), stays what it is at 5 units (the 1,000-element poster: 1.7 units)
    at5 = 80.0 / (25.0 + p.soft)
    for g in (3.0, 1.72, 0.5):
        for filled in (True, False):
            k = p.for_run(filled=filled, gap=g).k_repulsion
            assert k / (g * g + p.soft) == pytest.approx(at5)
    assert p.repulsion(True, 5.0) == 80.0 and p.repulsion(True, 4.999) == pytest.approx(80.0, rel=1e-3)
    assert dataclasses.replace(p, k_repulsion=50.0).for_run(filled=True, gap=1.0).k_repulsion == 50.0
    assert terms_of(dataclasses.replace(p, k_repulsion=50.0).for_run(filled=False))[0] == Repulsion(50.0, p.soft)


def test_a_state_saved_to_a_checkpoint_file_resumes_bit_identically(template, tmp_path):
    """The checkpoint is the State: a run restored from the file (a fresh model and
    state) continues exactly as the uninterrupted one, vertices inside a mesh included."""
    sim = _sim(template)
    every = sim.params.requery_every
    for _ in range(every):
        sim.step()
    assert sim.state.inside.any()  # the entry sides are part of what is saved
    save_checkpoint(tmp_path / "c.npz", {"primary": sim.snapshot_state()}, "fp")
    for _ in range(2 * every):
        sim.step()
    again = _sim(template)
    again.restore(load_checkpoint(tmp_path / "c.npz", "fp")["primary"])
    assert again.state.iteration == every
    for _ in range(2 * every):
        again.step()
    np.testing.assert_array_equal(again.state.x, sim.state.x)
    np.testing.assert_array_equal(again.state.n_grow, sim.state.n_grow)
    np.testing.assert_array_equal(again.state.growth, sim.state.growth)


def test_a_checkpoint_with_wider_neighbour_lists_resumes(template):
    """A checkpoint written by a build that kept more neighbouring meshes per vertex
    (wider lists than MAX_NEIGHBOURS) loads: the inside vertices keep their first
    entries, and the run continues exactly as from a checkpoint of this build."""
    sim = _sim(template)
    every = sim.params.requery_every
    for _ in range(every):
        sim.step()
    saved = sim.snapshot_state()
    k = sim.state.nb_elem.shape[1]
    assert len(saved["inside_idx"])  # vertices inside a mesh: their lists are saved
    wide = dict(saved)
    for name in ("inside_nb_elem", "inside_nb_seg"):  # unused slots beyond the counts
        a = saved[name]
        wide[name] = np.concatenate([a, np.full((len(a), k), 7, a.dtype)], axis=1)
    runs = []
    for state in (saved, wide):
        again = _sim(template)
        again.restore(state)
        for _ in range(every):
            again.step()
        runs.append(again.state.x.copy())
    np.testing.assert_array_equal(runs[0], runs[1])


def test_state_copy_shares_no_array(template):
    sim = _sim(template)
    sim.step()
    c = sim.state.copy()
    assert isinstance(c, State)
    for k, v in vars(sim.state).items():
        if isinstance(v, np.ndarray):
            assert getattr(c, k) is not v and np.array_equal(getattr(c, k), v), k
    c.x[0, 0] += 1.0
    assert c.x[0, 0] != sim.state.x[0, 0]


def test_pinning_moves_the_active_vertices(template):
    sim = _sim(template)
    m, st = sim.model, sim.state
    n_all = len(st.active_all)
    sim.set_moving(1, False)
    own = np.arange(m.elem_vstart[1], m.elem_vstart[2])
    assert not st.moving[1] and len(st.active_all) == n_all - len(own)
    assert not np.isin(own, st.active_all).any() and not np.isin(own, st.active_skin).any()
    x1 = st.x[own].copy()
    for _ in range(5):
        sim.step()
    np.testing.assert_array_equal(st.x[own], x1)  # a pinned element does not move
    sim.set_moving(1, True)
    assert len(st.active_all) == n_all


def test_alignment_leaves_limited_rotations_and_settling_alone(template):
    """The alignment term turns elongated elements (here all three squares, weighted as
    if they were) while they grow, but not an element whose rotation the designer limits
    (``rot_on``), and nothing once the run settles."""
    sim = _sim(template)
    for _ in range(sim.params.requery_every):
        sim.step()
    sim.update_contacts(full=True)
    m, st = sim.model, sim.state
    term = Alignment(10.0, 2.0)
    m.align_weight = np.ones(m.n_elements)
    free = _alone(term, m, st)
    vs = m.elem_vstart
    assert free[vs[0]:vs[1]].any()
    m.rot_on = np.array([True, False, False])
    limited = _alone(term, m, st)
    assert not limited[vs[0]:vs[1]].any()
    np.testing.assert_array_equal(limited[vs[1]:], free[vs[1]:])
    m.rot_on = None
    sim.begin_settle()
    assert not _alone(term, m, st).any()
