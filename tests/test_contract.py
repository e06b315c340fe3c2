"""Issue 10's promises on the fast scenes of benchmarks/scenes.py (the same measurements
``python benchmarks/contract.py`` makes on the whole suite, see docs/quality.md).

Each scene is packed once through ``repulsionpak pack``'s code path and measured on the
output SVG read back from disk. Every promise must hold on every fast scene.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import scenes
from repulsionpak.measure import ContractLimits

LIMITS = ContractLimits()
FAST = scenes.fast_suite()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("contract")
    return {s.name: scenes.run_scene(s, root) for s in FAST}


@pytest.fixture(params=[s.name for s in FAST])
def run(request, runs):
    return runs[request.param]


# --------------------------------------------------------------------------- the measurement


@pytest.mark.slow
def test_measured_from_the_output_svg(run):
    """Every element of the output is measured against its own source file."""
    sc, m, rep = run["scene"], run["metrics"], run["report"]
    # the count asked for, or fewer if the verification dropped one; pockets filled
    # with small copies (secondary.auto)
    assert sc.count - 1 <= rep["n_primary"] <= sc.count
    assert m["n_elements"] == rep["n_primary"] + rep["n_secondary"]
    assert len(m["sources"]) == m["n_elements"] and set(m["sources"]) <= {p.name for p in run["files"].elements}
    assert all(v is not None for v in m["distortion"]["values"])
    assert all(v is not None for v in m["edge"]["values"])
    assert m["gap"]["requested"] == pytest.approx(sc.gap_units)
    # exact art geometry read back agrees with the pack's own (in-memory) measurement
    assert m["area_fraction"] == pytest.approx(rep["area_fraction"], abs=0.01)
    assert m["overlap_area"] == pytest.approx(rep["overlap_area"], abs=1e-6 * m["container_area"])
    pr = m["promises"]
    json.dumps(pr, allow_nan=False)
    cats = {scenes.element_category(n) for n in m["sources"]}
    assert {k for k in pr if k.startswith("distortion_")} == {f"distortion_{c}" for c in cats}


# --------------------------------------------------------------------------- the promises


@pytest.mark.slow
def test_gap_median_within_10_percent(run):
    v = run["metrics"]["gap"]["median"] / run["files"].gap
    assert LIMITS.gap_median_low <= v <= LIMITS.gap_median_high, f"median gap {v:.3f} × gap"


@pytest.mark.slow
def test_gap_p10_at_least_80_percent(run):
    v = run["metrics"]["gap"]["p10"] / run["files"].gap
    assert v >= LIMITS.gap_p10, f"10th percentile gap {v:.3f} × gap"


@pytest.mark.slow
def test_no_art_overlap(run):
    m = run["metrics"]
    assert m["overlap_area"] <= LIMITS.overlap * m["container_area"], m["overlap_area"]


@pytest.mark.slow
def test_nothing_outside(run):
    m = run["metrics"]
    assert m["outside_area"] <= LIMITS.outside * m["container_area"], m["outside_area"]


@pytest.mark.slow
def test_edge_margin(run):
    m, gap = run["metrics"], run["files"].gap
    assert m["edge"]["min"] >= LIMITS.margin_tolerance * LIMITS.margin * gap, \
        f"art {m['edge']['min'] / gap:.3f} × gap from the edge; {m['edge']['n_below_margin']} elements too close"


@pytest.mark.slow
def test_distortion_p95_by_category(run):
    m = run["metrics"]
    by_cat: dict[str, list[float]] = {}
    for name, d in zip(m["sources"], m["distortion"]["values"]):
        by_cat.setdefault(scenes.element_category(name), []).append(d)
    bad = {c: float(np.percentile(v, 95)) for c, v in by_cat.items()
           if np.percentile(v, 95) > LIMITS.distortion_limit(c)}
    assert not bad, f"distortion p95 over the limit: {bad}"


#: fast scenes whose full output misses the Q_s promise since pocket copies have a size
#: floor (``secondary.min_size``, 1/5 of the median primary) and holes are filled only when
#: asked: their primaries alone leave channels (and ring and letter holes) that copies of
#: that size cannot close, which the specks used to hide (issue 41 part 1, still open; see
#: docs/quality.md). Guarded against getting worse; the promise itself is an expected failure.
#: fast-letters' guard is 0.52 since the growth rate k_g = 0.04: its primaries alone pack
#: closer (area 0.34 -> 0.38, their Q_s ratio 0.66 -> 0.63), leaving fewer pockets a
#: floor-sized copy fits (18 -> 11 copies), so the whole output's ratio went 0.47 -> 0.50.
LOOSE_PRIMARIES = {"fast-spiky-thin": 0.52, "fast-rings-x10": 0.51, "fast-letters": 0.52}


@pytest.mark.slow
def test_scp_ratio(run):
    v = run["metrics"]["scp_ratio"]
    name = run["scene"].name
    if name in LOOSE_PRIMARIES:
        assert v <= LOOSE_PRIMARIES[name], f"Q_s(gap/2)/Q_s(0) = {v:.3f}, worse than with the floor"
        if v > LIMITS.scp_ratio:
            pytest.xfail(f"Q_s(gap/2)/Q_s(0) = {v:.3f} > {LIMITS.scp_ratio}: the primaries alone are "
                         "too loose without speck-sized pocket copies (issue 41 part 1)")
    assert v <= LIMITS.scp_ratio, f"Q_s(gap/2)/Q_s(0) = {v:.3f}"


# --------------------------------------------------------------------------- the CLI


@pytest.mark.slow
def test_cli_report_and_evaluate_give_each_elements_distortion(tmp_path):
    """``pack --report`` and ``evaluate --elements --json`` report the same per-element
    distortion, edge distances and outside area (and keep the older keys)."""
    from typer.testing import CliRunner

    from repulsionpak.cli import app

    sc = next(s for s in FAST if s.name == "fast-rings-x10")
    files = sc.write(tmp_path)
    out, rep = tmp_path / "out.svg", tmp_path / "rep.json"
    r = CliRunner().invoke(app, ["pack", str(files.container), *map(str, files.elements), "-o", str(out),
                                 "--gap", str(files.gap), "--count", str(sc.count), "--seed", "3",
                                 "--report", str(rep), "-q"])
    assert r.exit_code == 0, r.output
    report = json.loads(rep.read_text())
    for key in ("n_primary", "n_secondary", "n_vertices", "iterations", "seconds", "area_fraction", "gap",
                "seed", "params", "gap_stats", "invariants"):
        assert key in report
    d = report["distortion"]
    n = report["n_primary"] + report["n_secondary"]
    assert len(d["values"]) == n and all(0 <= v < 2 for v in d["values"])
    assert d["p95"] == pytest.approx(float(np.percentile(d["values"], 95)))
    assert len(report["edge"]["values"]) == n and report["outside_area"] >= 0
    r = CliRunner().invoke(app, ["evaluate", str(out), "--json", "--elements", str(files.elements[0].parent)])
    assert r.exit_code == 0, r.output
    ev = json.loads(r.output)
    for key in ("area_fraction", "overlap_area", "n_primary", "n_secondary", "gap", "scp"):
        assert key in ev
    # the same art (read back at 4 decimals) gives the same distortion
    assert ev["distortion"]["values"] == pytest.approx(d["values"], abs=2e-3)
    r = CliRunner().invoke(app, ["evaluate", str(out), "--json"])
    assert json.loads(r.output)["distortion"]["values"] == [None] * n
    r = CliRunner().invoke(app, ["evaluate", str(out)])
    assert "distortion" not in r.output and "edge distance min" in r.output
    r = CliRunner().invoke(app, ["evaluate", str(out), "--elements", str(tmp_path / "missing.svg")])
    assert r.exit_code == 2
