"""docs/examples/quickstart.ipynb runs: its code cells executed in order, in one namespace."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "examples" / "quickstart.ipynb"


@pytest.mark.slow
def test_the_quickstart_notebook_runs(tmp_path, monkeypatch, capsys):
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    cells = ["".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code"]
    assert len(cells) >= 4
    monkeypatch.chdir(tmp_path)
    ns: dict = {}
    for i, src in enumerate(cells):
        exec(compile(src, f"{NOTEBOOK.name}[{i}]", "exec"), ns)  # noqa: S102
    packing, stiff = ns["packing"], ns["stiff"]
    assert packing._repr_svg_() == (tmp_path / "heart.svg").read_text(encoding="utf-8")
    assert (tmp_path / "heart.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = json.loads((tmp_path / "heart.json").read_text())
    assert report["n_primary"] == packing.n_primary > 5 and report["invariants"]["ok"]
    assert stiff.params.sim.k_edge == 200 and packing.params.sim.k_edge == 20
    out = capsys.readouterr().out
    assert "area fraction" in out and "Q_s(gap/2) =" in out
