"""Growth beside one-sided contacts (sim.integrate.confined_contacts, sim.one_sided_growth) and
shallow overlaps (sim.integrate.deep_contacts, sim.contact_depth)."""

from __future__ import annotations

import numpy as np

from repulsionpak.sim.integrate import confined_contacts, deep_contacts, grow


def _ring(n=16, r=1.0, c=(0.0, 0.0)):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([c[0] + r * np.cos(t), c[1] + r * np.sin(t)])


def _case(inside_idx, one_sided):
    x = np.ascontiguousarray(_ring())
    inside = np.zeros(16, np.bool_)
    inside[list(inside_idx)] = True
    out = np.zeros(16, np.bool_)
    confined_contacts(x, inside, np.array([0], np.int32), np.array([16], np.int32), np.ones(1, np.bool_),
                      one_sided, out)
    return inside, out


def test_contacts_on_one_side_do_not_block_growth():
    inside, out = _case([0, 1, 15], 0.7)  # three neighbouring vertices around angle 0
    assert inside.any() and not out.any()


def test_contacts_on_opposite_sides_block_growth():
    inside, out = _case([0, 8], 0.7)  # pressed from left and right
    assert np.array_equal(out, inside)
    inside, out = _case([0, 4], 0.8)  # 90 degrees apart: resultant 0.707 < 0.8
    assert np.array_equal(out, inside)
    inside, out = _case([0, 4], 0.7)  # ... > 0.7
    assert not out.any()


def test_off_is_the_papers_rule():
    inside, out = _case([0], 0.0)
    assert np.array_equal(out, inside)


def test_grow_follows_the_blocking_vertices():
    _, out = _case([0, 1, 15], 0.7)
    n_grow = np.zeros(1, np.int64)
    growth = np.ones(1)
    g = grow(out, np.zeros(16, np.bool_), np.array([0], np.int32), np.array([16], np.int32),
             np.ones(1, np.bool_), n_grow, growth, 0.001, True, np.array([2.0]))
    assert g == 1 and n_grow[0] == 1 and growth[0] == 1.001
    inside, _ = _case([0, 1, 15], 0.7)
    g = grow(inside, np.zeros(16, np.bool_), np.array([0], np.int32), np.array([16], np.int32),
             np.ones(1, np.bool_), n_grow, growth, 0.001, True, np.array([2.0]))
    assert g == 0 and n_grow[0] == 1



def test_only_overlaps_deeper_than_the_depth_block_growth():
    inside = np.array([True, True, True, False])
    nb_count = np.array([2, 1, 0, 1], np.int64)
    nb_d2 = np.array([[0.04, 0.25], [0.36, 0.0], [0.0, 0.0], [0.0, 0.0]])  # depths 0.2 (nearest), 0.6, none
    out = np.zeros(4, np.bool_)
    deep_contacts(inside, nb_count, nb_d2, 0.3 ** 2, out)
    assert out.tolist() == [False, True, True, False]  # no way out known: deep
    deep_contacts(inside, nb_count, nb_d2, 0.0, out)
    assert out.tolist() == inside.tolist()  # depth 0: the paper's rule


def test_contact_depth_must_not_be_negative():
    import pytest

    from repulsionpak.errors import ParameterError
    from repulsionpak.params import Params

    with pytest.raises(ParameterError, match="contact_depth"):
        Params().with_(sim__contact_depth=-0.1).validate()
