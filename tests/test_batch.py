"""Batches of packings on Dask (``repulsionpak batch``) and the deformation study on the
same machinery: option parsing, a real LocalCluster, a scheduler and a worker started as
separate processes on 127.0.0.1, a failing job, cancellation (API and a real Ctrl-C).

The scene is tiny (5 elements, 300 + 300 iterations) so each packing takes about a second.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import repulsionpak
from repulsionpak import examples
from repulsionpak.batch import (CSV_COLUMNS, BatchInputs, dask_client, make_jobs, parse_seeds, parse_set,
                                run_batch, run_jobs)
from repulsionpak.cli import app
from repulsionpak.errors import ConfigError, OutputError, ParameterError
from repulsionpak.measure import evaluate, evaluate_file
from repulsionpak.io import load_container, load_elements
from repulsionpak.pack import pack
from repulsionpak.params import SimParams, params_from_dict
from deformation_study import deformation_study, study_jobs
from deformation_study import main as study_main

pytest.importorskip("distributed")

EX = examples.examples_dir()
CONTAINER = EX / "containers" / "circle.svg"
ELEMENTS = [EX / "elements" / "apple.svg", EX / "elements" / "fish.svg"]
TINY = ["--gap", "10", "--count", "5", "--max-iterations", "300", "--no-pocket-fill"]
SRC = Path(repulsionpak.__file__).resolve().parents[1]


def tiny_params(**more):
    """5 elements, 300 + 300 iterations, no pocket filling: about a second per packing."""
    return params_from_dict({"gap": 10.0, "placement": {"count": 5}, "sim": {"max_iterations": 300},
                             "secondary": {"auto": False}, **more})


def png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def read_csv(path: Path) -> tuple[list[str], list[dict]]:
    text = path.read_text()
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], [dict(zip(rows[0], r)) for r in rows[1:]]


# --------------------------------------------------------------------------- parsing


def test_parse_seeds():
    assert parse_seeds("1-4") == [1, 2, 3, 4]
    assert parse_seeds("7") == [7]
    assert parse_seeds("5, 1-2,2") == [1, 2, 5]
    for bad in ("", "a-b", "4-1", "-3", "1-", "1.5"):
        with pytest.raises(ParameterError, match="--seeds"):
            parse_seeds(bad)
    with pytest.raises(ParameterError, match="more than"):
        parse_seeds("0-10000000")


def test_parse_set_values_and_errors():
    assert parse_set("sim.k_edge=10,250.5, 1e3") == ("sim.k_edge", [10, 250.5, 1000.0])
    assert parse_set("placement.count=none,30") == ("placement.count", [None, 30])
    assert parse_set("gap=4") == ("gap", [4])
    for bad, msg in (("sim.k_edge", "expected SECTION.NAME"), ("=1", "expected SECTION.NAME"),
                     ("sim.k_edge=1,,2", "empty value"), ("sim.k_edge=1,1", "given twice"),
                     ("a.b.c=1", "not a parameter name"), ("seed=1,2", "--seeds")):
        with pytest.raises(ParameterError, match=msg):
            parse_set(bad)


def test_make_jobs_product_and_strict_names():
    base = tiny_params()
    jobs = make_jobs(base, [1, 2], [parse_set("sim.k_edge=10,40"), parse_set("gap=8,9")])
    assert len(jobs) == 8 and len({j.name for j in jobs}) == 8
    assert [j.seed for j in jobs] == [1] * 4 + [2] * 4
    assert jobs[0].name == "seed-1_sim.k_edge-10_gap-8"
    for j in jobs:
        s = dict(j.setting)
        assert j.params.seed == j.seed and j.params.sim.k_edge == s["sim.k_edge"] and j.params.gap == s["gap"]
        assert j.params.placement.count == 5  # the base is kept
    with pytest.raises(ConfigError, match="did you mean 'k_edge'"):
        make_jobs(base, [1], [parse_set("sim.k_edg=10")])
    with pytest.raises(ConfigError, match="did you mean 'gap'"):
        make_jobs(base, [1], [parse_set("gpa=10")])
    with pytest.raises(ConfigError, match=r"--set sim.k_edge=abc: sim.k_edge must be a float"):
        make_jobs(base, [1], [parse_set("sim.k_edge=abc")])
    with pytest.raises(ParameterError, match="--set sim.dt=2"):
        make_jobs(base, [1], [parse_set("sim.dt=0.1,2")])
    with pytest.raises(ParameterError, match="more than once"):
        make_jobs(base, [1], [parse_set("gap=1"), parse_set("gap=2")])


def test_cli_option_errors_exit_3(tmp_path):
    r = CliRunner()
    for extra, msg in ((["--seeds", "x"], "--seeds"), (["--seeds", "1", "--set", "sim.k_edg=1"], "did you mean"),
                       (["--seeds", "1", "--count", "0"], "--count"), (["--seeds", "1", "--workers", "0"], "--workers")):
        res = r.invoke(app, ["batch", str(CONTAINER), *map(str, ELEMENTS), "-o", str(tmp_path / "o"), *extra])
        assert res.exit_code == 3, (extra, res.output)
        assert msg in res.output
    with pytest.raises(OutputError, match="input directory"):
        run_batch(CONTAINER, [EX / "elements"], EX / "elements", "1")
    # element files given one by one: their folder would read the packings back as elements
    with pytest.raises(OutputError, match="holds the element apple.svg"):
        run_batch(CONTAINER, [EX / "elements" / "apple.svg"], EX / "elements", "1")
    assert sorted(p.suffix for p in (EX / "elements").iterdir()) == [".svg"] * len(list((EX / "elements").iterdir()))


# --------------------------------------------------------------------------- a real LocalCluster


@pytest.fixture(scope="module")
def local_client():
    """A real LocalCluster of 2 single-threaded worker processes, shared by the tests below
    (each worker process loads the numba kernels once)."""
    with dask_client(workers=2) as client:
        yield client


@pytest.mark.slow
def test_batch_cli_on_the_local_cluster(tmp_path, local_client):
    """Two seeds × two gaps through the CLI on the LocalCluster (``--scheduler``): the gap
    of 300 cannot work in a 460-unit circle, so those two jobs fail and are recorded, the
    others finish; the CSV, best.svg and the contact sheet agree with the SVGs."""
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["batch", str(CONTAINER), *map(str, ELEMENTS), "-o", str(out), "--seeds", "1-2",
                                   "--set", "gap=10,300", "--count", "5", "--max-iterations", "300",
                                   "--no-pocket-fill", "--scheduler", local_client.scheduler.address, "-q"])
    assert res.exit_code == 1, res.output  # some jobs failed
    assert "2 of 4 packings failed" in res.output
    header, rows = read_csv(out / "results.csv")
    assert header == [*CSV_COLUMNS, "gap"]
    assert [(r["seed"], r["gap"]) for r in rows] == [("1", "10"), ("1", "300"), ("2", "10"), ("2", "300")]
    for r in rows:
        if r["gap"] == "300":
            assert "absurdly large" in r["error"] and r["file"] == "" and r["area_fraction"] == ""
            continue
        # (the growing iterations stop at --max-iterations, the settling ones follow)
        settle = SimParams().settle_iterations
        assert r["error"] == "" and int(r["iterations"]) == 300 + settle and float(r["seconds"]) > 0
        m = evaluate_file(out / r["file"])  # the CSV describes the file written
        # (the file holds the art as fitted curves, within render's tolerance of the
        # polylines the metrics were computed on)
        assert float(r["area_fraction"]) == pytest.approx(m["area_fraction"], rel=3e-3)
        assert float(r["scp_half_gap"]) == pytest.approx(m["scp_at_half_gap"], rel=1e-2, abs=1e-3)
        assert float(r["gap_median"]) == pytest.approx(m["gap"]["median"], rel=1e-2)
        assert float(r["overlap_area"]) == pytest.approx(m["overlap_area"], abs=1e-6)
    ok = [r for r in rows if r["file"]]
    best = min(ok, key=lambda r: float(r["scp_half_gap"]))
    assert (out / "best.svg").read_bytes() == (out / best["file"]).read_bytes()
    assert sorted(p.name for p in out.glob("*.svg")) == sorted(["best.svg", *(r["file"] for r in ok)])
    # contact sheet: 4 tiles in 2 columns of 240 px, each with an 18 px label strip
    data = (out / "contact-sheet.png").read_bytes()
    assert png_size(data) == (2 * 240, 2 * (240 + 18))
    import matplotlib.image as mimage

    img = mimage.imread(io.BytesIO(data), format="png")[..., :3]
    tiles = [img[r * 258:r * 258 + 240, c * 240:(c + 1) * 240] for r in range(2) for c in range(2)]
    for t, row in zip(tiles, rows):
        coloured = np.count_nonzero(np.ptp(t, axis=2) > 0.2)  # the art is orange/red, the rest grey
        assert (coloured > 500) == bool(row["file"]), row
    # a batch job is the packing `repulsionpak pack` makes with that seed, byte for byte
    one = tmp_path / "one.svg"
    res = CliRunner().invoke(app, ["pack", str(CONTAINER), *map(str, ELEMENTS), "-o", str(one), "--seed", "2", *TINY,
                                   "-q"])
    assert res.exit_code == 0, res.output
    assert one.read_bytes() == (out / "seed-2_gap-10.svg").read_bytes()


@pytest.mark.slow
def test_study_runs_on_the_batch_machinery_with_the_same_results(local_client):
    """The deformation study through Dask gives exactly what packing each run in this
    process gives."""
    cont, elems = load_container(CONTAINER), load_elements(ELEMENTS)
    base = tiny_params()
    seen = []
    res = deformation_study(cont, elems, 10.0, (10.0, 1000.0), runs=1, count_range=(4, 5), base=base,
                            on_run=lambda k, i, r: seen.append((k, i)), client=local_client)
    assert sorted(seen) == [(10.0, 0), (1000.0, 0)]
    jobs = study_jobs(10.0, (10.0, 1000.0), runs=1, count_range=(4, 5), base=base)
    for job, label in zip(jobs, ("k_e=10", "k_e=1000")):
        packing = pack(cont, elems, job.params)
        direct = evaluate(packing.container, packing.placed, 10.0)  # the container as the run flattened it
        got = res["groups"][label][0]
        assert got["iterations"] == packing.iterations["primary"]
        assert json.dumps({k: got[k] for k in direct}, sort_keys=True) == json.dumps(direct, sort_keys=True)
    assert set(res["summary"]) == {"k_e=10", "k_e=1000"}
    for label, group in res["groups"].items():
        assert res["summary"][label]["area_fraction"] == pytest.approx(group[0]["area_fraction"])


def test_study_script_names_a_bad_option(tmp_path, capsys):
    """benchmarks/deformation_study.py: a bad --k-edge is one error line naming the option,
    the exit code of a parameter error, and no plot."""
    out = tmp_path / "s.png"
    assert study_main(["--runs", "1", "--k-edge", "-5", "-o", str(out), "-q"]) == 3
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.strip().splitlines() == ["deformation_study: error: --k-edge must be a number >= 0, got -5"]
    assert not out.exists()
    assert study_main(["--runs", "0", "-o", str(out), "-q"]) == 3
    assert "--runs must be >= 1, got 0" in capsys.readouterr().err


@pytest.mark.slow
def test_run_jobs_interrupt_cancels_the_rest(local_client):
    """A KeyboardInterrupt while collecting (here raised by the callback after the first
    result) cancels the remaining jobs, and a running one stops within a second or so."""
    inputs = BatchInputs(load_container(CONTAINER, tolerance=2.5), tuple(load_elements(ELEMENTS)))
    quick = make_jobs(tiny_params(), [1])[0]
    endless = make_jobs(tiny_params(sim={"max_iterations": 1_000_000, "min_iterations": 1_000_000}), [2])[0]

    def stop(i, r):
        raise KeyboardInterrupt

    results, interrupted = run_jobs(local_client, inputs, [quick, endless], stop)
    assert interrupted
    assert results[0] is not None and results[0].ok and results[1] is None

    def executing(dask_worker):
        return dask_worker.state.executing_count

    deadline = time.monotonic() + 15  # the endless task would run for hours
    while sum(local_client.run(executing).values()):
        assert time.monotonic() < deadline, "the cancelled task is still running"
        time.sleep(0.2)


# --------------------------------------------------------------------------- separate processes


@pytest.fixture
def scheduler_and_worker(tmp_path):
    """``dask scheduler`` and ``dask worker`` as separate processes on 127.0.0.1."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]))
    sfile = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                                       "--port", "0", "--no-dashboard", "--scheduler-file", str(sfile)],
                                      env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE))
        deadline = time.monotonic() + 60
        while not (sfile.exists() and sfile.stat().st_size):
            assert procs[0].poll() is None, procs[0].stderr.read().decode()
            assert time.monotonic() < deadline, "the scheduler did not start"
            time.sleep(0.2)
        address = json.loads(sfile.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        procs.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", address, "--nthreads", "1",
                                       "--nworkers", "1", "--host", "127.0.0.1", "--no-dashboard"],
                                      env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        from distributed import Client

        with Client(address, timeout=30) as c:
            c.wait_for_workers(1, timeout=60)
        yield address, procs[1]
    finally:
        import psutil

        for p in reversed(procs):  # the worker (and its nanny's child), then the scheduler
            tree = [p.pid]
            with contextlib.suppress(psutil.Error):
                tree += [c.pid for c in psutil.Process(p.pid).children(recursive=True)]
            p.terminate()
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
            for pid in tree[1:]:
                with contextlib.suppress(OSError):
                    os.kill(pid, signal.SIGKILL)


