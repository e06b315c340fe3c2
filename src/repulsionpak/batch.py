"""Many packings as Dask tasks: ``repulsionpak batch`` and the deformation study.

One task per job (a seed × a combination of ``--set`` values). The client reads the
inputs once and sends them to the workers once (:func:`run_jobs` scatters them); every
task runs :func:`repulsionpak.pack.pack` with its job's :class:`~repulsionpak.params.Params`,
measures the packing with :func:`repulsionpak.evaluate.evaluate` and returns a
:class:`JobResult` holding the SVG text, the metrics and a thumbnail PNG — never a file.
The client writes every output (:func:`write_svg`, :func:`write_summary`).

The cluster is a :class:`distributed.LocalCluster` of single-threaded worker processes
by default, or an existing scheduler (``dask scheduler`` + ``dask worker``) reached by
its address; see :func:`dask_client`.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import io
import itertools
import logging
import math
import os
import re
import signal
import socket
import time
import tomllib
import uuid
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from .errors import OutputError, ParameterError, RepulsionPakError
from .params import Params, params_from_dict
from .types import Container, Element

#: Columns of ``results.csv`` before the one column per ``--set`` name (DESIGN.md).
CSV_COLUMNS = ("seed", "file", "area_fraction", "gap_median", "scp_half_gap", "overlap_area",
               "iterations", "seconds", "error")

#: Upper bound on the number of jobs of one batch (seeds × settings).
MAX_JOBS = 100_000

#: Longer side of a contact-sheet thumbnail, pixels.
THUMBNAIL_PX = 240


class JobFailed(RepulsionPakError):
    """A job of a batch failed; ``exit_code`` is the one its own error would have had."""

    def __init__(self, message: str, exit_code: int = 1):
        super().__init__(message)
        self.exit_code = exit_code


# --------------------------------------------------------------------------- jobs


@dataclass(frozen=True, eq=False)
class BatchInputs:
    """The parsed inputs every job of a batch shares (sent to each worker once)."""

    container: Container
    elements: tuple[Element, ...]
    secondary: tuple[Element, ...] = ()


@dataclass(frozen=True)
class Job:
    """One packing of a batch.

    ``params`` is complete (seed and gap set, validated); ``setting`` holds the
    ``--set`` values of this job as ``((name as given, value), ...)``; ``name`` is its
    file stem, unique within the batch. ``svg`` / ``thumbnail_px`` / ``scp`` say what the
    worker returns: the SVG text, a thumbnail PNG of that longer side (0: none), the SCP
    curve (needed for ``scp_half_gap``; the raster is the slow part of measuring).
    """

    seed: int
    params: Params
    setting: tuple[tuple[str, object], ...] = ()
    name: str = ""
    svg: bool = True
    thumbnail_px: int = THUMBNAIL_PX
    scp: bool = True


@dataclass
class JobResult:
    """What a worker returns for a :class:`Job` (picklable, no files).

    ``metrics`` is the :func:`~repulsionpak.evaluate.evaluate` dict (None when the job
    failed); ``error`` is one line naming the problem, ``exit_code`` the CLI code of that
    error (0 on success). ``worker`` is ``host:pid`` of the process that ran the task,
    ``started`` / ``finished`` its wall clock (``time.time()``), ``seconds`` the task's
    own duration (pack, measure, SVG text, thumbnail).
    """

    name: str
    seed: int
    setting: tuple[tuple[str, object], ...] = ()
    metrics: dict | None = None
    iterations: dict = field(default_factory=dict)
    seconds: float = 0.0
    svg: str | None = None
    thumbnail: bytes | None = None
    error: str | None = None
    exit_code: int = 0
    worker: str = ""
    started: float = 0.0
    finished: float = 0.0

    @property
    def ok(self) -> bool:
        return self.error is None and self.metrics is not None

    @property
    def scp_half_gap(self) -> float | None:
        v = None if self.metrics is None else self.metrics.get("scp_at_half_gap")
        return None if v is None or not math.isfinite(v) else float(v)


def parse_seeds(text: str, option: str = "--seeds") -> list[int]:
    """``"A-B"`` (inclusive), ``"N"`` or a comma list of both → sorted distinct seeds."""
    seeds: set[int] = set()
    for part in str(text).split(","):
        part = part.strip()
        m = re.fullmatch(r"(\d+)(?:\s*-\s*(\d+))?", part)
        if not m:
            raise ParameterError(f"{option} {text!r}: expected A-B (e.g. 1-8), a seed, or a comma list of them")
        a = int(m.group(1))
        b = int(m.group(2)) if m.group(2) is not None else a
        if b < a:
            raise ParameterError(f"{option} {part!r}: the range is empty (end before start)")
        if b >= 2**63:
            raise ParameterError(f"{option} {part!r}: seeds must be below 2**63")
        if b - a + 1 + len(seeds) > MAX_JOBS:
            raise ParameterError(f"{option} {text!r}: more than {MAX_JOBS} seeds")
        seeds.update(range(a, b + 1))
    return sorted(seeds)


def _parse_value(text: str):
    """A ``--set`` value: a TOML scalar (``10``, ``0.5``, ``1e3``, ``true``) or ``none``;
    anything else stays a string so the strict config check can name the type it wants."""
    if text.lower() in ("none", "null"):
        return None
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, KeyError):
        return text


def parse_set(spec: str) -> tuple[str, list]:
    """``"SECTION.NAME=V1,V2,..."`` → ``(name, [values])``; errors name ``--set``."""
    name, eq, values = str(spec).partition("=")
    name = name.strip()
    if not eq or not name:
        raise ParameterError(f"--set {spec!r}: expected SECTION.NAME=V1,V2,... (e.g. sim.k_edge=10,250)")
    parts = name.split(".")
    if len(parts) > 2 or not all(re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", p) for p in parts):
        raise ParameterError(f"--set {spec!r}: {name!r} is not a parameter name (SECTION.NAME or a "
                             "top-level name; see `repulsionpak params`)")
    if name == "seed":
        raise ParameterError("--set seed=...: give the seeds with --seeds")
    texts = [v.strip() for v in values.split(",")]
    if any(not t for t in texts):
        raise ParameterError(f"--set {spec!r}: empty value (give V1,V2,... without empty entries)")
    parsed = [_parse_value(t) for t in texts]
    seen: list = []
    for t, v in zip(texts, parsed):
        if any(type(v) is type(w) and v == w for w in seen):
            raise ParameterError(f"--set {name}: the value {t} is given twice")
        seen.append(v)
    return name, parsed


def _as_dict(name: str, value) -> dict:
    section, _, key = name.rpartition(".")
    return {section: {key: value}} if section else {key: value}


def _merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _fmt_value(v) -> str:
    if v is None:
        return "none"
    if isinstance(v, bool):
        return "true" if v else "false"
    text = repr(v) if isinstance(v, float) else str(v)
    return text[:-2] if isinstance(v, float) and text.endswith(".0") else text


def make_jobs(base: Params, seeds: Sequence[int], settings: Sequence[tuple[str, list]] = (),
              thumbnail_px: int = THUMBNAIL_PX) -> list[Job]:
    """One job per seed × combination of setting values (seeds outermost, settings in
    the order given), each with validated parameters.

    Every value goes through :func:`repulsionpak.params.params_from_dict`, so unknown
    names get a "did you mean" and wrong types or ranges a :class:`ParameterError`
    naming ``--set`` before any work starts.
    """
    names = [n for n, _ in settings]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ParameterError(f"--set {sorted(dup)[0]} is given more than once; list its values in one --set")
    n_combos = math.prod(len(v) for _, v in settings) if settings else 1
    if n_combos * max(len(seeds), 1) > MAX_JOBS:
        raise ParameterError(f"--seeds × --set make {n_combos * len(seeds)} jobs, more than {MAX_JOBS}")
    for name, values in settings:  # each name and value alone first: errors name that --set
        for v in values:
            params_from_dict(_as_dict(name, v), source=f"--set {name}={_fmt_value(v)}", base=base)
    combos = []
    for values in itertools.product(*(v for _, v in settings)):
        pairs = tuple(zip(names, values))
        data: dict = {}
        for n, v in pairs:
            data = _merge(data, _as_dict(n, v))
        where = "--set " + ", ".join(f"{n}={_fmt_value(v)}" for n, v in pairs) if pairs else "parameters"
        combos.append((pairs, params_from_dict(data, source=where, base=base) if pairs else base.validate()))
    width = len(str(max(seeds))) if seeds else 1
    jobs, used = [], set()
    for seed in seeds:
        for pairs, p in combos:
            stem = f"seed-{seed:0{width}d}" + "".join(
                "_" + re.sub(r"[^A-Za-z0-9.+-]", "_", f"{n}-{_fmt_value(v)}") for n, v in pairs)
            name, k = stem, 1
            while name in used:  # two values that read the same once made file-safe
                k += 1
                name = f"{stem}~{k}"
            used.add(name)
            jobs.append(Job(seed=seed, params=dataclasses.replace(p, seed=seed), setting=pairs,
                            name=name, thumbnail_px=thumbnail_px))
    return jobs


# --------------------------------------------------------------------------- the worker side


def _cancel_probe(interval: float = 0.5) -> Callable[[], bool] | None:
    """On a Dask worker: a ``should_stop()`` that turns true once the running task was
    cancelled (the client cancelled its future or went away), looked up at most every
    ``interval`` seconds in the worker's own state (no network round trip). None when
    not running as a Dask task."""
    try:
        from distributed import get_worker

        worker = get_worker()
        key = worker.get_current_task()
    except (ImportError, ValueError, AttributeError):
        return None
    last, stopped = [0.0], [False]

    def should_stop() -> bool:
        now = time.monotonic()
        if not stopped[0] and now - last[0] >= interval:
            last[0] = now
            try:
                ts = worker.state.tasks.get(key)
                stopped[0] = ts is None or ts.state in ("cancelled", "released", "forgotten")
            except Exception:  # noqa: BLE001  (internal state changed shape: never stop)
                stopped[0] = False
        return stopped[0]

    return should_stop


def run_job(inputs: BatchInputs, job: Job) -> JobResult:
    """Run one job (on a worker): pack, measure, SVG text, thumbnail.

    Never raises for a failing packing: the error is returned in the result (one line,
    with the exit code the CLI gives that error). With ``sim.threads`` automatic (0) the
    simulation runs on one thread: a batch already keeps every core busy with one task
    per worker thread.
    """
    from .evaluate import evaluate
    from .pack import pack
    from .packing_output import invariants, packing_svg_text

    started, t0 = time.time(), time.perf_counter()
    res = JobResult(name=job.name, seed=job.seed, setting=job.setting,
                    worker=f"{socket.gethostname()}:{os.getpid()}", started=started)
    try:
        params = job.params
        if params.sim.threads == 0:
            params = dataclasses.replace(params, sim=dataclasses.replace(params.sim, threads=1))
        packing = pack(inputs.container, inputs.elements, params, secondary=inputs.secondary,
                       should_stop=_cancel_probe())
        res.iterations = dict(packing.iterations)
        if packing.partial:
            raise JobFailed("cancelled before it finished", 130)
        metrics = evaluate(inputs.container, packing.placed, packing.gap, with_scp=job.scp)
        if job.svg:
            res.svg = packing_svg_text(packing, metrics, invariants(packing, metrics), path=f"{job.name}.svg")
        if job.thumbnail_px:
            from .io.png import png_bytes

            res.thumbnail = png_bytes(inputs.container, packing.placed, size_px=job.thumbnail_px)
        res.metrics = metrics
    except RepulsionPakError as exc:
        res.error, res.exit_code = _one_line(exc), getattr(exc, "exit_code", 1)
    except Exception as exc:  # noqa: BLE001  (one job's bug must not stop the batch)
        res.error, res.exit_code = _one_line(exc), 1
    res.seconds = time.perf_counter() - t0
    res.finished = time.time()
    return res


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or "(no message)"
    return text if isinstance(exc, JobFailed) else f"{type(exc).__name__}: {text}"


# --------------------------------------------------------------------------- the client side


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT while worker processes are started: they inherit the disposition, so
    Ctrl-C in a terminal reaches only the client, which then cancels cleanly."""
    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: nothing to protect
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


