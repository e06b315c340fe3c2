"""``Params.with_``: one call changes top-level and nested parameters, validated."""

from __future__ import annotations

import pytest

from repulsionpak import Params
from repulsionpak.errors import ParameterError


def test_nested_names_take_a_double_underscore():
    base = Params(gap=5, seed=1)
    p = base.with_(sim__k_edge=40, placement__count=30, margin=2)
    assert (p.sim.k_edge, p.placement.count, p.margin, p.gap, p.seed) == (40.0, 30, 2.0, 5.0, 1)
    assert type(p.sim.k_edge) is float  # as validate() types it (TOML gives floats)
    assert (base.sim.k_edge, base.placement.count) == (Params().sim.k_edge, None)  # frozen: a new one
    assert p.sim.k_repulsion == base.sim.k_repulsion and p.preprocess is base.preprocess


@pytest.mark.parametrize("kw, message", [
    ({"sim__k_edg": 1}, r"unknown name 'sim__k_edg'; did you mean 'sim__k_edge'\?.*sim__k_repulsion"),
    ({"simm__k_edge": 1}, r"unknown section name 'simm__k_edge'.*sim__NAME, secondary__NAME"),
    ({"gapp": 3}, r"unknown name 'gapp'; did you mean 'gap'\?.*seed, margin"),
    ({"sim__k_edge": -1}, r"sim\.k_edge must be >= 0"),
    ({"placement__count": "x"}, r"placement\.count must be an int, got 'x'"),
    ({"gap": 0}, r"gap must be a positive number"),
    ({"output__container_paint": "asdrawn"}, r"did you mean 'as-drawn'"),
])
def test_unknown_names_and_bad_values_are_parameter_errors(kw, message):
    with pytest.raises(ParameterError, match=message):
        Params().with_(**kw)


def test_a_draft_loosens_only_the_stopping_thresholds(tmp_path):
    """``drafted`` multiplies both phases' thresholds, on whatever the config set, and
    changes nothing else; ``--draft`` applies it after ``--config``."""
    from repulsionpak.cli.run import resolve_params
    from repulsionpak.params import DRAFT_FACTOR

    base = Params(gap=5, seed=1).with_(sim__stop_epsilon=1e-5, sim__k_edge=30)
    d = base.drafted()
    assert (d.sim.stop_epsilon, d.secondary.stop_epsilon) == pytest.approx(
        (DRAFT_FACTOR * 1e-5, DRAFT_FACTOR * base.secondary.stop_epsilon))
    assert d.with_(sim__stop_epsilon=1e-5, secondary__stop_epsilon=base.secondary.stop_epsilon) == base
    assert base.drafted(1.0) == base
    for bad in (0, -2.0, float("nan"), "4"):
        with pytest.raises(ParameterError, match="draft factor must be a positive number"):
            base.drafted(bad)
    cfg = tmp_path / "c.toml"
    cfg.write_text("[sim]\nstop_epsilon = 3e-5\n")
    assert resolve_params(cfg, draft=True).sim.stop_epsilon == pytest.approx(DRAFT_FACTOR * 3e-5)
    assert resolve_params(cfg).sim.stop_epsilon == pytest.approx(3e-5)


def test_without_pocket_fill_is_what_every_front_end_means_by_it():
    """``--no-pocket-fill``, the Inkscape dialog's and the studio's pocket fill unticked:
    one definition (:meth:`Params.without_pocket_fill`), the same parameters."""
    from repulsionpak.cli.run import resolve_params
    from repulsionpak.inkscape.library import Request, _params
    from repulsionpak.studio.settings import run_settings

    base = Params(seed=3, gap=2.0).with_(placement__count=4)
    empty = base.without_pocket_fill()
    s, d = empty.secondary, Params().secondary
    assert (s.auto, s.fill_leftover, s.fill_holes) == (False, False, False)
    assert (d.auto, d.fill_leftover) == (True, True)  # so the change is a change
    # nothing else changed
    assert empty.with_(secondary__auto=d.auto, secondary__fill_leftover=d.fill_leftover,
                       secondary__fill_holes=d.fill_holes) == base
    assert resolve_params(gap=2.0, seed=3, count=4, pocket_fill=False) == empty
    # (the dialog leaves the container out of the packing by default: the document has it)
    assert _params(Request(seed=3, gap=2.0, count=4, pocket_fill=False, container_paint="outline")) == empty
    assert run_settings({"gap": 2.0, "seed": 3, "count": 4, "pocket_fill": False})[0] == empty
    assert resolve_params(gap=2.0, seed=3, count=4) == base
    # an option's own check still names it with the pockets left empty
    with pytest.raises(ParameterError, match=r"^--seed must be >= 0"):
        resolve_params(seed=-1, pocket_fill=False)