@pytest.mark.slow
def test_batch_on_separate_scheduler_and_worker(tmp_path, scheduler_and_worker):
    import psutil

    address, worker_proc = scheduler_and_worker
    out = tmp_path / "out"
    seen = []
    summary = run_batch(CONTAINER, ELEMENTS, out, "3-4", ["sim.k_edge=20"], tiny_params(), scheduler=address,
                        on_result=lambda i, j, r: seen.append(r.worker))
    assert not summary.interrupted and summary.n_done == 2 and summary.n_failed == 0
    # the work ran in the `dask worker` process tree, not here
    pids = {int(w.rpartition(":")[2]) for w in seen}
    tree = {worker_proc.pid, *(c.pid for c in psutil.Process(worker_proc.pid).children(recursive=True))}
    assert pids and pids <= tree and os.getpid() not in pids
    header, rows = read_csv(out / "results.csv")
    assert header == [*CSV_COLUMNS, "sim.k_edge"] and [r["seed"] for r in rows] == ["3", "4"]
    assert all(r["error"] == "" and (out / r["file"]).is_file() for r in rows)
    assert png_size((out / "contact-sheet.png").read_bytes()) == (2 * 240, 240 + 18)
    with pytest.raises(ParameterError, match="--workers"):
        run_batch(CONTAINER, ELEMENTS, out, "1", scheduler=address, workers=2)


