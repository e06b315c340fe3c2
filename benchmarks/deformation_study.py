"""The paper's deformation study (sec. 11, Fig. 10): how the spring strength k_e changes
the evenness of the negative space, measured by the spherical contact probability.

The packings run as Dask tasks through :mod:`repulsionpak.batch`, like ``repulsionpak
batch``: one task per (k_e, run), on a local cluster or an existing scheduler.

Usage (a study of the library, not a command of it)::

    python benchmarks/deformation_study.py --runs 10 -o docs/images/deformation-study.png --json study.json
    python benchmarks/deformation_study.py --help
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from repulsionpak.batch import BatchInputs, Job, JobFailed, dask_client, run_jobs
from repulsionpak.errors import OutputError, ParameterError, RepulsionPakError
from repulsionpak.params import Params
from repulsionpak.types import Container, Element


def study_jobs(gap: float, k_values: Sequence[float] = (10.0, 250.0, 1000.0), runs: int = 10,
               count_range: tuple[int, int] = (23, 27), seed: int = 0, base: Params = Params()) -> list[Job]:
    """The study's packings, k_e outermost: run i of every k_e uses the same seed and
    count (random in ``count_range``, drawn from ``(seed, i)``), so the groups differ
    only by k_e; no secondary elements and no pocket filling (``secondary.auto`` off). Workers return the metrics with the SCP curve, no SVG or thumbnail."""
    if runs < 1:
        raise ValueError("runs must be >= 1")
    jobs = []
    for k_e in k_values:
        for i in range(runs):
            rng = np.random.default_rng([seed, i])
            count = int(rng.integers(count_range[0], count_range[1] + 1))
            p = dataclasses.replace(
                base, gap=gap, seed=int(rng.integers(2**31)),
                sim=dataclasses.replace(base.sim, k_edge=float(k_e)),
                placement=dataclasses.replace(base.placement, count=count),
                secondary=dataclasses.replace(base.secondary, auto=False)).validate()  # as the paper: none
            jobs.append(Job(seed=p.seed, params=p, setting=(("sim.k_edge", float(k_e)),),
                            name=f"k_e={k_e:g} run {i + 1}", svg=False, thumbnail_px=0, scp=True))
    return jobs


def deformation_study(container: Container, elements: Sequence[Element], gap: float,
                      k_values: Sequence[float] = (10.0, 250.0, 1000.0), runs: int = 10,
                      count_range: tuple[int, int] = (23, 27), seed: int = 0, base: Params = Params(),
                      on_run: Callable[[float, int, dict], None] | None = None,
                      workers: int | None = None, scheduler: str | None = None, client=None) -> dict:
    """Pack ``runs`` random packings per spring strength k_e and measure each.

    As in the paper: every packing uses a random count of primary elements in
    ``count_range`` and no secondary elements; run i of every k_e uses the same seed, so
    the groups differ only by k_e (k_e is in the paper's units, like the defaults).

    The packings are Dask tasks (see :mod:`repulsionpak.batch`): on ``client`` if given,
    else on the scheduler at ``scheduler``, else on a local cluster of ``workers``
    processes (default: one per core). ``on_run(k_e, i, result)`` is called as each
    packing finishes (in completion order). A failed packing raises :class:`JobFailed`
    naming the run; Ctrl-C cancels the rest and re-raises KeyboardInterrupt.

    Returns ``{"gap": gap, "groups": {"k_e=10": [evaluate() result, ...], ...},
    "summary": {label: {"area_fraction": mean, "scp_ratio": mean, "scp_ratio_std": std,
    "deformation": mean}}}``.
    """
    jobs = study_jobs(gap, k_values, runs, count_range, seed, base)
    inputs = BatchInputs(container, tuple(elements))

    def collect(j: int, res) -> None:
        if on_run is not None and res.metrics is not None:
            on_run(k_values[j // runs], j % runs, _result(res))

    if client is not None:
        results, interrupted = run_jobs(client, inputs, jobs, collect)
    else:
        with dask_client(workers, scheduler) as c:
            results, interrupted = run_jobs(c, inputs, jobs, collect)
    if interrupted:
        raise KeyboardInterrupt
    for job, res in zip(jobs, results):
        if res.metrics is None:  # a packing that breaks a promise is still measured, as before
            raise JobFailed(f"deformation study, {job.name}: {res.error}", res.exit_code)
    groups: dict[str, list[dict]] = {}
    for j, k_e in enumerate(k_values):
        groups[f"k_e={k_e:g}"] = [_result(r) for r in results[j * runs:(j + 1) * runs]]
    summary = {}
    for label, res in groups.items():
        ratios = np.array([r["scp_ratio"] for r in res], dtype=float)
        summary[label] = {
            "area_fraction": float(np.mean([r["area_fraction"] for r in res])),
            "scp_ratio": float(np.mean(ratios)), "scp_ratio_std": float(np.std(ratios)),
            "deformation": float(np.mean([r["deformation"]["mean"] or 0.0 for r in res])),
            "overlap_area": float(np.max([r["overlap_area"] for r in res])),
        }
    return {"gap": gap, "groups": groups, "summary": summary}


def _result(res) -> dict:
    """A study entry: the evaluate() metrics plus the primary phase's iterations."""
    return dict(res.metrics, iterations=res.iterations.get("primary", 0))


def study(output: Path, container: Path | None = None, elements: Sequence[Path] | None = None,
          gap: float | None = None, k_values: Sequence[float] | None = None, runs: int = 10, seed: int = 0,
          json_out: Path | None = None, workers: int | None = None, scheduler: str | None = None,
          quiet: bool = False) -> dict:
    """Run the study on files and write its plot (and ``json_out``); returns the
    :func:`deformation_study` result. Defaults: the shipped heart and element library at
    the example gap; a container of your own gets :func:`repulsionpak.inputs.default_gap`."""
    from repulsionpak import examples
    from repulsionpak.measure import scp_bands_png
    from repulsionpak.io import load_container, load_elements
    from repulsionpak.io.files import atomic_write_bytes
    from repulsionpak.inputs import default_gap

    if runs < 1:
        raise ParameterError(f"--runs must be >= 1, got {runs}")
    cfile = container or examples.container_file(examples.DEFAULT_CONTAINER)
    efiles = list(elements or examples.element_files())
    for out in (output, json_out):
        if out is not None and any(out.resolve() == f.resolve() for f in [cfile, *efiles]):
            raise OutputError(f"{out}: refusing to overwrite an input; choose another output path")
    cont = load_container(cfile)
    g = gap if gap is not None else (examples.DEFAULT_GAP if container is None else default_gap(cont))
    if not g > 0:
        raise ParameterError(f"--gap must be a positive number, got {g:g}")
    elems = load_elements(efiles)
    ks = list(k_values or [10.0, 250.0, 1000.0])
    for k in ks:
        if not k >= 0:
            raise ParameterError(f"--k-edge must be a number >= 0, got {k:g}")

    def on_run(k, i, r):
        if not quiet:
            print(f"k_e={k:g} run {i + 1}/{runs}: area {r['area_fraction']:.3f}, "
                  f"Q_s(gap/2)/Q_s(0) {r['scp_ratio']:.3f}", file=sys.stderr)

    res = deformation_study(cont, elems, g, ks, runs=runs, seed=seed, on_run=on_run,
                            workers=workers, scheduler=scheduler)
    atomic_write_bytes(output, scp_bands_png(res["groups"], g))
    if json_out is not None:
        slim = {"gap": g, "summary": res["summary"],
                "groups": {k: [{"area_fraction": r["area_fraction"], "scp": r["scp"],
                                "scp_ratio": r["scp_ratio"], "deformation": r["deformation"]["mean"]}
                               for r in v] for k, v in res["groups"].items()}}
        atomic_write_bytes(json_out, (json.dumps(slim, indent=2) + "\n").encode("utf-8"))
    return res


def main(argv: Sequence[str] | None = None) -> int:
    """The command line: prints one line per k_e; errors as one ``deformation_study: error:``
    line with the error's exit code (3 for a bad parameter, as ``repulsionpak``)."""
    ap = argparse.ArgumentParser(description="The paper's deformation study (Fig. 10): SCP of packings "
                                 "with weak to stiff springs, run as Dask tasks like `repulsionpak batch`.")
    ap.add_argument("-o", "--output", type=Path, default=Path("deformation-study.png"),
                    help="plot of Q_s(r) per k_e (PNG)")
    ap.add_argument("--container", type=Path, help="container file (default: the shipped heart)")
    ap.add_argument("--elements", type=Path, action="append",
                    help="element file or directory, repeatable (default: the shipped library)")
    ap.add_argument("--gap", type=float, help="gap (default: the example gap, or 1%% of the container)")
    ap.add_argument("--k-edge", type=float, action="append", dest="k_edge",
                    help="spring strength to compare, repeatable (paper: 10 250 1000)")
    ap.add_argument("--runs", type=int, default=10, help="packings per k_e (paper: 10)")
    ap.add_argument("--seed", type=int, default=0, help="base seed")
    ap.add_argument("--json", type=Path, dest="json_out", help="also write all results as JSON")
    ap.add_argument("--workers", type=int, help="worker processes of the local Dask cluster (default: one per core)")
    ap.add_argument("--scheduler", help="run on this Dask scheduler (tcp://HOST:PORT) instead of a local cluster")
    ap.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    a = ap.parse_args(argv)
    try:
        res = study(a.output, a.container, a.elements, a.gap, a.k_edge, a.runs, a.seed, a.json_out,
                    a.workers, a.scheduler, a.quiet)
    except RepulsionPakError as exc:
        print(f"deformation_study: error: {exc}", file=sys.stderr)
        return getattr(exc, "exit_code", 1)
    except KeyboardInterrupt:
        print("deformation_study: interrupted", file=sys.stderr)
        return 130
    for label, s in res["summary"].items():
        print(f"{label:>10s}: mean area fraction {s['area_fraction']:.3f}, "
              f"Q_s(gap/2)/Q_s(0) {s['scp_ratio']:.3f} ± {s['scp_ratio_std']:.3f}, "
              f"mean deformation {s['deformation']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
