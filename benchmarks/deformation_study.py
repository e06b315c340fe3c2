"""The paper's deformation study (sec. 11, Fig. 10): how the spring strength k_e changes
the evenness of the negative space, measured by the spherical contact probability.

The packings run as Dask tasks through :mod:`repulsionpak.batch`, like ``repulsionpak
batch``: one task per (k_e, run), on a local cluster or an existing scheduler.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from .batch import BatchInputs, Job, JobFailed, dask_client, run_jobs
from .params import Params
from .types import Container, Element


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


__all__ = ["deformation_study", "study_jobs"]