# --------------------------------------------------------------------------- Ctrl-C


@pytest.mark.slow
def _default_sigint() -> None:
    """In the child: SIGINT back to its default disposition. A test run started in the
    background (``pytest &``, nohup, some CI runners) ignores SIGINT, and an ignored signal
    stays ignored across exec, so the Ctrl-C under test would never arrive."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_ctrl_c_cancels_cleanly(tmp_path):
    """A real SIGINT to the whole process group (as a terminal's Ctrl-C): exit 130, no
    traceback, the finished job written, the endless one recorded as cancelled, no
    process left behind."""
    out = tmp_path / "out"
    cfg = tmp_path / "c.toml"
    cfg.write_text("gap = 10.0\n[placement]\ncount = 5\n[sim]\nstop_epsilon = 0.0\n[secondary]\nauto = false\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen([sys.executable, "-m", "repulsionpak.cli", "batch", str(CONTAINER), *map(str, ELEMENTS),
                             "-o", str(out), "--seeds", "1", "--config", str(cfg), "--workers", "2",
                             "--set", "sim.max_iterations=300,1000000"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=_default_sigint)
    try:
        lines = []
        deadline = time.monotonic() + 90
        while not any(line.startswith("[1/2]") for line in lines):
            assert time.monotonic() < deadline and proc.poll() is None, "".join(lines)
            lines.append(proc.stderr.readline())
        time.sleep(1.0)  # the endless job is running now
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=40)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    err = "".join(lines) + err
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "interrupted" in err
    _, rows = read_csv(out / "results.csv")
    assert rows[0]["error"] == "" and (out / rows[0]["file"]).is_file()
    assert rows[1]["error"].startswith("cancelled") and rows[1]["file"] == ""
    assert (out / "best.svg").read_bytes() == (out / rows[0]["file"]).read_bytes()
    import psutil

    time.sleep(0.5)
    left = [p for p in psutil.process_iter(["pid", "status"])
            if _pgid(p.pid) == proc.pid and p.info["status"] != psutil.STATUS_ZOMBIE]
    assert not left, left


def _pgid(pid: int) -> int | None:
    try:
        return os.getpgid(pid)
    except OSError:
        return None