@contextlib.contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None,
                timeout: float = 10.0) -> Iterator:
    """A :class:`distributed.Client`: on a new :class:`~distributed.LocalCluster` of
    ``workers`` single-threaded worker processes (default: one per core), or on the
    running scheduler at ``scheduler`` (``tcp://HOST:PORT``). Closed on exit."""
    from distributed import Client, LocalCluster

    if scheduler is not None:
        if workers is not None:
            raise ParameterError("--workers sizes the local cluster; with --scheduler, start the "
                                 "workers with `dask worker`")
        if not re.fullmatch(r"(tcp|tls|inproc|ws|wss)://\S+", scheduler):
            raise ParameterError(f"--scheduler {scheduler!r}: expected an address like tcp://HOST:PORT")
        try:
            client = Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError) as exc:
            raise RepulsionPakError(f"--scheduler {scheduler}: cannot connect ({exc}); is `dask scheduler` "
                                    "running there?") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = (os.cpu_count() or 1) if workers is None else workers
    if n < 1:
        raise ParameterError(f"--workers must be >= 1, got {n}")
    with _sigint_ignored():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
    try:
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


def run_jobs(client, inputs: BatchInputs, jobs: Sequence[Job],
             on_result: Callable[[int, JobResult], None] | None = None) -> tuple[list[JobResult | None], bool]:
    """Submit one task per job and collect the results as they complete.

    ``on_result(i, result)`` is called on the client for job ``i`` as soon as it
    finishes (in completion order). A task that dies with its worker becomes a failed
    result. Ctrl-C (KeyboardInterrupt) cancels the remaining tasks (running ones stop
    within a second) and returns what finished.

    Returns ``(results, interrupted)``: ``results[i]`` belongs to ``jobs[i]`` (None if
    cancelled before it finished).
    """
    from distributed import as_completed

    results: list[JobResult | None] = [None] * len(jobs)
    if not jobs:
        return results, False
    futures = []
    try:
        data = client.scatter(inputs, broadcast=True, hash=False)
        tag = uuid.uuid4().hex[:12]
        futures = [client.submit(run_job, data, job, key=f"repulsionpak-{tag}-{i}", pure=False)
                   for i, job in enumerate(jobs)]
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            i = index[fut.key]
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001  (the task or its worker died)
                job = jobs[i]
                res = JobResult(name=job.name, seed=job.seed, setting=job.setting,
                                error=f"task failed: {_one_line(exc)}", exit_code=1)
            fut.release()
            results[i] = res
            if on_result is not None:
                on_result(i, res)
    except KeyboardInterrupt:
        with contextlib.suppress(Exception):
            client.cancel(futures)
        return results, True
    return results, False


