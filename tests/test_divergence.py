"""Divergence: NaN or exploding positions are detected during the run; the simulation
recovers by restoring the last good state with a smaller time step, or fails with a
clear DivergedError — never a broken packing written as if it were good."""

from __future__ import annotations

import re

import numpy as np
import pytest
from shapely.geometry import box
from typer.testing import CliRunner

from repulsionpak import examples
from repulsionpak.cli import app
from repulsionpak.errors import DivergedError
from repulsionpak.pack import prepare
from repulsionpak.sim.phase import typical_size
from repulsionpak.params import params_from_dict
from repulsionpak.sim.model import SimFrame, build_model
from repulsionpak.sim.runner import Simulator
from repulsionpak.types import ArtPath, Container, Element, Style


def small_sim(max_iterations=400):
    sq = Element("sq", "sq.svg", (ArtPath((np.array([[0, 0], [10, 0], [10, 10], [0, 10.0]]),), (True,), Style()),))
    cont = Container("c.svg", box(0, 0, 100, 100))
    p = params_from_dict({"gap": 3.0, "seed": 1, "placement": {"count": 4},
                          "sim": {"max_iterations": max_iterations, "settle_iterations": 10}})
    templates, placement, gap = prepare(cont, [sq], p, np.random.default_rng(1))
    frame = SimFrame.for_region(cont.region)
    rs = frame.to_sim(cont.region)
    size = typical_size(templates, placement.template_index) / frame.unit
    model, state = build_model(templates, placement, frame, rs, cell_size=p.sim.cell_size * size,
                               gap=gap / frame.unit)
    return Simulator(model, state, p.sim)


def test_nan_is_recovered_with_a_smaller_time_step():
    sim = small_sim()
    original = sim.step
    calls = {"n": 0}

    def flaky_step():
        calls["n"] += 1
        a = original()
        if calls["n"] == 250:  # one bad step after the state at 200 was saved
            sim.state.x[sim.state.active_all[0]] = np.nan
            return float("nan")
        return a

    sim.step = flaky_step
    res = sim.run()
    assert res.dt == pytest.approx(sim.params.dt / 2)
    assert np.isfinite(sim.state.x).all()
    assert res.stopped_by in ("converged", "max_iterations")


def test_exploding_positions_are_detected():
    sim = small_sim()
    original = sim.step

    exploded = []

    def exploding_step():
        a = original()
        if sim.state.iteration == 390 and not exploded:  # once: the replay after recovery is clean
            exploded.append(True)
            sim.state.x[sim.state.active_all[:3]] += 1e9
        return a

    sim.step = exploding_step
    res = sim.run()
    assert res.dt < sim.params.dt  # recovered from the last good state
    assert np.abs(sim.state.x).max() < 1e6


def test_persistent_divergence_raises_a_clear_error():
    sim = small_sim()
    original = sim.step

    def always_nan():
        original()
        sim.state.x[sim.state.active_all[0]] = np.inf
        return float("nan")

    sim.step = always_nan
    with pytest.raises(DivergedError, match="diverged"):
        sim.run()


def test_cli_reports_divergence_without_writing(tmp_path, monkeypatch):
    def boom(self, *a, **k):
        raise DivergedError("the simulation diverged at iteration 7 (test)")

    monkeypatch.setattr(Simulator, "run", boom)
    out = tmp_path / "o.svg"
    r = CliRunner().invoke(app, ["pack", str(examples.container_file("circle")), str(examples.element_files()[0]),
                                 "-o", str(out), "--count", "3", "-q"])
    assert r.exit_code == 4
    assert "diverged" in r.output and "Traceback" not in r.output
    assert not out.exists()
    # no --seed: the one drawn is named, so the run can be reproduced
    seed = re.search(r"\(seed (\d+): rerun with --seed \1 to reproduce\)", r.output)
    assert seed, r.output
