"""Checkpoints: a resumed run ends exactly like the uninterrupted one; Ctrl-C writes a
partial packing; bad checkpoints are refused clearly."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from typer.testing import CliRunner

from repulsionpak import examples
from repulsionpak.checkpoint import load_checkpoint
from repulsionpak.cli import app
from repulsionpak.errors import InputError
from repulsionpak.io import load_container, load_elements, read_packing_svg
from repulsionpak.pack import pack
from repulsionpak.params import params_from_dict

CONTAINER = examples.container_file("circle")
ELEMENTS = examples.element_files()[:3]
SECONDARY = examples.secondary_files()[:1]


def params():
    return params_from_dict({"gap": 12.0, "seed": 5, "placement": {"count": 5},
                             "sim": {"max_iterations": 700, "settle_iterations": 50}})


def test_resume_from_any_checkpoint_equals_uninterrupted_run():
    cont, els, secs = load_container(CONTAINER), load_elements(ELEMENTS), load_elements(SECONDARY)
    saved = []
    full = pack(cont, els, params(), secondary=secs, on_checkpoint=lambda s: saved.append(s),
                checkpoint_every=160)
    phases = [tuple(sorted(s)) for s in saved]
    assert ("primary",) in phases and ("primary", "secondary") in phases
    assert full.n_secondary > 0
    # resume from a mid-primary checkpoint and from a mid-secondary one
    mid_primary = next(s for s in saved if "secondary" not in s and not s["primary"]["done"])
    mid_secondary = next(s for s in saved if "secondary" in s and not s["secondary"]["done"])
    for state in (mid_primary, mid_secondary):
        again = pack(cont, els, params(), secondary=secs, resume=state)
        assert again.iterations == full.iterations
        np.testing.assert_array_equal(again.state.x, full.state.x)


def test_resume_while_settling_narrows_the_skins_as_the_uninterrupted_run():
    """A checkpoint taken after growth stopped holds positions pulled towards skins that
    :func:`~repulsionpak.sim.skinwidth.narrow_grown_skins` narrowed; the resumed run (its
    model built again as placed) narrows them again from the saved growth and ends where
    the uninterrupted run ends."""
    cont, els = load_container(CONTAINER), load_elements(ELEMENTS)
    p = params_from_dict({"gap": 12.0, "seed": 5, "placement": {"count": 8}, "secondary": {"auto": False},
                          "sim": {"settle_iterations": 50}})
    saved = []
    full = pack(cont, els, p, on_checkpoint=lambda s: saved.append(s), checkpoint_every=20)
    assert full.model.band_scale is not None and (full.model.band_scale < 1.0).any()
    settling = next(s for s in saved if s["primary"]["settle_left"])
    again = pack(cont, els, p, resume=settling)
    assert again.iterations == full.iterations
    np.testing.assert_array_equal(again.state.x, full.state.x)
    np.testing.assert_array_equal(again.model.band_scale, full.model.band_scale)


def test_checkpoint_file_round_trip_and_fingerprint(tmp_path):
    out, ck = tmp_path / "a.svg", tmp_path / "ck.npz"
    args = ["pack", str(CONTAINER), *map(str, ELEMENTS), "--gap", "12", "--count", "5", "--seed", "5",
            "--max-iterations", "400", "-q"]
    r = CliRunner().invoke(app, [*args, "-o", str(out), "--checkpoint", str(ck), "--checkpoint-every", "100"])
    assert r.exit_code == 0, r.output
    data = load_checkpoint(ck)
    assert data["primary"]["done"] and data["primary"]["x"].ndim == 2
    # resuming a finished run reproduces the same file
    out2 = tmp_path / "b.svg"
    r = CliRunner().invoke(app, [*args, "-o", str(out2), "--resume", str(ck)])
    assert r.exit_code == 0, r.output
    assert out.read_bytes() == out2.read_bytes()
    # other parameters: refused, naming the checkpoint
    r = CliRunner().invoke(app, [*args[:-3], "--max-iterations", "500", "-q", "-o", str(tmp_path / "c.svg"),
                                 "--resume", str(ck)])
    assert r.exit_code == 2 and "other inputs or parameters" in r.output and not (tmp_path / "c.svg").exists()
    # other controls (they were not in the fingerprint: a different packing, exit 0)
    for extra in (["--rotation", "fixed"], ["--rigid"], ["--stiffness", "3"]):
        r = CliRunner().invoke(app, [*args, *extra, "-o", str(tmp_path / "d.svg"), "--resume", str(ck)])
        assert r.exit_code == 2 and "other inputs or parameters" in r.output, (extra, r.output)
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(InputError, match="not a repulsionpak checkpoint"):
        load_checkpoint(bad)


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigint_writes_partial_packing_and_resume_matches(tmp_path):
    exe = [sys.executable, "-m", "repulsionpak.cli"]
    # the primary phase runs at least 2,500 iterations (about a second), so the signal sent
    # once the first checkpoint (iteration 100) is on disk lands in it however busy the
    # machine: by default this scene's primaries converge ~0.1 s after that checkpoint, and
    # a signal that came later landed in the pocket phase (more copies) or the verification
    config = tmp_path / "long.toml"
    config.write_text("[sim]\nmin_iterations = 2500\n")
    base = ["pack", str(CONTAINER), *map(str, ELEMENTS), "--gap", "12", "--count", "5", "--seed", "5",
            "--max-iterations", "3000", "--config", str(config), "-q"]
    ck, part, resumed, full = (tmp_path / n for n in ("ck.npz", "part.svg", "resumed.svg", "full.svg"))
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    proc = subprocess.Popen([*exe, *base, "-o", str(part), "--checkpoint", str(ck), "--checkpoint-every", "100"],
                            stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.time() + 120
    while not ck.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert ck.exists(), "no checkpoint was written"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    _, placed, info = read_packing_svg(part)
    assert info["partial"] is True and len(placed) == 5
    assert all(p.kind == "primary" for p in placed)  # interrupted in the primary phase
    r = subprocess.run([*exe, *base, "-o", str(resumed), "--resume", str(ck)], capture_output=True, text=True,
                       env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([*exe, *base, "-o", str(full)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert resumed.read_bytes() == full.read_bytes()
