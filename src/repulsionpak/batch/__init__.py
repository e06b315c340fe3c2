"""Many packings as Dask tasks: ``repulsionpak batch`` and the deformation study.

One task per job (a seed × a combination of ``--set`` values). The client reads the
inputs once and sends them to the workers once (:func:`run_jobs` scatters them); every
task runs :func:`repulsionpak.pack.pack` with its job's :class:`~repulsionpak.params.Params`,
measures the packing with :func:`repulsionpak.measure.evaluate` and returns a
:class:`JobResult` holding the SVG text, the metrics and a thumbnail PNG — never a file.
The client writes every output (:func:`write_svg`, :func:`write_summary`).

The cluster is a :class:`distributed.LocalCluster` of single-threaded worker processes
by default, or an existing scheduler (``dask scheduler`` + ``dask worker``) reached by
its address; see :func:`dask_client`.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import OutputError
from ..params import Params
from .jobs import MAX_JOBS, THUMBNAIL_PX, Job, make_jobs, parse_seeds, parse_set, thumbnail_size
from .outputs import CSV_COLUMNS, best_result, check_outdir, results_csv, write_summary, write_svg
from .tasks import BatchInputs, JobFailed, JobResult, dask_client, require_dask, run_job, run_jobs


@dataclass
class BatchSummary:
    """What :func:`run_batch` did: every job and result (in job order), the best one."""

    jobs: list[Job]
    results: list[JobResult | None]
    best: JobResult | None
    interrupted: bool
    seconds: float

    @property
    def n_failed(self) -> int:
        return sum(1 for r in self.results if r is not None and not r.ok)

    @property
    def n_done(self) -> int:
        return sum(1 for r in self.results if r is not None and r.ok)


def _n_combos(settings) -> int:
    n = 1
    for _, values in settings:
        n *= len(values)
    return n


def run_batch(container: Path, elements: Sequence[Path], outdir: Path, seeds: str,
              sets: Sequence[str] = (), base: Params = Params(), secondary: Sequence[Path] = (),
              workers: int | None = None, scheduler: str | None = None,
              on_start: Callable[[int, object], None] | None = None,
              on_result: Callable[[int, Job, JobResult], None] | None = None,
              controls=None) -> BatchSummary:
    """Everything ``repulsionpak batch`` does: parse ``--seeds`` and ``--set``, read the
    inputs once, run the jobs on Dask, write ``OUTDIR/*.svg`` as results arrive, then
    ``results.csv``, ``best.svg`` and ``contact-sheet.png``.

    ``on_start(n_jobs, client)`` is called once the cluster is up, ``on_result(i, job,
    result)`` per finished job. ``controls``: the CLI's default element controls
    (element manifests among ``elements`` are read as by ``pack``). A Ctrl-C (KeyboardInterrupt) cancels the rest and still
    writes the outputs of what finished (``summary.interrupted``).
    """
    from ..inputs import load_inputs, run_container

    require_dask("repulsionpak batch")
    t0 = time.perf_counter()
    check_outdir(outdir, [container, *elements, *secondary], [*elements, *secondary])
    seed_list = parse_seeds(seeds)
    settings = [parse_set(s) for s in sets]
    make_jobs(base, seed_list, settings)  # all parameter errors before any work
    read = load_inputs(container, list(elements), base, list(secondary), controls)  # the gap, as pack reads
    jobs = make_jobs(read.params, seed_list, settings, thumbnail_size(len(seed_list) * _n_combos(settings)))
    cont = read.container
    least = min(j.params.gap for j in jobs)
    if least != read.params.gap:  # --set gap=...: the container flattened for the finest gap
        cont, _ = run_container(container, dataclasses.replace(read.params, gap=least))
    inputs = BatchInputs(cont, read.elements, read.secondary)
    outdir = Path(outdir)
    files: dict[int, str] = {}
    best: list = [None, None]  # ((scp_half_gap, job index), svg text) of the best so far

    def collect(i: int, r: JobResult) -> None:
        if r.svg is not None:  # also a packing that breaks a promise, for inspection
            files[i] = write_svg(outdir, r)
            q = r.scp_half_gap
            if r.ok and q is not None and (best[0] is None or (q, i) < best[0]):  # ties: the first job
                best[0], best[1] = (q, i), r.svg
            r.svg = None  # written: do not keep hundreds of SVGs in memory
        if on_result is not None:
            on_result(i, jobs[i], r)

    with dask_client(workers, scheduler) as client:
        try:  # once the cluster is there, before any work
            outdir.mkdir(parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError):
            raise OutputError(f"{outdir}: exists and is not a directory; -o names the output directory") from None
        except OSError as exc:
            raise OutputError(f"{outdir}: cannot create the output directory ({exc.strerror or exc})") from None
        if on_start is not None:
            on_start(len(jobs), client)
        results, interrupted = run_jobs(client, inputs, jobs, collect)
    best_r = write_summary(outdir, jobs, results, [n for n, _ in settings], files, best[1])
    return BatchSummary(jobs, results, best_r, interrupted, time.perf_counter() - t0)


__all__ = ["BatchInputs", "BatchSummary", "CSV_COLUMNS", "MAX_JOBS", "THUMBNAIL_PX", "Job", "JobFailed",
           "JobResult", "best_result", "check_outdir", "dask_client", "make_jobs", "parse_seeds", "parse_set",
           "require_dask", "results_csv", "run_batch", "run_job", "run_jobs", "thumbnail_size", "write_summary", "write_svg"]
