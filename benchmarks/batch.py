"""Timings of ``repulsionpak batch`` on Dask (not part of the test run).

    python benchmarks/batch.py speedup [--seeds 1-8] [--repeat 2]  # 8 heart packings: in-process, 1 and 2 workers
    python benchmarks/batch.py overhead [--tasks 200]  # per-task cost of the Dask path (instant jobs)
    python benchmarks/batch.py study                    # benchmarks/deformation_study.py (2 k_e x 2 runs), 1 and 2 workers

The heart scene is the paper's (``../shared/data``, gap 5.2, no secondaries); without
it the shipped heart and example library are used. Results are printed as Markdown for
docs/benchmarks.md. The numba kernels are compiled (cached on disk) before timing.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared" / "data"
sys.path.insert(0, str(HERE))

from bench import machine  # noqa: E402


def scene():
    from repulsionpak import examples

    if (SHARED / "containers" / "heart.svg").is_file():
        return SHARED / "containers" / "heart.svg", [SHARED / "animals"], 5.2, "paper heart, 9 animals, gap 5.2"
    return examples.container_file("heart"), examples.element_files(), examples.DEFAULT_GAP, "shipped heart + library"


def warm(container, elements, gap) -> None:
    """Compile / load every kernel once (pack, evaluate with SCP, thumbnail)."""
    from repulsionpak.batch import BatchInputs, make_jobs, run_job
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.params import params_from_dict

    base = params_from_dict({"gap": gap, "sim": {"max_iterations": 50}})
    inputs = BatchInputs(load_container(container), tuple(load_elements(elements)))
    r = run_job(inputs, make_jobs(base, [0])[0])
    assert r.ok, r.error


def first_task_extra(results) -> tuple[float, float]:
    """(mean extra seconds of each worker's first task over the median of the others,
    median task seconds)."""
    by_worker = defaultdict(list)
    for r in results:
        if r is not None and r.ok:
            by_worker[r.worker].append(r)
    med = statistics.median(r.seconds for rs in by_worker.values() for r in rs)
    firsts = [min(rs, key=lambda r: r.started).seconds - med for rs in by_worker.values()]
    return statistics.mean(firsts), med


def bench_speedup(seeds: str = "1-8", repeat: int = 2) -> None:
    """The same batch with 1 and 2 workers, alternated ``repeat`` times (this VM is shared:
    alternating spreads other users' load over both), after one in-process sequential run."""
    from repulsionpak.batch import BatchInputs, make_jobs, parse_seeds, run_batch, run_job
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.params import params_from_dict

    container, elements, gap, what = scene()
    warm(container, elements, gap)
    base = params_from_dict({"gap": gap})
    print(f"{machine()}; {what}; seeds {seeds}")
    # in this process, one after the other: the work itself
    inputs = BatchInputs(load_container(container, tolerance=base.preprocess.flatten_tolerance * gap),
                         tuple(load_elements(elements)))
    t = time.perf_counter()
    seq = [run_job(inputs, j) for j in make_jobs(base, parse_seeds(seeds))]
    t_seq = time.perf_counter() - t
    assert all(r.ok for r in seq), [r.error for r in seq]
    print(f"in-process sequential: {t_seq:.1f} s, task CPU time {sum(r.cpu_seconds for r in seq):.1f} s "
          f"(median {statistics.median(r.seconds for r in seq):.2f} s), 1-min load average after "
          f"{os.getloadavg()[0]:.1f}")
    print("| workers | whole command | cluster start | tasks (first submit to last result) | "
          "first task per worker, extra | median task | task CPU time, sum | parallelism | "
          "same packings as in-process | load average |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: |")
    totals = defaultdict(list)
    for _ in range(repeat):
        for workers in (1, 2):
            marks = {}
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                s = run_batch(container, elements, Path(tmp) / "out", seeds, base=base, workers=workers,
                              on_start=lambda n, c: marks.setdefault("up", time.perf_counter()),
                              on_result=lambda i, j, r: marks.__setitem__("last", time.perf_counter()))
                total = time.perf_counter() - t0
            assert s.n_done == len(s.jobs), [r.error for r in s.results if r and not r.ok]
            extra, med = first_task_extra(s.results)
            same = all(a.metrics["area_fraction"] == b.metrics["area_fraction"] for a, b in zip(seq, s.results))
            totals[workers].append(total)
            window = marks["last"] - marks["up"]
            cpu = sum(r.cpu_seconds for r in s.results)
            print(f"| {workers} | {total:.1f} s | {marks['up'] - t0:.1f} s | {window:.1f} s "
                  f"| {extra:+.2f} s | {med:.2f} s | {cpu:.1f} s | {cpu / window:.2f} | {same} "
                  f"| {os.getloadavg()[0]:.1f} |", flush=True)
    ratios = [a / b for a, b in zip(totals[1], totals[2])]
    print(f"speed-up 1 -> 2 workers (whole command, per pair): {', '.join(f'{r:.2f}x' for r in ratios)}; "
          f"in-process sequential {t_seq:.1f} s")


def bench_overhead(tasks: int = 200) -> None:
    """Jobs that fail at once (a gap too large for the container) run the whole Dask path
    (submit, scatter lookup, result transfer, callback) with no packing work."""
    from repulsionpak.batch import BatchInputs, dask_client, make_jobs, parse_seeds, run_jobs
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.params import params_from_dict

    container, elements, gap, what = scene()
    inputs = BatchInputs(load_container(container), tuple(load_elements(elements)))
    jobs = make_jobs(params_from_dict({"gap": 1000.0}), parse_seeds(f"1-{tasks}"))
    print(f"{machine()}; {tasks} instant jobs ({what} inputs scattered once)")
    print("| workers | tasks | wall | per task |")
    print("| ---: | ---: | ---: | ---: |")
    for workers in (1, 2):
        with dask_client(workers=workers) as client:
            run_jobs(client, inputs, jobs[:4])  # workers up and importing
            t = time.perf_counter()
            res, _ = run_jobs(client, inputs, jobs)
            dt = time.perf_counter() - t
        assert all(r is not None and "absurdly large" in r.error for r in res)
        print(f"| {workers} | {tasks} | {dt:.2f} s | {1000 * dt / tasks:.1f} ms |")


def bench_study() -> None:
    print(machine())
    print("| workers | `python benchmarks/deformation_study.py --runs 2 --k-edge 10 --k-edge 1000` wall |")
    print("| ---: | ---: |")
    for workers in (1, 2):
        with tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            subprocess.run([sys.executable, str(HERE / "deformation_study.py"), "-o", f"{tmp}/s.png", "--runs", "2",
                            "--k-edge", "10", "--k-edge", "1000", "--workers", str(workers), "-q"], check=True)
            print(f"| {workers} | {time.perf_counter() - t:.1f} s |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("what", choices=["speedup", "overhead", "study"])
    ap.add_argument("--seeds", default="1-8")
    ap.add_argument("--tasks", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args()
    if a.what == "speedup":
        bench_speedup(a.seeds, a.repeat)
    elif a.what == "overhead":
        bench_overhead(a.tasks)
    else:
        bench_study()


if __name__ == "__main__":
    main()
