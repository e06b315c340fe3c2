"""What the commands show while they work, and how they take signals: progress bars on a
terminal (rich, on stderr; silent when stderr is not a TTY) and the stop flags of Ctrl-C and
SIGTERM."""

from __future__ import annotations

import contextlib
import signal
import sys

import typer


class _Progress:
    """Live progress on a terminal (rich), silent when stderr is not a TTY."""

    def __init__(self, enabled: bool, counters: bool = True):
        self.enabled = enabled and sys.stderr.isatty()
        self.counters = counters  # the simulation's iteration, area and element count
        self._live = None
        self._task = None

    def __enter__(self):
        if self.enabled:
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            # the meshes' area (art and the skins around it): the art's own, in the
            # summary, is smaller (0.93 here against 0.79 there read as a failure)
            counters = [TextColumn("it {task.fields[it]:>6}  skins' area {task.fields[area]:.3f}  "
                                   "elements {task.fields[n]}")] if self.counters else []
            self._live = Progress(TextColumn("[bold]{task.fields[phase]}"), BarColumn(), *counters,
                                  TimeElapsedColumn(), transient=True,
                                  console=__import__("rich.console").console.Console(stderr=True))
            self._live.__enter__()
            self._task = self._live.add_task("pack", total=None, phase="start", it=0, area=0.0, n=0)
        return self

    def __call__(self, snap) -> None:
        if self._live is not None:
            self._live.update(self._task, phase=snap.phase, it=snap.iteration,
                              area=snap.area_fraction, n=snap.n_elements)

    def stage(self, name: str) -> None:
        """A stage without snapshots (the art's map, the verification, writing ...): its
        name replaces the phase's, the clock goes on."""
        if self._live is not None:
            self._live.update(self._task, phase=name)

    def __exit__(self, *exc):
        if self._live is not None:
            self._live.__exit__(*exc)


class _FrameProgress:
    """The movie's frames being drawn and encoded (a bar on a terminal, after the
    simulation's bar has gone)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled and sys.stderr.isatty()
        self._live = self._task = None

    def __enter__(self):
        if self.enabled:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self._live = Progress(TextColumn("[bold]movie"), BarColumn(), MofNCompleteColumn(),
                                  TextColumn("frames"), TimeElapsedColumn(), transient=True,
                                  console=Console(stderr=True))
            self._live.__enter__()
            self._task = self._live.add_task("movie", total=None)
        return self

    def __call__(self, done: int, total: int) -> None:
        if self._live is not None:
            self._live.update(self._task, total=total, completed=done)

    def __exit__(self, *exc):
        if self._live is not None:
            self._live.__exit__(*exc)


class _StopFlag:
    """SIGINT/SIGTERM handler: the first signal asks the simulation to stop after the
    current iteration (a partial packing is then written), or, once the simulation is
    over, the verification to end its repair rounds (what still violates is dropped); a
    second one aborts (Ctrl-C twice, or ``kill`` twice). A signal before the simulation
    first asks whether to stop (while the inputs are read, meshed and placed: nothing to
    write yet) aborts at once."""

    def __init__(self):
        self.stop = False
        self.polled = False  # the simulation has started asking
        self._old = {}

    def __enter__(self):
        def handler(signum, frame):
            if self.stop or not self.polled:
                raise KeyboardInterrupt
            self.stop = True

        for sig in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(ValueError):  # not in the main thread
                self._old[sig] = signal.signal(sig, handler)
        return self

    def __call__(self) -> bool:
        self.polled = True
        return self.stop

    def at_stage(self, name: str) -> None:
        """While the art is mapped there is no partial result to stop at (it is what any
        packing needs written): a signal then aborts at once, as before the simulation (a
        first SIGTERM was ignored for minutes on art of 1,000 subpaths). The verification
        polls again: a signal there ends its repair rounds."""
        if name == "mapping the art":
            self.polled = False

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            signal.signal(sig, old)


class _BatchProgress:
    """Progress of a batch: a bar on a terminal, else one line per finished job."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.tty = enabled and sys.stderr.isatty()
        self._live = None
        self._task = None
        self.n = self.done = self.failed = 0

    def start(self, n_jobs: int, client) -> None:
        self.n = n_jobs
        if not self.enabled:
            return
        workers = client.scheduler_info().get("workers", {})
        typer.echo(f"repulsionpak: {n_jobs} packings on {len(workers)} Dask workers ({client.scheduler.address})",
                   err=True)
        if not workers:
            typer.echo("repulsionpak: no worker yet: start some with `dask worker ADDRESS`", err=True)
        if self.tty:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, \
                TimeRemainingColumn

            self._live = Progress(TextColumn("[bold]batch"), BarColumn(), MofNCompleteColumn(),
                                  TextColumn("{task.fields[failed]} failed"), TimeElapsedColumn(),
                                  TimeRemainingColumn(), transient=True, console=Console(stderr=True))
            self._live.__enter__()
            self._task = self._live.add_task("batch", total=n_jobs, failed=0)

    def __call__(self, i: int, job, result) -> None:
        self.done += 1
        self.failed += not result.ok
        if self.enabled:
            for w in result.warnings:
                line = f"repulsionpak: warning: {job.name}: {w}"
                if self._live is not None:
                    self._live.console.print(line, markup=False, highlight=False)
                else:
                    typer.echo(line, err=True)
        if self._live is not None:
            self._live.update(self._task, advance=1, failed=self.failed)
        elif self.enabled:
            m = result.metrics or {}
            what = (f"area {m['area_fraction']:.3f}, Q_s(gap/2) {result.scp_half_gap:.4f}"
                    if result.ok and result.scp_half_gap is not None else f"failed: {result.error}")
            typer.echo(f"[{self.done}/{self.n}] {job.name}: {what} ({result.seconds:.1f} s)", err=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._live is not None:
            self._live.__exit__(*exc)


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """SIGTERM ends a batch like Ctrl-C does (cancel, write what finished, exit 130)."""
    def handler(signum, frame):
        raise KeyboardInterrupt

    try:
        old = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not in the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)
