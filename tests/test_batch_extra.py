"""``repulsionpak batch`` without its optional extra: one line naming the install command."""

from __future__ import annotations

import sys
from pathlib import Path

from typer.testing import CliRunner

from repulsionpak import examples
from repulsionpak.cli import app


def test_batch_without_dask_names_the_extra(monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    E = Path(examples.__file__).parent
    r = CliRunner().invoke(app, ["batch", str(E / "containers" / "circle.svg"), str(E / "elements" / "apple.svg"),
                                 "-o", str(tmp_path / "runs"), "--seeds", "1-2"])
    assert r.exit_code == 3
    lines = r.stderr.strip().splitlines()
    assert lines == ["repulsionpak: error: repulsionpak batch needs Dask: pip install 'repulsionpak[batch]'"]
    assert not (tmp_path / "runs").exists()
