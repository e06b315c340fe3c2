"""The Python API gives what the command line gives: ``pack()`` + ``Packing.save`` write the
same bytes as ``repulsionpak pack`` for the same inputs, seed and parameters, and
``Packing.report()`` is its ``--report`` but for the times.

Small scenes from the shipped examples (a few hundred iterations each).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

import repulsionpak as rp
from repulsionpak import examples
from repulsionpak.cli import app
from repulsionpak.errors import ParameterError

E = Path(examples.__file__).parent
CIRCLE, CLOUD, HEART = (str(E / "containers" / f"{n}.svg") for n in ("circle", "cloud", "heart"))
APPLE, FISH, LEAF = (str(E / "elements" / f"{n}.svg") for n in ("apple", "fish", "leaf"))
DOT, STAR = (str(E / "secondary" / f"{n}.svg") for n in ("dot", "star"))
SHORT = ["--max-iterations", "120"]

#: name: (container, elements, secondary, CLI options, Params.with_ keywords)
SCENES = {
    "default-gap-count": (CIRCLE, [APPLE, FISH], [], ["--count", "4", "--seed", "3"],
                          dict(seed=3, placement__count=4)),
    "gap": (CLOUD, [LEAF, APPLE], [], ["--gap", "9", "--count", "5", "--seed", "2"],
            dict(gap=9.0, seed=2, placement__count=5)),
    "secondary": (HEART, [FISH, APPLE], [DOT, STAR], ["--gap", "8", "--count", "5", "--seed", "4"],
                  dict(gap=8.0, seed=4, placement__count=5)),
    "as-drawn": (HEART, [LEAF], [], ["--count", "4", "--seed", "5", "--container-paint", "as-drawn"],
                 dict(seed=5, placement__count=4, output__container_paint="as-drawn")),
}


def _cli(tmp: Path, name: str, extra=()) -> tuple[Path, Path]:
    container, elements, secondary, opts, _ = SCENES[name]
    out, rep = tmp / f"{name}-cli.svg", tmp / f"{name}-cli.json"
    args = ["pack", container, *elements, "-o", str(out), "--report", str(rep), *opts, *SHORT, "-q", *extra]
    for s in secondary:
        args += ["--secondary", s]
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 0, r.output
    return out, rep


def _params(name: str) -> rp.Params:
    return rp.Params().with_(sim__max_iterations=120, **SCENES[name][4])


def _strip_times(report: dict) -> dict:
    return {k: v for k, v in report.items() if k != "seconds"}


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cli")
    return {name: _cli(tmp, name) for name in SCENES}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SCENES))
def test_pack_and_save_write_the_svg_of_the_command_line(name, cli_runs, tmp_path):
    """The DESIGN contract: pack(load_container(path), load_elements(paths), Params(...)).save()."""
    container, elements, secondary, _, _ = SCENES[name]
    p = rp.pack(rp.load_container(container), rp.load_elements(elements), _params(name),
                secondary=rp.load_elements(secondary) if secondary else ())
    out = p.save(tmp_path / "py.svg")
    cli_svg, cli_rep = cli_runs[name]
    assert out.read_bytes() == cli_svg.read_bytes()
    assert p._repr_svg_() == cli_svg.read_text(encoding="utf-8")
    cli_report = json.loads(cli_rep.read_text())
    mine = json.loads(json.dumps(p.report()))
    # Element objects name their files; the command line records its arguments as given
    assert mine["inputs"]["elements"] == [Path(e).name for e in elements]
    assert _strip_times(dict(mine, inputs=None)) == _strip_times(dict(cli_report, inputs=None))
    assert mine["area_fraction"] > 0.2 and mine["invariants"]["ok"]


@pytest.mark.slow
def test_pack_given_paths_reports_what_the_command_line_reports(cli_runs, tmp_path):
    """pack() also takes the paths: then even the report's inputs are the command line's."""
    container, elements, secondary, _, _ = SCENES["secondary"]
    p = rp.pack(container, elements, _params("secondary"), secondary=secondary)
    cli_svg, cli_rep = cli_runs["secondary"]
    assert p.save(tmp_path / "py.svg").read_bytes() == cli_svg.read_bytes()
    saved = json.loads(p.save(tmp_path / "py.json").read_text())
    assert _strip_times(saved) == _strip_times(json.loads(cli_rep.read_text()))
    assert saved["inputs"] == {"container": container, "elements": elements, "secondary": secondary}
    assert saved["n_secondary"] > 0 and set(saved["seconds"]) >= {"preprocess", "primary", "total"}


@pytest.mark.slow
def test_png_and_pdf_from_save(cli_runs, tmp_path):
    pytest.importorskip("cairosvg")
    name = "gap"
    _, _, _, opts, _ = SCENES[name]
    png_cli = tmp_path / "cli.png"
    _cli(tmp_path, name, ["--png", str(png_cli)])
    container, elements, _, _, _ = SCENES[name]
    p = rp.pack(rp.load_container(container), rp.load_elements(elements), _params(name))
    png = p.save(tmp_path / "py.png")
    assert png.read_bytes() == png_cli.read_bytes()  # the --png picture, byte for byte
    assert p._repr_png_()[:8] == b"\x89PNG\r\n\x1a\n"
    pdf = p.save(tmp_path / "py.pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and len(pdf) > 2000
    with pytest.raises(ParameterError, match=r"\.svg, \.pdf, \.png, \.json"):
        p.save(tmp_path / "py.gif")
    ev = p.evaluate()
    assert ev["scp"]["q"][0] == pytest.approx(1 - ev["area_fraction"], abs=0.02)
    assert ev["n_primary"] == p.n_primary and ev["overlap_area"] == pytest.approx(0, abs=1e-6)


def test_a_container_read_by_default_is_flattened_for_the_run():
    """load_container(path) flattens to a thousandth of its diagonal; a run re-reads it at a
    thousandth of the gap, as the command line reads it (finer: more vertices)."""
    from repulsionpak.inputs import CONTAINER_TOLERANCE, default_gap, load_inputs

    c = rp.load_container(HEART)
    assert c.path == HEART and c.tolerance is None
    ins = load_inputs(c, [rp.load_elements([APPLE])[0]], rp.Params())
    g = default_gap(c)
    assert ins.params.gap == g and ins.container.tolerance == pytest.approx(CONTAINER_TOLERANCE * g)
    n = lambda cont: sum(len(r.coords) for poly in getattr(cont.region, "geoms", [cont.region])  # noqa: E731
                         for r in [poly.exterior, *poly.interiors])
    assert n(ins.container) > n(c)
    same = load_inputs(HEART, [APPLE], rp.Params())
    assert same.container.region.equals_exact(ins.container.region, 0) and same.params.gap == g
    own = rp.load_container(HEART, tolerance=0.5)  # the caller's tolerance is kept
    assert load_inputs(own, [APPLE], rp.Params(gap=5)).container is own


def test_pack_refuses_what_is_not_an_input():
    with pytest.raises(ParameterError, match="must be a Container"):
        rp.pack(42, [APPLE])
    with pytest.raises(ParameterError, match="list of Element"):
        rp.pack(CIRCLE, [APPLE, rp.load_elements([FISH])[0]])


def test_pack_without_report_fits_no_distortion(tmp_path, monkeypatch):
    """``repulsionpak pack`` without ``--report`` does not fit the copies to their sources
    (the summary line does not show it); its dict is the report's but for the distortion
    and the primaries' Q_s ratio, and the SVG is the same bytes."""
    from repulsionpak.cli import run_pack
    from repulsionpak.measure import evaluation

    container, elements, _, _, _ = SCENES["default-gap-count"]
    fits = []
    real = evaluation.distortions
    monkeypatch.setattr(evaluation, "distortions", lambda *a, **k: fits.append(1) or real(*a, **k))
    kw = dict(seed=3, count=4, max_iterations=120, progress=False)
    bare = run_pack(Path(container), [Path(e) for e in elements], tmp_path / "bare.svg", **kw)
    assert fits == []
    full = run_pack(Path(container), [Path(e) for e in elements], tmp_path / "full.svg",
                    report=tmp_path / "full.json", **kw)
    assert fits == [1]
    assert (tmp_path / "bare.svg").read_bytes() == (tmp_path / "full.svg").read_bytes()
    assert bare["distortion"]["median"] is None and full["distortion"]["median"] is not None
    assert bare["scp_ratio_primary"] is None
    skip = ("seconds", "distortion", "scp_ratio_primary")
    assert {k: v for k, v in bare.items() if k not in skip} == {k: v for k, v in full.items() if k not in skip}


def test_command_collects_the_youngest_garbage_less_often(monkeypatch):
    """The console entry point raises the youngest generation's collection threshold (the
    library leaves the host's collector alone)."""
    import gc

    from repulsionpak import cli

    before = gc.get_threshold()
    monkeypatch.setattr(sys, "argv", ["repulsionpak", "--help"])
    try:
        with pytest.raises(SystemExit):
            cli.main()
        assert gc.get_threshold() == (cli.GC_THRESHOLD, *before[1:])
    finally:
        gc.set_threshold(*before)
        gc.unfreeze()  # (main freezes what is alive when it ends)
