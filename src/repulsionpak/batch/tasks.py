"""The Dask side of a batch: the task every worker runs (:func:`run_job`: pack, measure,
SVG text, thumbnail — never a file), the cluster (:func:`dask_client`) and the client
loop that submits the jobs and collects their results (:func:`run_jobs`)."""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
import re
import signal
import socket
import time
import uuid
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field

from ..errors import ParameterError, RepulsionPakError
from ..types import Container, Element
from .jobs import Job


class JobFailed(RepulsionPakError):
    """A job of a batch failed; ``exit_code`` is the one its own error would have had."""

    def __init__(self, message: str, exit_code: int = 1):
        super().__init__(message)
        self.exit_code = exit_code


@dataclass(frozen=True, eq=False)
class BatchInputs:
    """The parsed inputs every job of a batch shares (sent to each worker once)."""

    container: Container
    elements: tuple[Element, ...]
    secondary: tuple[Element, ...] = ()


@dataclass
class JobResult:
    """What a worker returns for a :class:`Job` (picklable, no files).

    ``metrics`` is the :func:`~repulsionpak.measure.evaluate` dict (None when the job
    failed, or measured but breaking a promise: then ``error`` says so and ``exit_code``
    is 6); ``error`` is one line naming the problem, ``exit_code`` the CLI code of that
    error (0 on success); ``warnings`` the messages ``pack`` warned with. ``worker`` is
    ``host:pid`` of the process that ran the task, ``started`` / ``finished`` its wall clock (``time.time()``), ``seconds`` the task's
    own duration (pack, measure, SVG text, thumbnail) and ``cpu_seconds`` the CPU time
    of the thread that ran it (unlike ``seconds``, not stretched by other load).
    """

    name: str
    seed: int
    setting: tuple[tuple[str, object], ...] = ()
    metrics: dict | None = None
    iterations: dict = field(default_factory=dict)
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    warnings: list[str] = field(default_factory=list)
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
    from ..pack import pack

    started, t0, c0 = time.time(), time.perf_counter(), time.thread_time()
    res = JobResult(name=job.name, seed=job.seed, setting=job.setting,
                    worker=f"{socket.gethostname()}:{os.getpid()}", started=started)
    try:
        params = job.params
        if params.sim.threads == 0:
            params = dataclasses.replace(params, sim=dataclasses.replace(params.sim, threads=1))
        with warnings.catch_warnings(record=True) as caught:  # returned to the client, not the worker's log
            warnings.simplefilter("always")
            packing = pack(inputs.container, inputs.elements, params, secondary=inputs.secondary,
                           should_stop=_cancel_probe())
        res.warnings = [" ".join(str(w.message).split()) for w in caught]
        hiding = packing.paint_warning()  # --container-paint as-drawn over art of its colour
        if hiding is not None:
            res.warnings.append(" ".join(hiding.split()))
        res.iterations = dict(packing.iterations)
        if packing.partial:
            raise JobFailed("cancelled before it finished", 130)
        metrics = packing.metrics(distortion=False, scp=job.scp)
        checks = packing.checks()
        if job.svg:
            res.svg = packing.svg_text(path=f"{job.name}.svg")
        if job.thumbnail_px:
            res.thumbnail = packing.png_bytes(job.thumbnail_px)
        res.metrics = metrics
        if not checks["ok"]:  # written for inspection, like `pack` (exit code 6), never the best
            broken = sorted(k[:-3] for k, v in checks.items() if k.endswith("_ok") and v is False)
            res.error = ("the packing breaks a promise" + (f" ({', '.join(broken)})" if broken else "")
                         + "; see the invariants in its SVG metadata")
            res.exit_code = 6
    except RepulsionPakError as exc:
        res.error, res.exit_code = _one_line(exc), getattr(exc, "exit_code", 1)
    except Exception as exc:  # noqa: BLE001  (one job's bug must not stop the batch)
        res.error, res.exit_code = _one_line(exc), 1
    res.seconds = time.perf_counter() - t0
    res.cpu_seconds = time.thread_time() - c0
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


def require_dask(what: str = "running packings on Dask") -> None:
    """Raise a one-line :class:`ParameterError` naming the install command when Dask
    (the optional extra ``batch``: ``dask`` and ``distributed``) is missing."""
    try:
        import dask  # noqa: F401
        import distributed  # noqa: F401
    except ImportError:
        raise ParameterError(f"{what} needs Dask: pip install 'repulsionpak[batch]'") from None


@contextlib.contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None,
                timeout: float = 10.0) -> Iterator:
    """A :class:`distributed.Client`: on a new :class:`~distributed.LocalCluster` of
    ``workers`` single-threaded worker processes (default: one per core), or on the
    running scheduler at ``scheduler`` (``tcp://HOST:PORT``). Closed on exit."""
    require_dask()
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
    # the workers' own log lines stay quiet below CRITICAL: every job's outcome reaches the
    # user through its result (progress line, the CSV's error column, a task lost with its
    # worker), and what distributed logs at ERROR are shutdown races — on Ctrl-C under load
    # a worker's heartbeat to the closing scheduler fails and logger.exception printed its
    # traceback on the user's terminal
    with _sigint_ignored():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.CRITICAL)
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


__all__ = ["BatchInputs", "JobFailed", "JobResult", "dask_client", "require_dask", "run_job", "run_jobs"]
