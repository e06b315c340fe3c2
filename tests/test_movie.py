"""`repulsionpak pack --movie OUT.gif|OUT.mp4 [--movie-every N]`: the simulation as an
animation (frames drawn from the snapshots after the run, the finished packing held at
the end). Small scenes from the shipped example library."""

from __future__ import annotations

import json
import math
import sys
from types import SimpleNamespace

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from repulsionpak import examples
from repulsionpak.cli import app
from repulsionpak.errors import OutputError, ParameterError
from repulsionpak.render.movie import MovieRecorder, check_movie_output

BASE = ["pack", str(examples.container_file("circle")), *map(str, examples.element_files()[:4]),
        "--gap", "10", "--count", "6", "--seed", "7", "--max-iterations", "300", "-q"]


def _frames(path):
    """RGB arrays and durations (ms) of every frame of a GIF."""
    out, dur = [], []
    with Image.open(path) as im:
        for i in range(im.n_frames):
            im.seek(i)
            out.append(np.asarray(im.convert("RGB"), dtype=np.int16))
            dur.append(im.info.get("duration"))
    return out, dur


def test_gif_frames_from_movie_every_and_svg_unchanged(tmp_path):
    every = 40  # not a multiple of the usual snapshot cadence (25): snapshots every 5 iterations
    r = CliRunner().invoke(app, [*BASE, "-o", str(tmp_path / "m.svg"), "--report", str(tmp_path / "r.json"),
                                 "--movie", str(tmp_path / "m.gif"), "--movie-every", str(every)])
    assert r.exit_code == 0, r.output
    rep = json.loads((tmp_path / "r.json").read_text())
    # one frame per multiple of N in each phase, the last state of each phase, the result
    its = [n for n in rep["iterations"].values() if n > 0]
    expected = sum(math.ceil(n / every) for n in its) + 1
    assert len(its) == 2  # the pockets were filled: both phases are in the film
    frames, dur = _frames(tmp_path / "m.gif")
    assert len(frames) == expected == rep["movie"]["frames"]
    # the circle's bounds are square: 600 x 600 px
    assert frames[0].shape == (600, 600, 3)
    # elements grew and pockets were filled: far more of the disc is painted at the end
    painted = [float((f.sum(axis=2) < 3 * 250).mean()) for f in (frames[0], frames[-1])]
    assert painted[1] > painted[0] + 0.1, painted
    assert dur[-1] >= 2000 and all(d == dur[0] for d in dur[:-1])
    assert 10 <= 1000 / dur[0] <= 25
    # the same run without --movie writes the same SVG, byte for byte
    r2 = CliRunner().invoke(app, [*BASE, "-o", str(tmp_path / "plain.svg")])
    assert r2.exit_code == 0, r2.output
    assert (tmp_path / "plain.svg").read_bytes() == (tmp_path / "m.svg").read_bytes()


def test_mp4_written(tmp_path):
    ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="pip install 'repulsionpak[mp4]' to test MP4 output")
    out = tmp_path / "m.mp4"
    r = CliRunner().invoke(app, [*BASE, "--no-pocket-fill", "-o", str(tmp_path / "m.svg"),
                                 "--report", str(tmp_path / "r.json"), "--movie", str(out), "--movie-every", "50"])
    assert r.exit_code == 0, r.output
    rep = json.loads((tmp_path / "r.json").read_text())
    data = out.read_bytes()
    assert data[4:8] == b"ftyp"
    n, secs = ffmpeg.count_frames_and_secs(str(out))
    fps = rep["movie"]["fps"]
    # the simulation frames, then the result held for 2 s
    sim = math.ceil(rep["iterations"]["primary"] / 50)
    assert n == rep["movie"]["frames"] == sim + round(2 * fps)
    assert secs == pytest.approx(n / fps, abs=0.1)
    gen = ffmpeg.read_frames(str(out))
    meta = next(gen)
    assert tuple(meta["size"]) == (600, 600)
    gen.close()
    assert not list(tmp_path.glob(".m.mp4*")), "the temp file was left behind"


def test_bad_movie_extension_is_a_usage_error(tmp_path):
    r = CliRunner().invoke(app, [*BASE, "-o", str(tmp_path / "m.svg"), "--movie", str(tmp_path / "m.avi")])
    assert r.exit_code == 2
    assert ".gif or .mp4" in r.output
    assert not (tmp_path / "m.svg").exists()
    r = CliRunner().invoke(app, [*BASE, "-o", str(tmp_path / "m.svg"), "--movie", str(tmp_path / "m.gif"),
                                 "--movie-every", "0"])
    assert r.exit_code == 2
    with pytest.raises(ParameterError, match=r"\.gif or \.mp4"):
        MovieRecorder(tmp_path / "m.webm")


def test_mp4_without_imageio_ffmpeg_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # import fails
    with pytest.raises(OutputError, match=r"pip install 'repulsionpak\[mp4\]'"):
        check_movie_output(tmp_path / "m.mp4")
    assert check_movie_output(tmp_path / "m.gif") == "gif"
    # the command refuses before the run, and writes nothing
    r = CliRunner().invoke(app, [*BASE, "-o", str(tmp_path / "m.svg"), "--movie", str(tmp_path / "m.mp4")])
    assert r.exit_code == OutputError.exit_code
    assert "repulsionpak[mp4]" in r.output
    assert not (tmp_path / "m.svg").exists()


def _snap(it, phase="primary", done=False, n=10):
    st = SimpleNamespace(x=np.full((n, 2), float(it)))
    return SimpleNamespace(phase=phase, iteration=it, done=done, state=st, model=object())


def test_adaptive_stride_keeps_frames_within_bounds():
    """Without --movie-every the stride doubles as the run goes on: any run length ends
    with frames..2*frames evenly spaced frames, the end of each phase kept."""
    for total in (3000, 20000, 77777):
        rec = MovieRecorder("x.gif", frames=60)
        for it in range(25, total + 1, 25):
            rec(_snap(it))
        rec(_snap(total, done=True))
        its = [f.iteration for f in rec.frames]
        assert 60 <= len(its) <= 120
        # the film starts at the first snapshot and ends with the last state
        assert its[0] == 25 and rec.frames[0].pinned
        assert its[-1] == total and rec.frames[-1].pinned
        steps = np.diff(its[1:-1])
        assert (steps == rec.stride).all() and all(i % rec.stride == 0 for i in its[1:-1])
        assert rec.stride >= 25 * total / 25 / 120
        # the copies are frozen: later snapshots did not change them
        assert all(f.x[0, 0] == f.iteration for f in rec.frames)
    # the GIF timing makes a film of 120..240 frames (the default) about 12 s long
    for n in (120, 150, 180, 240):
        delay, fps = MovieRecorder("x.gif").timing(n)
        assert 11 <= n * delay / 100 <= 13.5 and 10 <= fps <= 25