# --------------------------------------------------------------------------- outputs


def write_svg(outdir: Path, result: JobResult) -> str:
    """Write a finished job's SVG as ``OUTDIR/NAME.svg`` (atomically); returns the file name."""
    from .io.svg_write import atomic_write_bytes

    fname = f"{result.name}.svg"
    atomic_write_bytes(Path(outdir) / fname, result.svg.encode("utf-8"))
    return fname


def best_result(results: Sequence[JobResult | None]) -> JobResult | None:
    """The finished job with the lowest ``scp_half_gap`` (the first of equals)."""
    ok = [r for r in results if r is not None and r.ok and r.scp_half_gap is not None]
    return min(ok, key=lambda r: r.scp_half_gap) if ok else None


def _num(x, fmt: str = ".6g") -> str:
    return "" if x is None else format(float(x), fmt)


def results_csv(jobs: Sequence[Job], results: Sequence[JobResult | None], set_names: Sequence[str],
                files: dict[int, str]) -> str:
    """The ``results.csv`` text: :data:`CSV_COLUMNS` then one column per ``--set`` name,
    one row per job in job order; jobs that never finished say so in ``error``."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([*CSV_COLUMNS, *set_names])
    for i, job in enumerate(jobs):
        r = results[i]
        setting = dict(job.setting)
        m = (r.metrics if r is not None else None) or {}
        gap = m.get("gap") or {}
        w.writerow([
            job.seed, files.get(i, ""),
            _num(m.get("area_fraction")), _num(gap.get("median")), _num(m.get("scp_at_half_gap")),
            _num(m.get("overlap_area")),
            "" if r is None or not r.iterations else sum(r.iterations.values()),
            "" if r is None else _num(r.seconds, ".3f"),
            "cancelled: the batch was interrupted" if r is None else (r.error or ""),
            *(_fmt_value(setting[n]) for n in set_names),
        ])
    return buf.getvalue()


def _label(job: Job, r: JobResult | None, max_chars: int) -> str:
    parts = [f"seed {job.seed}"] + [f"{n.rpartition('.')[2]}={_fmt_value(v)}" for n, v in job.setting]
    if r is None:
        parts.append("cancelled")
    elif not r.ok:
        parts.append("failed")
    elif r.scp_half_gap is not None:
        parts.append(f"Q {r.scp_half_gap:.3f}")
    text = "  ".join(parts)
    return text if len(text) <= max_chars else text[: max(1, max_chars - 1)] + "…"


def write_summary(outdir: Path, jobs: Sequence[Job], results: Sequence[JobResult | None],
                  set_names: Sequence[str], files: dict[int, str], best_svg: str | None) -> JobResult | None:
    """Write ``results.csv``, ``best.svg`` (the lowest ``scp_half_gap``, when any job
    finished) and ``contact-sheet.png`` (one tile per job, in job order; failed and
    cancelled jobs are empty tiles saying so). Returns the best result."""
    from .io.png import contact_sheet_png
    from .io.svg_write import atomic_write_bytes

    outdir = Path(outdir)
    atomic_write_bytes(outdir / "results.csv", results_csv(jobs, results, set_names, files).encode("utf-8"))
    best = best_result(results)
    if best is not None and best_svg is not None:
        atomic_write_bytes(outdir / "best.svg", best_svg.encode("utf-8"))
    tile = max([j.thumbnail_px for j in jobs] + [64])
    max_chars = int(tile / 6.2)
    tiles = [None if r is None or not r.ok else r.thumbnail for r in results]
    labels = [_label(j, r, max_chars) for j, r in zip(jobs, results)]
    atomic_write_bytes(outdir / "contact-sheet.png", contact_sheet_png(tiles, labels, tile))
    return best


# --------------------------------------------------------------------------- one call


def check_outdir(outdir: Path, inputs: Sequence[Path]) -> None:
    """Refuse an output directory that is a file or that holds the inputs' own SVGs
    (an element directory would read the packings back as elements next time)."""
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise OutputError(f"{outdir}: exists and is not a directory; -o names the output directory")
    for inp in map(Path, inputs):
        with contextlib.suppress(OSError):
            if inp.is_dir() and inp.resolve() == outdir.resolve():
                raise OutputError(f"{outdir}: is the input directory {inp}; choose another output directory")
            if inp.is_file() and inp.parent.resolve() == outdir.resolve() and (
                    inp.name in ("best.svg", "results.csv", "contact-sheet.png") or inp.name.startswith("seed-")):
                raise OutputError(f"{outdir}: would overwrite the input {inp}; choose another output directory")


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


def _tolerance(jobs: Sequence[Job]) -> float | None:
    """Curve flattening tolerance of the shared read: the finest any job asks for (the
    same as ``repulsionpak pack`` when all jobs share one gap)."""
    tols = [None if j.params.gap is None else j.params.preprocess.flatten_tolerance * j.params.gap for j in jobs]
    return None if not tols or any(t is None for t in tols) else min(tols)


def run_batch(container: Path, elements: Sequence[Path], outdir: Path, seeds: str,
              sets: Sequence[str] = (), base: Params = Params(), secondary: Sequence[Path] = (),
              workers: int | None = None, scheduler: str | None = None,
              on_start: Callable[[int, object], None] | None = None,
              on_result: Callable[[int, Job, JobResult], None] | None = None,
              thumbnail_px: int = THUMBNAIL_PX) -> BatchSummary:
    """Everything ``repulsionpak batch`` does: parse ``--seeds`` and ``--set``, read the
    inputs once, run the jobs on Dask, write ``OUTDIR/*.svg`` as results arrive, then
    ``results.csv``, ``best.svg`` and ``contact-sheet.png``.

    ``on_start(n_jobs, client)`` is called once the cluster is up, ``on_result(i, job,
    result)`` per finished job. A Ctrl-C (KeyboardInterrupt) cancels the rest and still
    writes the outputs of what finished (``summary.interrupted``).
    """
    from .io import load_container, load_elements
    from .pack import default_gap

    t0 = time.perf_counter()
    check_outdir(outdir, [container, *elements, *secondary])
    seed_list = parse_seeds(seeds)
    settings = [parse_set(s) for s in sets]
    jobs = make_jobs(base, seed_list, settings, thumbnail_px)  # all parameter errors before any work
    cont = load_container(container, tolerance=_tolerance(jobs))
    if base.gap is None:
        jobs = make_jobs(dataclasses.replace(base, gap=default_gap(cont)), seed_list, settings, thumbnail_px)
    inputs = BatchInputs(cont, tuple(load_elements(list(elements))),
                         tuple(load_elements(list(secondary))) if secondary else ())
    outdir = Path(outdir)
    files: dict[int, str] = {}
    best: list = [None, None]  # (scp_half_gap, svg text) of the best so far

    def collect(i: int, r: JobResult) -> None:
        if r.ok and r.svg is not None:
            files[i] = write_svg(outdir, r)
            q = r.scp_half_gap
            if q is not None and (best[0] is None or q < best[0]):
                best[0], best[1] = q, r.svg
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


__all__ = ["BatchInputs", "BatchSummary", "CSV_COLUMNS", "Job", "JobFailed", "JobResult", "best_result",
           "dask_client", "make_jobs", "parse_seeds", "parse_set", "results_csv", "run_batch", "run_job",
           "run_jobs", "write_summary"]
